//! A head's motion, and what a head-worn IMU reads of it.
//!
//! Axes (world and sensor alike, the sensor level when the head is):
//! x forward, y to the user's left, z up. The head's orientation is three
//! angles applied yaw, then pitch, then roll (`R = Rz(yaw)·Ry(pitch)·Rx(roll)`,
//! sensor to world), all right-handed:
//!
//! - **pitch** about y: positive is nose *down* (look down),
//! - **roll** about x: positive is the right ear down (tilt right),
//! - **yaw** about z: positive is a turn to the *left*.
//!
//! Each angle is a sum of smooth parts ([`Step`]: a minimum-jerk move
//! that stays; [`Wave`]: a sine under a smooth envelope), so the angle,
//! its rate and its acceleration are known exactly at any time. The
//! sensor then reads:
//!
//! - gyro = the body angular rate `ω` (the Euler rates turned into the
//!   sensor frame, exact for the profile);
//! - accel = the specific force in the sensor frame: gravity
//!   (`(0, 0, +g)` in the world, [`GRAVITY`]) turned into the sensor
//!   frame, plus the acceleration of a sensor [`LEVER_M`] above the neck
//!   pivot (`α × l + ω × (ω × l)`), plus any translation of the whole
//!   body (a wheelchair's vibration, [`Jolt`]s), all rotated likewise.
//!
//! So a level, still head reads `(0, 0, 9.80665)` and zero rates, and a
//! head rolled by `φ` reads `ay = g·sin φ`.

use std::f64::consts::PI;

use nalgebra::{Rotation3, Vector3};

/// Standard gravity, m/s².
pub const GRAVITY: f64 = 9.80665;
/// The sensor's height above the neck's pivot, m.
pub const LEVER_M: f64 = 0.10;

/// One of the head's three angles.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    /// About y, positive nose down.
    Pitch,
    /// About x, positive right ear down.
    Roll,
    /// About z, positive to the left.
    Yaw,
}

impl Axis {
    fn index(self) -> usize {
        match self {
            Axis::Roll => 0,
            Axis::Pitch => 1,
            Axis::Yaw => 2,
        }
    }
}

/// An angle's value, rate and acceleration (rad, rad/s, rad/s²).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Kin {
    /// rad.
    pub angle: f64,
    /// rad/s.
    pub rate: f64,
    /// rad/s².
    pub accel: f64,
}

/// A minimum-jerk move of one angle by `amount` rad, from `start` s over
/// `duration` s, after which it stays moved: `amount·(10τ³ − 15τ⁴ + 6τ⁵)`.
/// Rate and acceleration are zero at both ends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    /// Which angle.
    pub axis: Axis,
    /// Start, s.
    pub start: f64,
    /// Length, s (> 0).
    pub duration: f64,
    /// How far, rad.
    pub amount: f64,
}

impl Step {
    /// Its end, s.
    pub fn end(&self) -> f64 {
        self.start + self.duration
    }

    /// Its angle, rate and acceleration at `t` s.
    pub fn at(&self, t: f64) -> Kin {
        let tau = (t - self.start) / self.duration;
        if tau <= 0.0 {
            return Kin::default();
        }
        if tau >= 1.0 {
            return Kin {
                angle: self.amount,
                ..Kin::default()
            };
        }
        let (t2, t3) = (tau * tau, tau * tau * tau);
        let d = self.duration;
        Kin {
            angle: self.amount * (10.0 * t3 - 15.0 * t3 * tau + 6.0 * t3 * t2),
            rate: self.amount * (30.0 * t2 - 60.0 * t3 + 30.0 * t2 * t2) / d,
            accel: self.amount * (60.0 * tau - 180.0 * t2 + 120.0 * t3) / (d * d),
        }
    }
}

/// How a [`Wave`]'s amplitude varies: a factor and its two derivatives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Envelope {
    /// `1 + depth·sin(2π·hz·t + phase)` for ever (a modulated tremor).
    Modulated {
        /// 0 ≤ depth < 1.
        depth: f64,
        /// Hz.
        hz: f64,
        /// rad.
        phase: f64,
    },
    /// 0 outside `[start, end]`, 1 inside but for raised-cosine edges of
    /// `ramp` s (a burst of talking, a stretch of rough ground).
    Window {
        /// s.
        start: f64,
        /// s.
        end: f64,
        /// s, at most half the window.
        ramp: f64,
    },
}

