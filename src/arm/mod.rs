//! The arm seam: where the core's 100 Hz Cartesian-velocity stream goes.
//!
//! A backend's life: **connect** ([`Arm::connect`]) → **commands**
//! ([`Arm::send`], one per 10 ms cycle, from the arm thread, never the
//! control thread) → **feedback** ([`Arm::feedback`]: the measured pose and
//! fingers, when the backend has them) → **stop** ([`end_stream`]: a zero
//! command, then [`Arm::stop`]). Every stop path ends the stream with a
//! zero command, so an arm that keeps executing its last command (a Gen3's
//! twist runs until `Stop()`) is told to stand still.
//!
//! Feedback: a backend that measures the tool pose (a driver's
//! `tool_pose` topic, the SDK's `GetCartesianPosition`) says so with
//! [`Arm::measures_pose`]; the runtime then hands each measurement to the
//! core, whose workspace and orientation limits use it instead of dead
//! reckoning. A backend that can tell its link is gone says so from
//! [`Arm::check_link`], polled every millisecond by the arm thread.
//!
//! Backends: [`sim`] (the simulated JACO), [`ros2`] (a ROS 2 topic),
//! [`ros1`] (kinova-ros over ROS 1), [`kinova_sdk`] (a JACO2 through
//! Kinova's own library).

pub mod kinova_sdk;
pub mod ros1;
#[cfg(feature = "ros2")]
pub mod ros2;
pub mod settings;
pub mod sim;

use std::fmt;

use nalgebra::Isometry3;
use serde::{Serialize, Serializer};

use crate::control::motion::stream::ArmCommand;

/// Which arm to drive: the `--arm` values, a contract documented in
/// `--help` and `docs/commands.md`. A new backend adds its form here and
/// one line where it is opened (`wiring/arm.rs`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ArmSpec {
    /// `sim`: the simulated JACO2.
    Sim,
    /// `ros2:TOPIC`: a ROS 2 topic (MoveIt Servo's `/servo_node/delta_twist_cmds`,
    /// ros2_kortex's `/twist_controller/commands`, a JACO2 port's
    /// `/j2n6s300_driver/in/cartesian_velocity`); settings in `[arm.ros2]`.
    Ros2 {
        /// The command topic, as given (a leading `/` optional).
        topic: String,
    },
    /// `ros1:NAMESPACE`: a kinova-ros driver (e.g. `/j2n6s300_driver`),
    /// the master from `ROS_MASTER_URI`; settings in `[arm.ros1]`.
    Ros1 {
        /// The driver's namespace, as given.
        namespace: String,
    },
    /// `kinova-sdk:usb` or `kinova-sdk:eth`: a JACO2 through Kinova's own
    /// library, loaded at run time; settings in `[arm.kinova_sdk]`.
    KinovaSdk {
        /// Which of Kinova's command layers.
        link: SdkLink,
    },
}

/// How Kinova's SDK reaches the arm.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SdkLink {
    /// `Kinova.API.USBCommandLayerUbuntu.so`.
    Usb,
    /// `Kinova.API.EthCommandLayerUbuntu.so`.
    Eth,
}

impl ArmSpec {
    /// Parses an `--arm` value; the error says which forms exist.
    pub fn parse(text: &str) -> Result<ArmSpec, String> {
        let forms = "`sim`, `ros2:TOPIC`, `ros1:NAMESPACE` or `kinova-sdk:usb|eth`";
        match text.split_once(':') {
            None if text == "sim" => Ok(ArmSpec::Sim),
            Some(("ros2", topic)) if valid_ros_name(topic) => Ok(ArmSpec::Ros2 {
                topic: topic.into(),
            }),
            Some(("ros2", topic)) => Err(format!(
                "`ros2:` needs a topic name (letters, digits, `_` and `/`), e.g. `ros2:/servo_node/delta_twist_cmds`; got `{topic}`"
            )),
            Some(("ros1", namespace)) if valid_ros_name(namespace) => Ok(ArmSpec::Ros1 {
                namespace: namespace.into(),
            }),
            Some(("ros1", namespace)) => Err(format!(
                "`ros1:` needs the driver's namespace (letters, digits, `_` and `/`), e.g. `ros1:/j2n6s300_driver`; got `{namespace}`"
            )),
            Some(("kinova-sdk", "usb")) => Ok(ArmSpec::KinovaSdk { link: SdkLink::Usb }),
            Some(("kinova-sdk", "eth")) => Ok(ArmSpec::KinovaSdk { link: SdkLink::Eth }),
            Some(("kinova-sdk", other)) => Err(format!(
                "`kinova-sdk:` takes `usb` or `eth` (Kinova's USB or Ethernet command layer); got `{other}`"
            )),
            _ => Err(format!("unknown arm `{text}`: use {forms}")),
        }
    }
}

/// A ROS graph name: non-empty; letters, digits, `_` and `/`; no `//`;
/// not starting with a digit.
fn valid_ros_name(name: &str) -> bool {
    let bare = name.trim_start_matches('/');
    !bare.is_empty()
        && !bare.starts_with(|c: char| c.is_ascii_digit())
        && !name.contains("//")
        && !name.ends_with('/')
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '/')
}

impl fmt::Display for ArmSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ArmSpec::Sim => f.write_str("sim"),
            ArmSpec::Ros2 { topic } => write!(f, "ros2:{topic}"),
            ArmSpec::Ros1 { namespace } => write!(f, "ros1:{namespace}"),
            ArmSpec::KinovaSdk { link: SdkLink::Usb } => f.write_str("kinova-sdk:usb"),
            ArmSpec::KinovaSdk { link: SdkLink::Eth } => f.write_str("kinova-sdk:eth"),
        }
    }
}

