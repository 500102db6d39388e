//! The motion limits: the configured speeds, accelerations and jerks, and
//! the hard caps no configuration may exceed.

use serde::Serialize;

/// Hard caps no configuration may exceed: the Kinova JACO2's client limits
/// (ISO 10218's reduced speed, 0.25 m/s, is above them).
pub mod caps {
    /// Linear speed, m/s.
    pub const LINEAR_SPEED_MPS: f64 = 0.20;
    /// Slowest linear speed the JACO2 executes (its dead band is ~0.03 m/s).
    pub const MIN_LINEAR_SPEED_MPS: f64 = 0.04;
    /// Angular speed, rad/s.
    pub const ANGULAR_SPEED_RADPS: f64 = 1.07;
    /// Slowest angular speed the JACO2 executes (dead band).
    pub const MIN_ANGULAR_SPEED_RADPS: f64 = 0.2;
    /// Linear acceleration, m/s².
    pub const LINEAR_ACCELERATION_MPS2: f64 = 0.64;
    /// Angular acceleration, rad/s².
    pub const ANGULAR_ACCELERATION_RADPS2: f64 = 2.75;
    /// Linear jerk, m/s³ (our choice: full acceleration in 32 ms at
    /// least — gentler on the arm than a step, which is all the JACO2's own
    /// 100 Hz stream would give).
    pub const LINEAR_JERK_MPS3: f64 = 20.0;
    /// Angular jerk, rad/s³ (full acceleration in 27.5 ms at least).
    pub const ANGULAR_JERK_RADPS3: f64 = 100.0;
    /// Finger speed, JACO2 finger units/s (0 = open … 6800 = closed).
    pub const FINGER_SPEED: f64 = 6800.0;
    /// Finger acceleration, units/s².
    pub const FINGER_ACCELERATION: f64 = 100_000.0;
    /// Finger jerk, units/s³.
    pub const FINGER_JERK: f64 = 2_000_000.0;
    /// Reach of the arm, m.
    pub const REACH_M: f64 = 0.9;
}

/// Motion settings (`[motion]` in the config file); the config validates
/// them against [`caps`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MotionConfig {
    /// Speed of a translation mode, m/s.
    pub linear_speed_mps: f64,
    /// Speed of a rotation mode, rad/s.
    pub angular_speed_radps: f64,
    /// Limit on the linear acceleration vector, m/s².
    pub linear_acceleration_mps2: f64,
    /// Limit on the angular acceleration vector, rad/s².
    pub angular_acceleration_radps2: f64,
    /// Limit on the linear jerk vector, m/s³.
    pub linear_jerk_mps3: f64,
    /// Limit on the angular jerk vector, rad/s³.
    pub angular_jerk_radps3: f64,
    /// Finger speed, units/s.
    pub finger_speed: f64,
    /// Finger acceleration limit, units/s².
    pub finger_acceleration: f64,
    /// Finger jerk limit, units/s³.
    pub finger_jerk: f64,
    /// Scale speed with how hard the user sips or puffs.
    pub proportional_speed: bool,
    /// Pressure past the threshold that gives full speed, volts.
    pub proportional_full_scale_volts: f64,
    /// Fraction of full speed at the threshold itself.
    pub proportional_min_fraction: f64,
}

impl Default for MotionConfig {
    fn default() -> Self {
        MotionConfig {
            linear_speed_mps: caps::LINEAR_SPEED_MPS,
            angular_speed_radps: caps::ANGULAR_SPEED_RADPS,
            linear_acceleration_mps2: caps::LINEAR_ACCELERATION_MPS2,
            angular_acceleration_radps2: caps::ANGULAR_ACCELERATION_RADPS2,
            // Full acceleration in 50 ms: after a release the speed rises
            // by A²/2J = 8 % of full speed at most and a stop from full
            // speed takes v/A + A/J = v/A + 50 ms (see `hold_to_run`).
            linear_jerk_mps3: 12.8,
            angular_jerk_radps3: 55.0,
            finger_speed: 3000.0,
            finger_acceleration: 20_000.0,
            // Full acceleration in 25 ms.
            finger_jerk: 800_000.0,
            proportional_speed: false,
            proportional_full_scale_volts: 1.0,
            proportional_min_fraction: 0.25,
        }
    }
}

/// Hold-to-run: motion ends when the breath ends. After a release the
/// speed may rise by at most this fraction of the full speed before it
/// falls (it rises by A²/2J while the acceleration ramps down)…
pub const HOLD_TO_RUN_RISE: f64 = 0.10;
/// …and a stop from full speed takes at most v/A plus this, s (the ramps
/// add A/J).
pub const HOLD_TO_RUN_EXTRA_S: f64 = 0.060;

/// The least jerk that keeps hold-to-run for a speed `v`, an acceleration
/// `a`: A²/2J ≤ 10 % of v and A/J ≤ 60 ms.
pub fn hold_to_run_min_jerk(v: f64, a: f64) -> f64 {
    (a * a / (2.0 * HOLD_TO_RUN_RISE * v)).max(a / HOLD_TO_RUN_EXTRA_S)
}