impl Envelope {
    /// The factor, its rate and acceleration at `t`.
    fn at(&self, t: f64) -> Kin {
        match *self {
            Envelope::Modulated { depth, hz, phase } => {
                let w = 2.0 * PI * hz;
                let a = w * t + phase;
                Kin {
                    angle: 1.0 + depth * a.sin(),
                    rate: depth * w * a.cos(),
                    accel: -depth * w * w * a.sin(),
                }
            }
            Envelope::Window { start, end, ramp } => {
                if t <= start || t >= end {
                    return Kin::default();
                }
                // An edge: (1 − cos(π·u))/2 for u = time into the ramp / ramp.
                let (u, sign) = if t < start + ramp {
                    ((t - start) / ramp, 1.0)
                } else if t > end - ramp {
                    ((end - t) / ramp, -1.0)
                } else {
                    return Kin {
                        angle: 1.0,
                        ..Kin::default()
                    };
                };
                let k = PI / ramp;
                Kin {
                    angle: (1.0 - (PI * u).cos()) / 2.0,
                    rate: sign * k * (PI * u).sin() / 2.0,
                    accel: k * k * (PI * u).cos() / 2.0,
                }
            }
        }
    }

    /// Where it is zero from on (`∞` if never).
    fn end(&self) -> f64 {
        match *self {
            Envelope::Modulated { .. } => f64::INFINITY,
            Envelope::Window { end, .. } => end,
        }
    }

    fn start(&self) -> f64 {
        match *self {
            Envelope::Modulated { .. } => f64::NEG_INFINITY,
            Envelope::Window { start, .. } => start,
        }
    }
}

/// `amplitude·envelope(t)·sin(2π·hz·t + phase)` on one angle: a tremor,
/// talking, the head rocking on rough ground.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wave {
    /// Which angle.
    pub axis: Axis,
    /// rad.
    pub amplitude: f64,
    /// Hz.
    pub hz: f64,
    /// rad.
    pub phase: f64,
    /// How the amplitude varies.
    pub envelope: Envelope,
}

impl Wave {
    /// Its angle, rate and acceleration at `t` s.
    pub fn at(&self, t: f64) -> Kin {
        let e = self.envelope.at(t);
        if e == Kin::default() {
            return e;
        }
        let w = 2.0 * PI * self.hz;
        let (s, c) = (w * t + self.phase).sin_cos();
        let a = self.amplitude;
        Kin {
            angle: a * e.angle * s,
            rate: a * (e.rate * s + e.angle * w * c),
            accel: a * (e.accel * s + 2.0 * e.rate * w * c - e.angle * w * w * s),
        }
    }
}

/// A translation of the whole body, in world axes, m/s²:
/// `amplitude·envelope(t)·sin(2π·hz·t + phase)` along `direction` (unit),
/// or a decaying bump (`decay` > 0: `amplitude·e^{−(t−start)/decay}·sin(…)`
/// from the envelope's start on).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Jolt {
    /// Unit vector, world axes.
    pub direction: [f64; 3],
    /// m/s².
    pub amplitude: f64,
    /// Hz.
    pub hz: f64,
    /// rad.
    pub phase: f64,
    /// How the amplitude varies.
    pub envelope: Envelope,
    /// A bump's decay time, s (0: none).
    pub decay: f64,
}

impl Jolt {
    /// Its acceleration, world axes, m/s².
    pub fn at(&self, t: f64) -> Vector3<f64> {
        let e = self.envelope.at(t).angle;
        if e == 0.0 {
            return Vector3::zeros();
        }
        let decay = if self.decay > 0.0 {
            (-(t - self.envelope.start()) / self.decay).exp()
        } else {
            1.0
        };
        let a = self.amplitude * e * decay * (2.0 * PI * self.hz * t + self.phase).sin();
        Vector3::from(self.direction) * a
    }
}

/// Everything the head and body do: steps, waves and jolts, each kept in
/// order of start, evaluated at increasing times ([`HeadMotion::at`]).
#[derive(Debug, Clone, Default)]
pub struct HeadMotion {
    /// The moves (any order; sorted by [`HeadMotion::finish`]).
    pub steps: Vec<Step>,
    /// The oscillations.
    pub waves: Vec<Wave>,
    /// The body's translations.
    pub jolts: Vec<Jolt>,
}

/// The head's state at one time: angles with rates and accelerations
/// (roll, pitch, yaw) and the body's translation, world axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeadState {
    /// Roll, pitch, yaw.
    pub angles: [Kin; 3],
    /// m/s², world axes.
    pub translation: Vector3<f64>,
}