/// What an arm reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmState {
    /// Tool pose in the base frame (m; the orientation as a rotation from
    /// the base frame).
    pub pose: Isometry3<f64>,
    /// Finger position, JACO2 units (0 open), when the arm reports it.
    pub fingers: Option<f64>,
    /// The command being executed, or the last one sent (zero when none).
    pub executing: ArmCommand,
}

/// Written as position (m), rotation vector (rad), fingers and command.
impl Serialize for ArmState {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        #[derive(Serialize)]
        struct Fields {
            position_m: [f64; 3],
            rotation_vector_rad: [f64; 3],
            fingers: Option<f64>,
            executing: ArmCommand,
        }
        Fields {
            position_m: self.pose.translation.vector.into(),
            rotation_vector_rad: self.pose.rotation.scaled_axis().into(),
            fingers: self.fingers,
            executing: self.executing,
        }
        .serialize(serializer)
    }
}

/// Why an arm refused or failed.
#[derive(Debug)]
#[non_exhaustive]
pub enum ArmError {
    /// The arm is not connected or not powered.
    Unavailable {
        /// Which arm and what to check.
        detail: String,
    },
    /// The arm refused a command.
    Rejected {
        /// Why.
        detail: String,
    },
    /// The connection failed while running.
    Disconnected {
        /// What happened.
        detail: String,
    },
}

impl fmt::Display for ArmError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ArmError::Unavailable { detail } => write!(f, "arm unavailable: {detail}"),
            ArmError::Rejected { detail } => write!(f, "arm refused a command: {detail}"),
            ArmError::Disconnected { detail } => write!(f, "arm disconnected: {detail}"),
        }
    }
}

impl std::error::Error for ArmError {}

/// An arm that takes the 100 Hz Cartesian velocity stream. Called from the
/// thread that owns the arm, never the control thread.
pub trait Arm: Send {
    /// What this arm is, for the report (e.g. `sim`).
    fn describe(&self) -> String;

    /// Connects (and, for a real arm, takes control). Called once, before
    /// the first command.
    fn connect(&mut self) -> Result<(), ArmError>;

    /// Sends one command, to be executed over the next 10 ms cycle.
    fn send(&mut self, command: &ArmCommand) -> Result<(), ArmError>;

    /// The newest state the arm reported since the previous call, if any
    /// (`None`: nothing new, or the backend measures nothing). Never
    /// blocks.
    fn feedback(&mut self) -> Option<ArmState>;

    /// Whether [`Arm::feedback`] carries a *measured* tool pose, which the
    /// core then uses for its limits instead of dead reckoning (and whose
    /// silence is a fault). The simulation's pose is the dead reckoning
    /// itself: it says `false`.
    fn measures_pose(&self) -> bool {
        false
    }

    /// Whether the link still stands: `Err(ArmError::Disconnected)` once
    /// the backend knows the other side is gone (the receiver, the
    /// master, the device). Asked at each of the arm thread's wake-ups
    /// (each command, at least every 10 ms); never blocks.
    fn check_link(&mut self) -> Result<(), ArmError> {
        Ok(())
    }

    /// Ends the stream and releases the arm. Call through [`end_stream`],
    /// which sends the zero command first.
    fn stop(&mut self) -> Result<(), ArmError>;

    /// The backend's own threads that carry the stream on to the arm (the
    /// Kinova SDK's worker, the DDS event loop that sends what a ROS 2
    /// writer queued), named, while connected: `run` gives them the arm
    /// thread's priority and CPUs, since a command waits on them too.
    fn threads(&self) -> Vec<(String, ThreadRef)> {
        Vec::new()
    }
}

/// A thread of this process, as the scheduler is told about it: one we
/// started (its pthread), or one a library started, found by its kernel
/// task id.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ThreadRef {
    /// A thread whose `JoinHandle` its owner holds.
    Pthread(libc::pthread_t),
    /// A thread's task id (`/proc/self/task/TID`).
    Task(libc::pid_t),
}

/// Ends a stream: a zero command numbered after `last` (so the arm stands
/// still whatever it was doing), then [`Arm::stop`]. Both are attempted;
/// the first error is returned.
pub fn end_stream(arm: &mut dyn Arm, last: Option<&ArmCommand>) -> Result<(), ArmError> {
    let zero = ArmCommand {
        seq: last.map_or(0, |c| c.seq + 1),
        tick: last.map_or(0, |c| c.tick + 10),
        ..ArmCommand::default()
    };
    let sent = arm.send(&zero);
    let stopped = arm.stop();
    sent.and(stopped)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_arm_forms_parse_and_print_back() {
        for text in [
            "sim",
            "ros2:/servo_node/delta_twist_cmds",
            "ros2:twist_controller/commands",
            "ros1:/j2n6s300_driver",
            "kinova-sdk:usb",
            "kinova-sdk:eth",
        ] {
            assert_eq!(ArmSpec::parse(text).unwrap().to_string(), text);
        }
    }

    #[test]
    fn a_wrong_arm_says_which_forms_exist() {
        let error = ArmSpec::parse("jaco").unwrap_err();
        assert!(
            error.contains("`ros2:TOPIC`") && error.contains("kinova-sdk"),
            "{error}"
        );
        for bad in [
            "ros2:",
            "ros2:/a//b",
            "ros2:/1x",
            "ros2:/a b",
            "ros1:/",
            "ros1:ns/",
        ] {
            assert!(ArmSpec::parse(bad).is_err(), "{bad}");
        }
        let error = ArmSpec::parse("kinova-sdk:serial").unwrap_err();
        assert!(error.contains("`usb` or `eth`"), "{error}");
    }
}
