//! The ROS 2 messages on the wire: CDR (little endian, XCDR1 as every ROS 2
//! RMW writes it), field for field as the `.msg` files declare them, and
//! the DDS names ROS 2 gives topics and types (`rt/<topic>`,
//! `<package>::msg::dds_::<Type>_`).
//!
//! Checked against the definitions: `geometry_msgs/msg/TwistStamped`
//! (`std_msgs/Header header` = `builtin_interfaces/Time stamp {int32 sec,
//! uint32 nanosec}` + `string frame_id`; `Twist twist` = two `Vector3` of
//! float64), `geometry_msgs/msg/PoseStamped` (header + `Pose` = `Point`
//! float64 x, y, z + `Quaternion` float64 x, y, z, w), and kinova-ros's
//! `kinova_msgs/msg/PoseVelocity.msg` (float32 twist_linear_x/y/z,
//! twist_angular_x/y/z) and `PoseVelocityWithFingerVelocity.msg` (the same
//! + float32 finger1, finger2, finger3).

use std::time::{SystemTime, UNIX_EPOCH};

use serde::{Deserialize, Serialize};

use crate::arm::settings::Ros2Message;
use crate::control::motion::stream::ArmCommand;

/// `builtin_interfaces/msg/Time`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Time {
    /// Seconds since the epoch.
    pub sec: i32,
    /// Nanoseconds within the second.
    pub nanosec: u32,
}

impl Time {
    /// The wall clock now, as ROS 2's `now()` gives it (system time).
    pub fn now() -> Time {
        let since = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .unwrap_or_default();
        Time {
            sec: i32::try_from(since.as_secs()).unwrap_or(i32::MAX),
            nanosec: since.subsec_nanos(),
        }
    }
}

/// `std_msgs/msg/Header`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Header {
    /// When.
    pub stamp: Time,
    /// In which frame.
    pub frame_id: String,
}

/// `geometry_msgs/msg/Vector3`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

impl From<[f64; 3]> for Vector3 {
    fn from([x, y, z]: [f64; 3]) -> Self {
        Vector3 { x, y, z }
    }
}

/// `geometry_msgs/msg/Twist`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Twist {
    /// m/s.
    pub linear: Vector3,
    /// rad/s.
    pub angular: Vector3,
}

/// `geometry_msgs/msg/TwistStamped`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TwistStamped {
    /// Stamp and frame.
    pub header: Header,
    /// The twist.
    pub twist: Twist,
}

/// `kinova_msgs/msg/PoseVelocity`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct PoseVelocity {
    /// m/s.
    pub twist_linear_x: f32,
    /// m/s.
    pub twist_linear_y: f32,
    /// m/s.
    pub twist_linear_z: f32,
    /// rad/s.
    pub twist_angular_x: f32,
    /// rad/s.
    pub twist_angular_y: f32,
    /// rad/s.
    pub twist_angular_z: f32,
}

/// `kinova_msgs/msg/PoseVelocityWithFingerVelocity`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct PoseVelocityWithFingerVelocity {
    /// m/s.
    pub twist_linear_x: f32,
    /// m/s.
    pub twist_linear_y: f32,
    /// m/s.
    pub twist_linear_z: f32,
    /// rad/s.
    pub twist_angular_x: f32,
    /// rad/s.
    pub twist_angular_y: f32,
    /// rad/s.
    pub twist_angular_z: f32,
    /// JACO2 finger units/s (positive closes).
    pub finger1: f32,
    /// JACO2 finger units/s.
    pub finger2: f32,
    /// JACO2 finger units/s.
    pub finger3: f32,
}

/// `geometry_msgs/msg/Point`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Point {
    /// m.
    pub x: f64,
    /// m.
    pub y: f64,
    /// m.
    pub z: f64,
}

/// `geometry_msgs/msg/Quaternion`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

/// `geometry_msgs/msg/Pose`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose {
    /// m.
    pub position: Point,
    /// Unit quaternion (not checked by ROS: we check it).
    pub orientation: Quaternion,
}

/// `geometry_msgs/msg/PoseStamped`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct PoseStamped {
    /// Stamp and frame.
    pub header: Header,
    /// The pose.
    pub pose: Pose,
}

/// The DDS type name of a `PoseStamped`.
pub const POSE_STAMPED_TYPE: &str = "geometry_msgs::msg::dds_::PoseStamped_";

/// One command message, of whichever type `[arm.ros2] message` chose.
/// Serialized as the message itself (no tag: `untagged`).
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum CommandMessage {
    /// `geometry_msgs/msg/TwistStamped`.
    TwistStamped(TwistStamped),
    /// `kinova_msgs/msg/PoseVelocity`.
    PoseVelocity(PoseVelocity),
    /// `kinova_msgs/msg/PoseVelocityWithFingerVelocity`.
    PoseVelocityWithFingerVelocity(PoseVelocityWithFingerVelocity),
}

/// The `.msg` name (`package/msg/Type`), for messages to a person.
pub fn ros_name(message: Ros2Message) -> &'static str {
    match message {
        Ros2Message::TwistStamped => "geometry_msgs/msg/TwistStamped",
        Ros2Message::PoseVelocity => "kinova_msgs/msg/PoseVelocity",
        Ros2Message::PoseVelocityWithFingerVelocity => {
            "kinova_msgs/msg/PoseVelocityWithFingerVelocity"
        }
    }
}