/// Walks a [`HeadMotion`] forward in time, keeping only what is active:
/// a finished step is folded into a constant, a finished wave dropped.
/// Moves may be added as it goes ([`MotionCursor::add`]): a person in
/// closed loop decides their next move from what they see.
#[derive(Debug)]
pub struct MotionCursor {
    motion: HeadMotion,
    next_step: usize,
    active_steps: Vec<Step>,
    settled: [f64; 3],
    next_wave: usize,
    active_waves: Vec<Wave>,
    next_jolt: usize,
    active_jolts: Vec<Jolt>,
}

impl HeadMotion {
    /// Sorts its parts by start, ready for [`HeadMotion::cursor`].
    pub fn finish(&mut self) {
        self.steps.sort_by(|a, b| a.start.total_cmp(&b.start));
        self.waves
            .sort_by(|a, b| a.envelope.start().total_cmp(&b.envelope.start()));
        self.jolts
            .sort_by(|a, b| a.envelope.start().total_cmp(&b.envelope.start()));
    }

    /// A cursor to evaluate it at increasing times (after [`HeadMotion::finish`]).
    pub fn into_cursor(self) -> MotionCursor {
        MotionCursor {
            motion: self,
            next_step: 0,
            active_steps: Vec::new(),
            settled: [0.0; 3],
            next_wave: 0,
            active_waves: Vec::new(),
            next_jolt: 0,
            active_jolts: Vec::new(),
        }
    }
}

impl MotionCursor {
    /// Adds a move (starting no earlier than the last evaluated time).
    pub fn add(&mut self, step: Step) {
        self.active_steps.push(step);
    }

    /// Adds `motion`'s moves, oscillations and jolts (none starting
    /// before the last evaluated time).
    pub fn add_motion(&mut self, motion: HeadMotion) {
        self.active_steps.extend(motion.steps);
        self.active_waves.extend(motion.waves);
        self.active_jolts.extend(motion.jolts);
    }

    /// The state at `t` s, no earlier than the last call's.
    pub fn at(&mut self, t: f64) -> HeadState {
        let m = &self.motion;
        while let Some(step) = m.steps.get(self.next_step).filter(|s| s.start <= t) {
            self.active_steps.push(*step);
            self.next_step += 1;
        }
        while let Some(wave) = m
            .waves
            .get(self.next_wave)
            .filter(|w| w.envelope.start() <= t)
        {
            self.active_waves.push(*wave);
            self.next_wave += 1;
        }
        while let Some(jolt) = m
            .jolts
            .get(self.next_jolt)
            .filter(|j| j.envelope.start() <= t)
        {
            self.active_jolts.push(*jolt);
            self.next_jolt += 1;
        }
        let settled = &mut self.settled;
        self.active_steps.retain(|s| {
            if s.end() <= t {
                settled[s.axis.index()] += s.amount;
                false
            } else {
                true
            }
        });
        self.active_waves.retain(|w| w.envelope.end() > t);
        self.active_jolts.retain(|j| j.envelope.end() > t);
        let mut angles = self.settled.map(|angle| Kin {
            angle,
            ..Kin::default()
        });
        let parts = self
            .active_steps
            .iter()
            .map(|s| (s.axis, s.at(t)))
            .chain(self.active_waves.iter().map(|w| (w.axis, w.at(t))));
        for (axis, k) in parts {
            let a = &mut angles[axis.index()];
            a.angle += k.angle;
            a.rate += k.rate;
            a.accel += k.accel;
        }
        let translation = self.active_jolts.iter().map(|j| j.at(t)).sum();
        HeadState {
            angles,
            translation,
        }
    }
}

