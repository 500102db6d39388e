//! `[motion]` and `[workspace]`: limits within the JACO2's caps, jerks
//! high enough for hold-to-run, a workspace inside the arm's reach.

use crate::config::error::Problems;
use crate::control::motion::limits::{self, MotionConfig, caps};
use crate::control::motion::workspace::WorkspaceConfig;

/// Largest tilt or twist limit, rad (170°): the tilt cone stays clear of
/// the tool pointing straight back, where the twist is undefined.
const MAX_ORIENTATION_LIMIT_RAD: f64 = 2.967;

/// `[motion]`: every limit positive and within the JACO2's caps.
pub(super) fn motion(p: &mut Problems, c: &MotionConfig) {
    p.range(
        "motion.linear_speed_mps",
        c.linear_speed_mps,
        caps::MIN_LINEAR_SPEED_MPS,
        true,
        caps::LINEAR_SPEED_MPS,
        "m/s (the JACO2 executes 0.04–0.20 m/s)",
    );
    p.range(
        "motion.angular_speed_radps",
        c.angular_speed_radps,
        caps::MIN_ANGULAR_SPEED_RADPS,
        true,
        caps::ANGULAR_SPEED_RADPS,
        "rad/s",
    );
    for (key, value, cap, unit) in [
        (
            "motion.linear_acceleration_mps2",
            c.linear_acceleration_mps2,
            caps::LINEAR_ACCELERATION_MPS2,
            "m/s²",
        ),
        (
            "motion.angular_acceleration_radps2",
            c.angular_acceleration_radps2,
            caps::ANGULAR_ACCELERATION_RADPS2,
            "rad/s²",
        ),
        (
            "motion.linear_jerk_mps3",
            c.linear_jerk_mps3,
            caps::LINEAR_JERK_MPS3,
            "m/s³",
        ),
        (
            "motion.angular_jerk_radps3",
            c.angular_jerk_radps3,
            caps::ANGULAR_JERK_RADPS3,
            "rad/s³",
        ),
        (
            "motion.finger_speed",
            c.finger_speed,
            caps::FINGER_SPEED,
            "units/s",
        ),
        (
            "motion.finger_acceleration",
            c.finger_acceleration,
            caps::FINGER_ACCELERATION,
            "units/s²",
        ),
        (
            "motion.finger_jerk",
            c.finger_jerk,
            caps::FINGER_JERK,
            "units/s³",
        ),
        (
            "motion.proportional_full_scale_volts",
            c.proportional_full_scale_volts,
            5.0,
            "V",
        ),
    ] {
        p.range(key, value, 0.0, false, cap, unit);
    }
    p.range(
        "motion.proportional_min_fraction",
        c.proportional_min_fraction,
        0.0,
        true,
        1.0,
        "",
    );
    hold_to_run(p, c);
}

/// Hold-to-run: each jerk high enough that motion ends when the breath
/// ends (after a release the speed rises by at most 10 % of full speed and
/// a stop from full speed takes at most v/A + 60 ms).
fn hold_to_run(p: &mut Problems, c: &MotionConfig) {
    for (key, jerk, speed, acceleration, unit) in [
        (
            "motion.linear_jerk_mps3",
            c.linear_jerk_mps3,
            c.linear_speed_mps,
            c.linear_acceleration_mps2,
            ("m/s³", "m/s²", "m/s"),
        ),
        (
            "motion.angular_jerk_radps3",
            c.angular_jerk_radps3,
            c.angular_speed_radps,
            c.angular_acceleration_radps2,
            ("rad/s³", "rad/s²", "rad/s"),
        ),
        (
            "motion.finger_jerk",
            c.finger_jerk,
            c.finger_speed,
            c.finger_acceleration,
            ("units/s³", "units/s²", "units/s"),
        ),
    ] {
        let all_positive = jerk > 0.0 && speed > 0.0 && acceleration > 0.0;
        let least = limits::hold_to_run_min_jerk(speed, acceleration);
        if all_positive && jerk < least * (1.0 - 1e-12) {
            let (j, a, v) = unit;
            p.add(
                key,
                format!(
                    "{jerk} {j} keeps the arm speeding up after a release: with an acceleration of {acceleration} {a} and a speed of {speed} {v} it must be at least {least:.4} {j} (or lower the acceleration), so that motion ends when the breath ends"
                ),
            );
        }
    }
}

/// `[workspace]`: a reach within the arm's, the other bounds inside it.
/// Below π the tilt limit is a cone and the twist is defined everywhere
/// in it.
pub(super) fn workspace(p: &mut Problems, c: &WorkspaceConfig) {
    for (key, value, low, low_inclusive, high, unit) in [
        (
            "workspace.reach_m",
            c.reach_m,
            0.0,
            false,
            caps::REACH_M,
            "m",
        ),
        (
            "workspace.min_radius_m",
            c.min_radius_m,
            0.0,
            true,
            c.reach_m,
            "m",
        ),
        (
            "workspace.table_z_m",
            c.table_z_m,
            -c.reach_m,
            true,
            c.reach_m,
            "m",
        ),
        (
            "workspace.stop_margin_m",
            c.stop_margin_m,
            0.0,
            false,
            0.1,
            "m",
        ),
        (
            "workspace.finger_closed",
            c.finger_closed,
            0.0,
            false,
            10_000.0,
            "units",
        ),
        (
            "workspace.max_tilt_rad",
            c.max_tilt_rad,
            0.0,
            false,
            MAX_ORIENTATION_LIMIT_RAD,
            "rad",
        ),
        (
            "workspace.max_twist_rad",
            c.max_twist_rad,
            0.0,
            false,
            MAX_ORIENTATION_LIMIT_RAD,
            "rad",
        ),
    ] {
        p.range(key, value, low, low_inclusive, high, unit);
    }
}
