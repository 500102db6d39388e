//! `[arm]`: the power-up pose inside the workspace, the checks on a
//! measured pose (`[arm.feedback]`) and the backends' settings.

use crate::arm::settings::ArmSettings;
use crate::config::error::Problems;
use crate::control::motion::feedback::{FeedbackConfig, MAX_WINDOW_MS};
use crate::control::motion::home::HomeConfig;
use crate::control::motion::workspace::WorkspaceConfig;

/// The power-up pose inside the workspace.
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

/// `[arm.feedback]`: a timer, a window the path holds, tolerances.
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

/// The backends' settings: `connect_timeout_ms` and `[arm.ros2]`,
/// `[arm.ros1]`, `[arm.kinova_sdk]`.
pub(super) fn backends(p: &mut Problems, c: &ArmSettings) {
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