/// What an ideal head-worn IMU reads in `state`: accelerations (m/s²,
/// gravity included) and rates (rad/s), sensor axes, noise-free.
pub fn ideal_reading(state: &HeadState) -> ([f64; 3], [f64; 3]) {
    let [roll, pitch, yaw] = state.angles;
    let (sr, cr) = roll.angle.sin_cos();
    let (sp, cp) = pitch.angle.sin_cos();
    let (dr, dp, dy) = (roll.rate, pitch.rate, yaw.rate);
    let (ddr, ddp, ddy) = (roll.accel, pitch.accel, yaw.accel);
    // Body rates of the ZYX Euler angles, and their derivatives.
    let omega = Vector3::new(
        dr - dy * sp,
        dp * cr + dy * cp * sr,
        -dp * sr + dy * cp * cr,
    );
    let alpha = Vector3::new(
        ddr - ddy * sp - dy * dp * cp,
        ddp * cr - dp * dr * sr + ddy * cp * sr - dy * dp * sp * sr + dy * dr * cp * cr,
        -ddp * sr - dp * dr * cr + ddy * cp * cr - dy * dp * sp * cr - dy * dr * cp * sr,
    );
    let rotation = Rotation3::from_euler_angles(roll.angle, pitch.angle, yaw.angle);
    let lever = Vector3::new(0.0, 0.0, LEVER_M);
    let to_sensor = rotation.inverse();
    let gravity = to_sensor * Vector3::new(0.0, 0.0, GRAVITY);
    let accel = gravity
        + alpha.cross(&lever)
        + omega.cross(&omega.cross(&lever))
        + to_sensor * state.translation;
    (accel.into(), omega.into())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn still(roll: f64, pitch: f64, yaw: f64) -> HeadState {
        let k = |angle| Kin {
            angle,
            ..Kin::default()
        };
        HeadState {
            angles: [k(roll), k(pitch), k(yaw)],
            translation: Vector3::zeros(),
        }
    }

    #[test]
    fn a_still_head_reads_gravity_rotated_into_the_sensor() {
        let (a, w) = ideal_reading(&still(0.0, 0.0, 0.7));
        assert_eq!(w, [0.0; 3]);
        assert!((a[2] - GRAVITY).abs() < 1e-12 && a[0].abs() < 1e-12 && a[1].abs() < 1e-12);
        let roll = 0.3;
        let (a, _) = ideal_reading(&still(roll, 0.0, 0.0));
        assert!((a[1] - GRAVITY * roll.sin()).abs() < 1e-12, "{a:?}");
        // Nose down: forward points down, so gravity's reaction reads
        // along −x.
        let (a, _) = ideal_reading(&still(0.0, 0.2, 0.0));
        assert!((a[0] + GRAVITY * 0.2f64.sin()).abs() < 1e-12, "{a:?}");
    }

    #[test]
    fn a_nodding_head_adds_the_lever_arms_acceleration() {
        // Level, pitching at 2 rad/s and speeding up at 20 rad/s².
        let mut state = still(0.0, 0.0, 0.0);
        state.angles[1] = Kin {
            angle: 0.0,
            rate: 2.0,
            accel: 20.0,
        };
        let (a, w) = ideal_reading(&state);
        assert_eq!(w, [0.0, 2.0, 0.0]);
        // Tangential α·L along x, centripetal ω²·L towards the pivot.
        assert!((a[0] - 20.0 * LEVER_M).abs() < 1e-12, "{a:?}");
        assert!((a[2] - (GRAVITY - 4.0 * LEVER_M)).abs() < 1e-12, "{a:?}");
        // A turn about the lever's own axis adds nothing.
        let mut state = still(0.0, 0.0, 0.0);
        state.angles[2] = Kin {
            angle: 0.3,
            rate: 3.0,
            accel: -10.0,
        };
        let (a, w) = ideal_reading(&state);
        assert_eq!(w, [0.0, 0.0, 3.0]);
        assert!(
            (a[2] - GRAVITY).abs() < 1e-12 && a[0].abs() < 1e-12,
            "{a:?}"
        );
    }

    #[test]
    fn rates_and_accelerations_are_the_derivatives_of_the_profile() {
        let step = Step {
            axis: Axis::Yaw,
            start: 1.0,
            duration: 0.5,
            amount: 0.8,
        };
        let window = Envelope::Window {
            start: 0.9,
            end: 2.0,
            ramp: 0.3,
        };
        let wave = Wave {
            axis: Axis::Pitch,
            amplitude: 0.05,
            hz: 3.0,
            phase: 0.4,
            envelope: window,
        };
        let h = 1e-5;
        for t in [1.05, 1.1, 1.21, 1.31, 1.45, 1.9] {
            for f in [&|t| step.at(t), &|t| wave.at(t)] as [&dyn Fn(f64) -> Kin; 2] {
                let (a, b, c) = (f(t - h), f(t), f(t + h));
                let rate = (c.angle - a.angle) / (2.0 * h);
                let accel = (c.rate - a.rate) / (2.0 * h);
                assert!((rate - b.rate).abs() < 1e-6, "{t}: {rate} vs {}", b.rate);
                assert!(
                    (accel - b.accel).abs() < 1e-4,
                    "{t}: {accel} vs {}",
                    b.accel
                );
            }
        }
        assert_eq!(step.at(1.5).angle, 0.8);
        assert_eq!(step.at(0.9).angle, 0.0);
    }
}
