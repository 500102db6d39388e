//! The arm backends' settings: `connect_timeout_ms` in `[arm]`, and the
//! `[arm.ros2]`, `[arm.ros1]` and `[arm.kinova_sdk]` tables. Read and
//! validated by `config/` like every other section; used only when a
//! backend is opened (never on the control thread). The measured-pose
//! checks the core makes live with the core (`[arm.feedback]`).

use serde::{Deserialize, Serialize};

/// The backends' settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ArmSettings {
    /// Give up connecting (no receiver matched, no master, no arm) after
    /// this long, ms: an error at start, before anything moves.
    pub connect_timeout_ms: u32,
    /// `--arm ros2:TOPIC`.
    pub ros2: Ros2Settings,
    /// `--arm ros1:NAMESPACE`.
    pub ros1: Ros1Settings,
    /// `--arm kinova-sdk:usb|eth`.
    pub kinova_sdk: KinovaSdkSettings,
}

impl Default for ArmSettings {
    fn default() -> Self {
        ArmSettings {
            connect_timeout_ms: 10_000,
            ros2: Ros2Settings::default(),
            ros1: Ros1Settings::default(),
            kinova_sdk: KinovaSdkSettings::default(),
        }
    }
}

/// The message a ROS 2 command topic carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Ros2Message {
    /// `geometry_msgs/msg/TwistStamped` (MoveIt Servo, ros2_kortex's
    /// twist controller): float64, m/s and rad/s.
    TwistStamped,
    /// `kinova_msgs/msg/PoseVelocity` (the JACO2 ROS 2 ports): float32.
    PoseVelocity,
    /// `kinova_msgs/msg/PoseVelocityWithFingerVelocity`: float32, the
    /// three fingers' velocities in JACO2 units per second.
    PoseVelocityWithFingerVelocity,
}

impl Ros2Message {
    /// Every message, in the order the docs list them.
    pub const ALL: [Ros2Message; 3] = [
        Ros2Message::TwistStamped,
        Ros2Message::PoseVelocity,
        Ros2Message::PoseVelocityWithFingerVelocity,
    ];

    /// The config name.
    pub fn name(self) -> &'static str {
        match self {
            Ros2Message::TwistStamped => "twist_stamped",
            Ros2Message::PoseVelocity => "pose_velocity",
            Ros2Message::PoseVelocityWithFingerVelocity => "pose_velocity_with_finger_velocity",
        }
    }

    /// The message for a config name.
    pub fn from_name(name: &str) -> Option<Ros2Message> {
        Ros2Message::ALL.into_iter().find(|m| m.name() == name)
    }
}

/// `[arm.ros2]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Ros2Settings {
    /// What the command topic carries.
    pub message: Ros2Message,
    /// `header.frame_id` of a `TwistStamped` (MoveIt Servo transforms the
    /// twist from this frame; the commands are in the arm's base frame).
    pub frame_id: String,
    /// The measured tool pose (`geometry_msgs/msg/PoseStamped`, in the
    /// base frame): empty for none (the limits then trust dead reckoning).
    pub pose_topic: String,
    /// The ROS 2 domain (`ROS_DOMAIN_ID`), 0–232.
    pub domain_id: u16,
}

impl Default for Ros2Settings {
    fn default() -> Self {
        Ros2Settings {
            message: Ros2Message::TwistStamped,
            frame_id: "base_link".into(),
            pose_topic: String::new(),
            domain_id: 0,
        }
    }
}

/// `[arm.ros1]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Ros1Settings {
    /// Publish `PoseVelocityWithFingerVelocity` on
    /// `<ns>/in/cartesian_velocity_with_finger_velocity` (the fingers move
    /// too) rather than `PoseVelocity` on `<ns>/in/cartesian_velocity`.
    pub fingers: bool,
    /// Subscribe to `<ns>/out/tool_pose` and close the loop on it.
    pub tool_pose: bool,
    /// How often the master is asked whether it is still there, ms (it
    /// going away is a fault).
    pub master_check_ms: u32,
}

impl Default for Ros1Settings {
    fn default() -> Self {
        Ros1Settings {
            fingers: true,
            tool_pose: true,
            master_check_ms: 100,
        }
    }
}

/// `[arm.kinova_sdk]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct KinovaSdkSettings {
    /// The folder holding Kinova's `Kinova.API.USBCommandLayerUbuntu.so`
    /// and `Kinova.API.EthCommandLayerUbuntu.so` (or kinova-ros's
    /// `USBCommandLayerUbuntu.so` and `EthCommandLayerUbuntu.so`).
    pub library_dir: String,
    /// The arm's serial number (e.g. `PJ00000001030703130`); empty for the
    /// first arm found, as kinova-ros does.
    pub serial_number: String,
    /// A library call that has not returned, or a command the SDK thread
    /// has not taken, after this long, ms, is a lost link (the arm
    /// thread's check, not a timeout inside the library). The JACO2 itself
    /// stops when points stop arriving; this decides when the core is
    /// told. Long enough for a normal thread's scheduling delays on a
    /// loaded machine (up to 80 ms measured).
    pub call_timeout_ms: u32,
    /// `kinova-sdk:eth`: this machine's address on the arm's network.
    pub local_ip: String,
    /// `kinova-sdk:eth`: that network's mask.
    pub subnet_mask: String,
    /// `kinova-sdk:eth`: the arm's address (set in Kinova's Development
    /// Center, General/Ethernet).
    pub robot_ip: String,
    /// `kinova-sdk:eth`: the arm's UDP port.
    pub robot_port: u16,
    /// `kinova-sdk:eth`: this machine's command port.
    pub local_cmd_port: u16,
    /// `kinova-sdk:eth`: this machine's broadcast port.
    pub local_broadcast_port: u16,
}

impl Default for KinovaSdkSettings {
    /// kinova-ros's defaults (`robot_parameters.yaml`, `kinova_comm.cpp`).
    fn default() -> Self {
        KinovaSdkSettings {
            library_dir: "/opt/kinova/API".into(),
            serial_number: String::new(),
            call_timeout_ms: 500,
            local_ip: "192.168.100.100".into(),
            subnet_mask: "255.255.255.0".into(),
            robot_ip: "192.168.100.11".into(),
            robot_port: 55000,
            local_cmd_port: 25000,
            local_broadcast_port: 25025,
        }
    }
}