/// The DDS type name ROS 2 (rosidl) gives a message.
pub fn dds_type_name(message: Ros2Message) -> &'static str {
    match message {
        Ros2Message::TwistStamped => "geometry_msgs::msg::dds_::TwistStamped_",
        Ros2Message::PoseVelocity => "kinova_msgs::msg::dds_::PoseVelocity_",
        Ros2Message::PoseVelocityWithFingerVelocity => {
            "kinova_msgs::msg::dds_::PoseVelocityWithFingerVelocity_"
        }
    }
}

/// The DDS topic of a ROS 2 topic: `rt` + the absolute name (a relative
/// name resolves against the root namespace, as a node in `/` resolves it).
pub fn dds_topic_name(topic: &str) -> String {
    format!("rt/{}", topic.trim_start_matches('/'))
}

/// A command as the chosen message: base frame, m/s and rad/s; the
/// kinova messages in float32 (rounded to nearest), the three fingers all
/// at the command's finger velocity; a TwistStamped stamped `stamp` in
/// `frame_id`.
pub fn command_message(
    message: Ros2Message,
    command: &ArmCommand,
    frame_id: &str,
    stamp: Time,
) -> CommandMessage {
    let [lx, ly, lz] = command.linear.map(|v| v as f32);
    let [ax, ay, az] = command.angular.map(|v| v as f32);
    let fingers = command.fingers as f32;
    match message {
        Ros2Message::TwistStamped => CommandMessage::TwistStamped(TwistStamped {
            header: Header {
                stamp,
                frame_id: frame_id.to_string(),
            },
            twist: Twist {
                linear: command.linear.into(),
                angular: command.angular.into(),
            },
        }),
        Ros2Message::PoseVelocity => CommandMessage::PoseVelocity(PoseVelocity {
            twist_linear_x: lx,
            twist_linear_y: ly,
            twist_linear_z: lz,
            twist_angular_x: ax,
            twist_angular_y: ay,
            twist_angular_z: az,
        }),
        Ros2Message::PoseVelocityWithFingerVelocity => {
            CommandMessage::PoseVelocityWithFingerVelocity(PoseVelocityWithFingerVelocity {
                twist_linear_x: lx,
                twist_linear_y: ly,
                twist_linear_z: lz,
                twist_angular_x: ax,
                twist_angular_y: ay,
                twist_angular_z: az,
                finger1: fingers,
                finger2: fingers,
                finger3: fingers,
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rustdds::CDRSerializerAdapter;
    use rustdds::no_key::SerializerAdapter;

    fn cdr<T: Serialize>(value: &T) -> Vec<u8> {
        <CDRSerializerAdapter<T> as SerializerAdapter<T>>::to_bytes(value)
            .unwrap()
            .to_vec()
    }

    #[test]
    fn a_twist_stamped_is_laid_out_as_rosidl_lays_it_out() {
        let command = ArmCommand {
            linear: [0.1, -0.2, 0.3],
            angular: [0.0, 0.5, -1.0],
            ..ArmCommand::default()
        };
        let message = command_message(
            Ros2Message::TwistStamped,
            &command,
            "base_link",
            Time { sec: 7, nanosec: 9 },
        );
        let bytes = cdr(&message);
        // sec, nanosec, string (length incl. NUL, bytes, NUL), pad to 8, 6 f64.
        let mut expected = Vec::new();
        expected.extend(7i32.to_le_bytes());
        expected.extend(9u32.to_le_bytes());
        expected.extend(10u32.to_le_bytes());
        expected.extend(b"base_link\0");
        expected.extend([0u8; 2]); // 8 + 4 + 10 = 22 → 24
        for v in [0.1, -0.2, 0.3, 0.0, 0.5, -1.0f64] {
            expected.extend(v.to_le_bytes());
        }
        assert_eq!(bytes, expected);
    }

    #[test]
    fn the_kinova_messages_are_float32_with_three_equal_fingers() {
        let command = ArmCommand {
            linear: [0.1, 0.0, -0.05],
            angular: [0.2, 0.0, 0.0],
            fingers: 3000.0,
            ..ArmCommand::default()
        };
        let bytes = cdr(&command_message(
            Ros2Message::PoseVelocityWithFingerVelocity,
            &command,
            "",
            Time::default(),
        ));
        let values: Vec<f32> = bytes
            .chunks(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect();
        assert_eq!(
            values,
            [0.1, 0.0, -0.05, 0.2, 0.0, 0.0, 3000.0, 3000.0, 3000.0]
        );
        let bytes = cdr(&command_message(
            Ros2Message::PoseVelocity,
            &command,
            "",
            Time::default(),
        ));
        assert_eq!(bytes.len(), 24);
    }

    #[test]
    fn ros_names_become_dds_names() {
        assert_eq!(
            dds_topic_name("/servo_node/delta_twist_cmds"),
            "rt/servo_node/delta_twist_cmds"
        );
        assert_eq!(
            dds_topic_name("twist_controller/commands"),
            "rt/twist_controller/commands"
        );
        for m in Ros2Message::ALL {
            let ros = ros_name(m)
                .replace('/', "::")
                .replace("::msg::", "::msg::dds_::");
            assert_eq!(format!("{ros}_"), dds_type_name(m));
        }
    }
}
