//! The safety monitor: checks the core's output tick by tick against what
//! the motion layer promises, independently of how it keeps the promise.
//! Used by the property tests, the `core_stream` fuzz target and the
//! motion tests.
//!
//! At every tick: every commanded value finite; the tool inside the
//! workspace by the stop margin as a normal distance; the tool inside its
//! orientation limits; the speed, acceleration and jerk *vectors* (from
//! the 1 kHz commands) within the configured limits (relative 1e-9); the
//! fingers inside their travel and limits; and after every release, fault
//! or return to detection mode with no breath held since, still within the
//! stopping time.

use std::fmt;

use nalgebra::Vector3;

use crate::control::core_config::CoreConfig;
use crate::control::mode::{Direction, ModeState};
use crate::control::motion::orientation::{OrientationLimits, tilt_and_twist};
use crate::control::motion::stream::ARM_STOPS_AFTER_TICKS;
use crate::control::motion::workspace;
use crate::control::motion::{CYCLE_S, MotionOutput};
use crate::control::tick::TickOutput;

/// Relative tolerance on every limit.
pub const RELATIVE: f64 = 1e-9;
/// Absolute allowance on the stop margin, m, and the orientation limits,
/// rad (a nanometre, a nanoradian).
pub const ABSOLUTE: f64 = 1e-9;

/// A broken promise, with the step (call) it happened on.
#[derive(Debug, Clone, PartialEq)]
pub struct Violation {
    /// Steps since the monitor started, from 0.
    pub step: u64,
    /// The core's tick.
    pub tick: u64,
    /// What, in words, with the figures.
    pub what: String,
}

impl fmt::Display for Violation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "step {} (tick {}): {}", self.step, self.tick, self.what)
    }
}

/// The longest a stop may take, in steps (1 ms ticks), over the linear,
/// angular and finger groups: from full acceleration near full speed the
/// acceleration first ramps to zero (A/J), then braking from full speed
/// takes v/A + A/J; plus two ticks.
pub fn stop_steps(config: &CoreConfig) -> u64 {
    let m = config.motion();
    let time = |v: f64, a: f64, j: f64| v / a + 2.0 * a / j;
    let worst = time(
        m.linear_speed_mps,
        m.linear_acceleration_mps2,
        m.linear_jerk_mps3,
    )
    .max(time(
        m.angular_speed_radps,
        m.angular_acceleration_radps2,
        m.angular_jerk_radps3,
    ))
    .max(time(m.finger_speed, m.finger_acceleration, m.finger_jerk));
    (worst / CYCLE_S).ceil() as u64 + 2
}

/// Watches one pipeline's outputs, in order.
#[derive(Debug, Clone)]
pub struct SafetyMonitor {
    config: CoreConfig,
    orientation: OrientationLimits,
    /// The last two steps' `[linear, angular, fingers]` velocities.
    history: [Option<[Vector3<f64>; 3]>; 2],
    step: u64,
    /// Steps that stopping may take, worst group.
    stop_steps: u64,
    /// A release, fault or return to detection: must be still by then
    /// unless a breath is held again first.
    still_by: Option<u64>,
    previous: Option<(Direction, ModeState, bool)>,
    /// The last tick seen.
    last_tick: Option<u64>,
}

impl SafetyMonitor {
    /// A monitor for a pipeline built from `config`, at its home pose.
    pub fn new(config: &CoreConfig) -> Self {
        let w = config.workspace();
        SafetyMonitor {
            config: config.clone(),
            orientation: OrientationLimits {
                home: config.home().pose().rotation,
                max_tilt_rad: w.max_tilt_rad,
                max_twist_rad: w.max_twist_rad,
            },
            history: [None; 2],
            step: 0,
            stop_steps: stop_steps(config),
            still_by: None,
            previous: None,
            last_tick: None,
        }
    }

    /// Checks one step's output.
    pub fn check(&mut self, out: &TickOutput) -> Result<(), Violation> {
        self.check_gap(out);
        let result = self
            .check_motion(&out.motion)
            .and_then(|()| self.check_stop(out));
        self.step += 1;
        result.map_err(|what| Violation {
            step: self.step - 1,
            tick: out.tick,
            what,
        })
    }

