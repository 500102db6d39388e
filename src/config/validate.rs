//! The checks a configuration must pass, on typed values, each error with
//! its key. The reader runs them section by section as it reads the file
//! (so errors come in file order); [`core`] runs them all again on a
//! changed configuration (`Config::with_*`), so no way of building a
//! `Config` skips them.

use std::collections::HashSet;

use crate::arm::settings::ArmSettings;
use crate::config::error::ConfigError;
use crate::control::action::ActionSeq;
use crate::control::core_config::CoreConfig;
use crate::control::detector::{DetectorConfig, REZERO_WINDOW_MS};
use crate::control::mode::Mode;
use crate::control::modes::CommandConfig;
use crate::control::motion::feedback::{FeedbackConfig, MAX_WINDOW_MS};
use crate::control::motion::home::HomeConfig;
use crate::control::motion::limits::{self, MotionConfig, caps};
use crate::control::motion::workspace::WorkspaceConfig;
use crate::control::selection::SequenceEntry;
use crate::control::selection::matcher::MatcherConfig;
use crate::control::selection::scanning::ScanningConfig;
use crate::sensor::settings::{EvdevInput, SensorSettings};

/// Largest library the matcher accepts.
pub const MAX_SEQUENCES: usize = 256;

/// Upper bound for every timer, to catch unit mistakes (seconds typed as
/// milliseconds ×1000) and keep tick arithmetic far from overflow.
pub const MAX_TIMER_MS: u32 = 600_000;

/// The problems found so far, in the order found.
#[derive(Debug, Default)]
pub(super) struct Problems {
    pub(super) errors: Vec<ConfigError>,
}

impl Problems {
    /// Records a problem with `key`.
    pub(super) fn add(&mut self, key: impl Into<String>, message: impl Into<String>) {
        self.errors.push(ConfigError {
            key: key.into(),
            line: None,
            column: None,
            message: message.into(),
        });
    }

    /// Checks `low < value ≤ high` (or `low ≤ value` when `low_inclusive`).
    pub(super) fn range(
        &mut self,
        key: &str,
        value: f64,
        low: f64,
        low_inclusive: bool,
        high: f64,
        unit: &str,
    ) {
        let above_low = if low_inclusive {
            value >= low
        } else {
            value > low
        };
        if !(above_low && value <= high) {
            let bound = if low_inclusive { "at least" } else { "above" };
            self.add(
                key,
                format!("{value} {unit} must be {bound} {low} {unit} and at most {high} {unit}"),
            );
        }
    }

    pub(super) fn positive_ms(&mut self, key: &str, value: u32) {
        if value == 0 {
            self.add(key, "must be greater than 0 ms");
        } else if value > MAX_TIMER_MS {
            self.add(
                key,
                format!("{value} ms is more than the {MAX_TIMER_MS} ms allowed"),
            );
        }
    }
}

/// Every check, in the order the reader runs them.
pub(super) fn core(p: &mut Problems, c: &CoreConfig) {
    detector(p, &c.detector);
    matcher(p, &c.matcher);
    command(p, &c.command);
    motion(p, &c.motion);
    workspace(p, &c.workspace);
    home(p, &c.home, &c.workspace);
    feedback(p, &c.feedback);
    library(p, &c.sequences);
    scanning(p, &c.scanning);
}

