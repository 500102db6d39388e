//! The robot's command stream: the 1 kHz twist decimated to the JACO2's
//! 100 Hz Cartesian-velocity stream (its DSP cycles every 10 ms; faster
//! fills its buffer and it keeps moving after commands stop).
//!
//! Each command is the mean velocity over its 10 ms window (trapezoidal
//! over the 1 kHz samples). An arm that executes it for the next 10 ms
//! travels exactly what the core's pose estimate travelled in the window:
//! it retraces the core's path 10 ms late and stops where the core stops.

use crate::control::Tick;

/// Ticks per arm command (10 ms).
pub const ARM_STREAM_PERIOD_TICKS: u32 = 10;

/// With no new command for this many ticks (two of its 10 ms cycles) the
/// arm has stopped on its own: the JACO2 executes each command for one
/// cycle and stands still when its stream stops.
pub const ARM_STOPS_AFTER_TICKS: u64 = 2 * ARM_STREAM_PERIOD_TICKS as u64;

/// One Cartesian velocity command for the arm, held for 10 ms. `Copy`.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct ArmCommand {
    /// Sequence number, from 0.
    pub seq: u64,
    /// Tick at which the command was produced (end of its window).
    pub tick: Tick,
    /// Linear velocity, m/s, base frame.
    pub linear: [f64; 3],
    /// Angular velocity, rad/s, base frame.
    pub angular: [f64; 3],
    /// Finger velocity, units/s (positive closes).
    pub fingers: f64,
}

impl ArmCommand {
    /// Whether the command moves nothing.
    pub fn is_zero(&self) -> bool {
        self.linear == [0.0; 3] && self.angular == [0.0; 3] && self.fingers == 0.0
    }
}

/// Accumulates the 1 kHz twist and emits one [`ArmCommand`] every
/// [`ARM_STREAM_PERIOD_TICKS`]. RT-safe.
#[derive(Debug, Clone, Default)]
pub struct Decimator {
    sum: [f64; 7],
    count: u32,
    seq: u64,
}

impl Decimator {
    /// Adds one tick's mean velocity (trapezoid of the previous and new
    /// samples: `[vx, vy, vz, wx, wy, wz, fingers]`); returns a command at
    /// the end of each window.
    pub fn push(&mut self, now: Tick, mean: [f64; 7]) -> Option<ArmCommand> {
        for (s, m) in self.sum.iter_mut().zip(mean) {
            *s += m;
        }
        self.count += 1;
        if self.count < ARM_STREAM_PERIOD_TICKS {
            return None;
        }
        let n = f64::from(self.count);
        let s = self.sum.map(|v| v / n);
        let command = ArmCommand {
            seq: self.seq,
            tick: now,
            linear: [s[0], s[1], s[2]],
            angular: [s[3], s[4], s[5]],
            fingers: s[6],
        };
        *self = Decimator {
            seq: self.seq + 1,
            ..Decimator::default()
        };
        Some(command)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_command_per_ten_ticks_with_the_window_mean() {
        let mut d = Decimator::default();
        let mut out = Vec::new();
        for t in 0..30u64 {
            let v = t as f64;
            if let Some(c) = d.push(t, [v, 0.0, 0.0, 0.0, 0.0, 0.0, -v]) {
                out.push(c);
            }
        }
        assert_eq!(out.len(), 3);
        assert_eq!((out[0].seq, out[0].tick, out[0].linear[0]), (0, 9, 4.5));
        assert_eq!((out[2].seq, out[2].tick, out[2].fingers), (2, 29, -24.5));
    }
}