    /// After a gap of more than two arm cycles (a stalled process) no
    /// command reached the arm, which has stopped on its own: the commands
    /// must start again from rest, within the limits.
    fn check_gap(&mut self, out: &TickOutput) {
        let gap = self.last_tick.map(|t| out.tick.saturating_sub(t));
        self.last_tick = Some(out.tick);
        if gap.is_some_and(|g| g > ARM_STOPS_AFTER_TICKS) {
            let rest = [Vector3::zeros(); 3];
            self.history = [Some(rest), Some(rest)];
        }
    }

    fn check_motion(&mut self, o: &MotionOutput) -> Result<(), String> {
        let m = self.config.motion();
        let w = self.config.workspace();
        let p = o.pose.translation.vector;
        let values = o
            .linear
            .iter()
            .chain(&o.angular)
            .chain([&o.fingers_velocity, &o.fingers])
            .chain(p.iter());
        if !values.copied().all(f64::is_finite) {
            return Err(format!("non-finite output {o:?}"));
        }
        let clearance = workspace::clearance(&p, w);
        if clearance < w.stop_margin_m - ABSOLUTE {
            return Err(format!(
                "tool {:.6} mm from a boundary (margin {} mm) at {:?}",
                clearance * 1e3,
                w.stop_margin_m * 1e3,
                p.as_slice()
            ));
        }
        let (tilt, twist) = tilt_and_twist(&o.pose.rotation, &self.orientation.home);
        if tilt > w.max_tilt_rad + ABSOLUTE || twist.abs() > w.max_twist_rad + ABSOLUTE {
            return Err(format!(
                "tilt {tilt:.9} rad (limit {}), twist {twist:.9} rad (limit ±{})",
                w.max_tilt_rad, w.max_twist_rad
            ));
        }
        if o.fingers < -ABSOLUTE || o.fingers > w.finger_closed + ABSOLUTE {
            return Err(format!("fingers at {}", o.fingers));
        }
        let now = [
            Vector3::from(o.linear),
            Vector3::from(o.angular),
            Vector3::new(o.fingers_velocity, 0.0, 0.0),
        ];
        let limits = [
            (
                "linear",
                m.linear_speed_mps,
                m.linear_acceleration_mps2,
                m.linear_jerk_mps3,
                1e-9,
            ),
            (
                "angular",
                m.angular_speed_radps,
                m.angular_acceleration_radps2,
                m.angular_jerk_radps3,
                1e-9,
            ),
            (
                "finger",
                m.finger_speed,
                m.finger_acceleration,
                m.finger_jerk,
                1e-3,
            ),
        ];
        let dt = CYCLE_S;
        for (g, (name, v_max, a_max, j_max, jerk_slack)) in limits.into_iter().enumerate() {
            let v = now[g];
            if v.norm() > v_max * (1.0 + RELATIVE) {
                return Err(format!("{name} speed {} > {v_max}", v.norm()));
            }
            if let Some(prev) = self.history[1] {
                let a = (v - prev[g]) / dt;
                if a.norm() > a_max * (1.0 + RELATIVE) {
                    return Err(format!("{name} acceleration {} > {a_max}", a.norm()));
                }
                if let Some(before) = self.history[0] {
                    let j = (v - 2.0 * prev[g] + before[g]) / (dt * dt);
                    if j.norm() > j_max * (1.0 + RELATIVE) + jerk_slack {
                        return Err(format!("{name} jerk {} > {j_max}", j.norm()));
                    }
                }
            }
        }
        self.history = [self.history[1], Some(now)];
        Ok(())
    }

    /// Still within the stopping time after a release, a fault or a
    /// return to detection mode, unless a breath moves it again first.
    fn check_stop(&mut self, out: &TickOutput) -> Result<(), String> {
        let now = (out.command.direction, out.command.state, out.faulted);
        if let Some((direction, state, faulted)) = self.previous {
            let released = direction != Direction::Still && now.0 == Direction::Still;
            let to_detection = state != ModeState::Detection && now.1 == ModeState::Detection;
            let fault = !faulted && now.2;
            if (released || to_detection || fault) && self.still_by.is_none() {
                self.still_by = Some(self.step + self.stop_steps);
            }
        }
        self.previous = Some(now);
        if out.command.direction != Direction::Still {
            self.still_by = None; // a breath moves it again
        }
        if let Some(by) = self.still_by
            && self.step >= by
        {
            self.still_by = None;
            if !out.motion.is_still() {
                return Err(format!(
                    "still moving {} steps after a release or fault: {:?}",
                    self.stop_steps,
                    out.motion.velocity()
                ));
            }
        }
        Ok(())
    }
}