/// `[detector]`: every level inside 0–5 V and on the right side of the
/// neutral, the hysteresis inside the band, timers positive and ordered.
pub(super) fn detector(p: &mut Problems, c: &DetectorConfig) {
    for (key, v) in [
        ("detector.neutral_volts", c.neutral_volts),
        ("detector.puff_threshold_volts", c.puff_threshold_volts),
        ("detector.sip_threshold_volts", c.sip_threshold_volts),
    ] {
        if !(0.0..=5.0).contains(&v) {
            p.add(key, format!("{v} V is outside the sensor's 0–5 V range"));
        }
    }
    if c.puff_threshold_volts <= c.neutral_volts {
        p.add(
            "detector.puff_threshold_volts",
            format!(
                "{} V must be above detector.neutral_volts ({} V): a puff raises the voltage",
                c.puff_threshold_volts, c.neutral_volts
            ),
        );
    }
    if c.sip_threshold_volts >= c.neutral_volts {
        p.add(
            "detector.sip_threshold_volts",
            format!(
                "{} V must be below detector.neutral_volts ({} V): a sip lowers the voltage",
                c.sip_threshold_volts, c.neutral_volts
            ),
        );
    }
    let nearest =
        (c.puff_threshold_volts - c.neutral_volts).min(c.neutral_volts - c.sip_threshold_volts);
    if c.hysteresis_volts.is_nan() || c.hysteresis_volts < 0.0 {
        p.add("detector.hysteresis_volts", "must be 0 V or more");
    } else if nearest > 0.0 && c.hysteresis_volts >= nearest {
        p.add(
            "detector.hysteresis_volts",
            format!(
                "{} V must be smaller than the distance from the neutral to the nearest threshold ({nearest:.3} V)",
                c.hysteresis_volts
            ),
        );
    }
    if !(c.fault_margin_volts > 0.0 && c.fault_margin_volts <= 5.0) {
        p.add(
            "detector.fault_margin_volts",
            format!(
                "{} V must be above 0 V and at most 5 V",
                c.fault_margin_volts
            ),
        );
    }
    p.positive_ms("detector.min_burst_ms", c.min_burst_ms);
    p.positive_ms("detector.long_burst_ms", c.long_burst_ms);
    p.positive_ms("detector.neutral_tracking_ms", c.neutral_tracking_ms);
    p.positive_ms("detector.fault_recovery_ms", c.fault_recovery_ms);
    p.positive_ms("detector.stale_ms", c.stale_ms);
    if c.long_burst_ms <= c.min_burst_ms {
        p.add(
            "detector.long_burst_ms",
            format!(
                "{} ms must be greater than detector.min_burst_ms ({} ms)",
                c.long_burst_ms, c.min_burst_ms
            ),
        );
    }
    if c.glitch_ms >= c.min_burst_ms {
        p.add(
            "detector.glitch_ms",
            format!(
                "{} ms must be smaller than detector.min_burst_ms ({} ms): a glitch is shorter than any burst",
                c.glitch_ms, c.min_burst_ms
            ),
        );
    }
    p.positive_ms("detector.max_hold_ms", c.max_hold_ms);
    p.positive_ms("detector.rezero_ms", c.rezero_ms);
    let shorter = if c.max_hold_ms <= c.long_burst_ms {
        Some(("detector.long_burst_ms", c.long_burst_ms))
    } else if c.max_hold_ms <= c.min_burst_ms {
        Some(("detector.min_burst_ms", c.min_burst_ms))
    } else {
        None
    };
    if let Some((other, value)) = shorter {
        p.add(
            "detector.max_hold_ms",
            format!(
                "{} ms must be greater than {other} ({value} ms): a breath longer than max_hold_ms is a stuck sensor",
                c.max_hold_ms
            ),
        );
    }
    let window = REZERO_WINDOW_MS as u32;
    if c.rezero_ms < 2 * window {
        p.add(
            "detector.rezero_ms",
            format!(
                "{} ms must be at least {} ms: steadiness is judged over {window} ms windows, at least two",
                c.rezero_ms,
                2 * window
            ),
        );
    }
}

/// `[matcher]`.
pub(super) fn matcher(p: &mut Problems, c: &MatcherConfig) {
    p.positive_ms("matcher.sequence_timeout_ms", c.sequence_timeout_ms);
}

/// `[command]`.
pub(super) fn command(p: &mut Problems, c: &CommandConfig) {
    p.positive_ms("command.inactivity_timeout_ms", c.inactivity_timeout_ms);
    if c.motion_onset_ms > 0 {
        p.positive_ms("command.motion_onset_ms", c.motion_onset_ms);
    }
}

/// `[scanning]`: positive dwell times, each mode at most once, at least one.
pub(super) fn scanning(p: &mut Problems, c: &ScanningConfig) {
    scanning_dwell(p, c.dwell_ms, c.first_dwell_ms);
    if c.order_len > c.order.len() {
        p.add(
            "scanning.order",
            format!(
                "{} modes, at most {} (each mode once)",
                c.order_len,
                c.order.len()
            ),
        );
    } else {
        scan_order(p, c.modes());
    }
}

/// `[scanning]`'s timers.
pub(super) fn scanning_dwell(p: &mut Problems, dwell_ms: u32, first_dwell_ms: u32) {
    p.positive_ms("scanning.dwell_ms", dwell_ms);
    p.positive_ms("scanning.first_dwell_ms", first_dwell_ms);
}

/// `[scanning] order`: each mode at most once, at least one.
pub(super) fn scan_order(p: &mut Problems, modes: &[Mode]) {
    let mut seen = HashSet::new();
    for mode in modes {
        if !seen.insert(mode) {
            p.add("scanning.order", format!("{:?} appears twice", mode.name()));
        }
    }
    if modes.is_empty() {
        p.add("scanning.order", "must list at least one mode");
    }
}

/// `[motion]`: every limit positive and within the JACO2's caps.
pub(super) fn motion(p: &mut Problems, c: &MotionConfig) {
    let speed_note = "m/s (the JACO2 executes 0.04–0.20 m/s)";
    p.range(
        "motion.linear_speed_mps",
        c.linear_speed_mps,
        caps::MIN_LINEAR_SPEED_MPS,
        true,
        caps::LINEAR_SPEED_MPS,
        speed_note,
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
pub(super) fn workspace(p: &mut Problems, c: &WorkspaceConfig) {
    p.range(
        "workspace.reach_m",
        c.reach_m,
        0.0,
        false,
        caps::REACH_M,
        "m",
    );
    p.range(
        "workspace.min_radius_m",
        c.min_radius_m,
        0.0,
        true,
        c.reach_m,
        "m",
    );
    p.range(
        "workspace.table_z_m",
        c.table_z_m,
        -c.reach_m,
        true,
        c.reach_m,
        "m",
    );
    p.range(
        "workspace.stop_margin_m",
        c.stop_margin_m,
        0.0,
        false,
        0.1,
        "m",
    );
    p.range(
        "workspace.finger_closed",
        c.finger_closed,
        0.0,
        false,
        10_000.0,
        "units",
    );
    // Below π the limit is a cone and the twist is defined everywhere in it.
    p.range(
        "workspace.max_tilt_rad",
        c.max_tilt_rad,
        0.0,
        false,
        MAX_ORIENTATION_LIMIT_RAD,
        "rad",
    );
    p.range(
        "workspace.max_twist_rad",
        c.max_twist_rad,
        0.0,
        false,
        MAX_ORIENTATION_LIMIT_RAD,
        "rad",
    );
}

/// Largest tilt or twist limit, rad (170°): the tilt cone stays clear of
/// the tool pointing straight back, where the twist is undefined.
const MAX_ORIENTATION_LIMIT_RAD: f64 = 2.967;

/// `[arm]`: the power-up pose inside the workspace.
pub(super) fn home(p: &mut Problems, c: &HomeConfig, workspace: &WorkspaceConfig) {
    let [x, y, z] = c.home_position_m;
    let r = (x * x + y * y + z * z).sqrt();
    let w = workspace;
    if !(r.is_finite()
        && r <= w.reach_m - w.stop_margin_m
        && r >= w.min_radius_m + w.stop_margin_m
        && z >= w.table_z_m + w.stop_margin_m)
    {
        p.add(
            "arm.home_position_m",
            format!(
                "{:?} is not inside the workspace (distance from the base {r:.3} m must be within {:.3}–{:.3} m, z at least {:.3} m)",
                c.home_position_m,
                w.min_radius_m + w.stop_margin_m,
                w.reach_m - w.stop_margin_m,
                w.table_z_m + w.stop_margin_m
            ),
        );
    }
    if !c.home_rotation_vector_rad.iter().all(|v| v.is_finite()) {
        p.add("arm.home_rotation_vector_rad", "must be finite");
    }
    p.range(
        "arm.home_fingers",
        c.home_fingers,
        0.0,
        true,
        w.finger_closed,
        "units",
    );
}

/// `[[sequence]]`: how many.
pub(super) fn library_size(p: &mut Problems, count: usize) {
    if count == 0 {
        p.add("sequence", "the library has no sequence");
    }
    if count > MAX_SEQUENCES {
        p.add(
            "sequence",
            format!("{count} sequences, at most {MAX_SEQUENCES} allowed"),
        );
    }
}

/// The message for a sequence listed a second time.
pub(super) fn listed_twice(sequence: &ActionSeq) -> String {
    format!("{sequence:?} is listed twice")
}

/// `[[sequence]]` as typed entries: the size, no empty sequence, none
/// listed twice.
pub(super) fn library(p: &mut Problems, entries: &[SequenceEntry]) {
    library_size(p, entries.len());
    let mut seen = HashSet::new();
    for (i, entry) in entries.iter().enumerate() {
        let key = format!("sequence #{}.actions", i + 1);
        if entry.actions.is_empty() {
            p.add(&key, "must hold at least one action");
        } else if !seen.insert(entry.actions) {
            p.add(&key, listed_twice(&entry.actions));
        }
    }
}

/// `[sensor]`: timers positive, the re-zero shift inside the band between
/// the thresholds, mappings finite and not flat, key and axis names real.
pub(super) fn feedback(p: &mut Problems, c: &FeedbackConfig) {
    p.positive_ms("arm.feedback.timeout_ms", c.timeout_ms);
    if c.window_ms == 0 || c.window_ms > MAX_WINDOW_MS {
        p.add(
            "arm.feedback.window_ms",
            format!(
                "{} ms must be from 1 to {MAX_WINDOW_MS} ms (how far back the commanded path is kept)",
                c.window_ms
            ),
        );
    }
    for (key, value, unit, most) in [
        ("arm.feedback.tolerance_m", c.tolerance_m, "m", 0.5),
        ("arm.feedback.tolerance_rad", c.tolerance_rad, "rad", 1.0),
    ] {
        if !(value > 0.0 && value <= most) {
            p.add(
                key,
                format!("{value} {unit} must be above 0 and at most {most} {unit}"),
            );
        }
    }
}

pub(super) fn arm(p: &mut Problems, c: &ArmSettings) {
    p.positive_ms("arm.connect_timeout_ms", c.connect_timeout_ms);
    p.positive_ms("arm.ros1.master_check_ms", c.ros1.master_check_ms);
    // ROS 2 maps a domain to UDP ports: above 232 they overflow.
    if c.ros2.domain_id > 232 {
        p.add(
            "arm.ros2.domain_id",
            format!("{} is not a ROS 2 domain (0–232)", c.ros2.domain_id),
        );
    }
    if c.ros2.frame_id.is_empty() {
        p.add(
            "arm.ros2.frame_id",
            "must name the frame the twist is in (e.g. \"base_link\")",
        );
    }
    let pose = &c.ros2.pose_topic;
    if !pose.is_empty() && crate::arm::ArmSpec::parse(&format!("ros2:{pose}")).is_err() {
        p.add(
            "arm.ros2.pose_topic",
            format!("{pose:?} is not a topic name (letters, digits, `_` and `/`; empty for none)"),
        );
    }
    if c.kinova_sdk.library_dir.is_empty() {
        p.add(
            "arm.kinova_sdk.library_dir",
            "must name the folder holding Kinova's command-layer libraries",
        );
    }
    let sdk = &c.kinova_sdk;
    p.positive_ms("arm.kinova_sdk.call_timeout_ms", sdk.call_timeout_ms);
    for (key, value) in [
        ("arm.kinova_sdk.local_ip", &sdk.local_ip),
        ("arm.kinova_sdk.subnet_mask", &sdk.subnet_mask),
        ("arm.kinova_sdk.robot_ip", &sdk.robot_ip),
    ] {
        if value.parse::<std::net::Ipv4Addr>().is_err() {
            p.add(
                key,
                format!("{value:?} is not an IPv4 address (e.g. \"192.168.100.100\")"),
            );
        }
    }
    for (key, value) in [
        ("arm.kinova_sdk.robot_port", sdk.robot_port),
        ("arm.kinova_sdk.local_cmd_port", sdk.local_cmd_port),
        (
            "arm.kinova_sdk.local_broadcast_port",
            sdk.local_broadcast_port,
        ),
    ] {
        if value == 0 {
            p.add(key, "must be a UDP port (1–65535)");
        }
    }
}

pub(super) fn sensor(p: &mut Problems, c: &SensorSettings) {
    p.positive_ms("sensor.rezero_ms", c.rezero_ms);
    p.positive_ms("sensor.rezero_timeout_ms", c.rezero_timeout_ms);
    if c.rezero_timeout_ms < c.rezero_ms {
        p.add(
            "sensor.rezero_timeout_ms",
            format!(
                "{} ms is shorter than sensor.rezero_ms ({} ms): the neutral could never be measured",
                c.rezero_timeout_ms, c.rezero_ms
            ),
        );
    }
    if !(c.rezero_max_shift_fraction >= 0.0 && c.rezero_max_shift_fraction < 1.0) {
        p.add(
            "sensor.rezero_max_shift_fraction",
            format!(
                "{} must be at least 0 and below 1 (a fraction of the distance from the neutral to the nearer threshold: at 1 a breath held through the measurement could become the neutral)",
                c.rezero_max_shift_fraction
            ),
        );
    }
    let e = &c.evdev;
    for (key, value) in [
        ("sensor.evdev.volts_at_min", e.volts_at_min),
        ("sensor.evdev.volts_at_max", e.volts_at_max),
    ] {
        if !value.is_finite() {
            p.add(key, format!("{value} must be a finite number of volts"));
        }
    }
    if e.volts_at_min == e.volts_at_max {
        p.add(
            "sensor.evdev.volts_at_max",
            "must differ from sensor.evdev.volts_at_min: the axis would read one level whatever the pressure",
        );
    }
    if e.axis.parse::<evdev::AbsoluteAxisCode>().is_err() {
        p.add(
            "sensor.evdev.axis",
            format!(
                "{:?} is not a Linux absolute axis name (e.g. ABS_X, ABS_Y, ABS_Z, ABS_RX, ABS_THROTTLE)",
                e.axis
            ),
        );
    }
    for (key, names) in [
        ("sensor.evdev.sip_keys", &e.sip_keys),
        ("sensor.evdev.puff_keys", &e.puff_keys),
    ] {
        let bad: Vec<&str> = names
            .iter()
            .filter(|n| n.parse::<evdev::KeyCode>().is_err())
            .map(String::as_str)
            .collect();
        if !bad.is_empty() {
            p.add(
                key,
                format!(
                    "{bad:?}: not Linux key or button names (e.g. BTN_TRIGGER, BTN_THUMB, KEY_ENTER, KEY_SPACE)"
                ),
            );
        }
        if names.is_empty() && e.input == EvdevInput::Switches {
            p.add(key, "needs at least one key for `input = \"switches\"`");
        }
    }
    if let Some(both) = e.sip_keys.iter().find(|k| e.puff_keys.contains(k)) {
        p.add(
            "sensor.evdev.puff_keys",
            format!("{both} is also a sip key: a key means sip or puff, not both"),
        );
    }
    let s = &c.serial;
    if s.baud == 0 || s.baud > 4_000_000 {
        p.add(
            "sensor.serial.baud",
            format!("{} must be between 1 and 4000000", s.baud),
        );
    }
    p.range(
        "sensor.serial.full_scale",
        s.full_scale,
        0.0,
        false,
        1e9,
        "counts",
    );
    p.range(
        "sensor.serial.volts_per_hpa",
        s.volts_per_hpa,
        0.0,
        false,
        5.0,
        "V/hPa",
    );
    p.positive_ms("sensor.serial.answer_timeout_ms", s.answer_timeout_ms);
    p.positive_ms("sensor.serial.silence_ms", s.silence_ms);
    let i = &c.iio;
    if !(i.gain.is_finite() && i.gain != 0.0) {
        p.add(
            "sensor.iio.gain",
            format!("{} must be a finite number other than 0", i.gain),
        );
    }
    if !i.offset_volts.is_finite() {
        p.add(
            "sensor.iio.offset_volts",
            format!("{} must be a finite number of volts", i.offset_volts),
        );
    }
    if i.rate_hz == 0 || i.rate_hz > 1000 {
        p.add(
            "sensor.iio.rate_hz",
            format!(
                "{} must be between 1 and 1000 (the control loop runs at 1 kHz)",
                i.rate_hz
            ),
        );
    }
}
