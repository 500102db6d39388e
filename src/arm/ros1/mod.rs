//! `--arm ros1:NAMESPACE`: a JACO2 through kinova-ros (ROS 1), spoken to
//! by a small ROS 1 client of our own (XML-RPC to the master and between
//! nodes, TCPROS for the messages).
//!
//! Publishes `kinova_msgs/PoseVelocity` on `<ns>/in/cartesian_velocity`,
//! or `kinova_msgs/PoseVelocityWithFingerVelocity` on
//! `<ns>/in/cartesian_velocity_with_finger_velocity` (`[arm.ros1]
//! fingers`), one message per 10 ms command; subscribes to
//! `<ns>/out/tool_pose` (`geometry_msgs/PoseStamped`) when `[arm.ros1]
//! tool_pose`. The master is `ROS_MASTER_URI`'s; this node is
//! `/sipnpuff` (a second one registering the name shuts the first down:
//! a fault there).
//!
//! Our own client because the wait for the driver, the link check and
//! "the zero was written" need a publisher that knows its subscribers:
//! roslibrust 0.26's always reports one connected, says nothing when one
//! goes away and only queues on `publish`; rosrust 0.9.12 is a
//! process-wide singleton that takes SIGINT, sees a closed subscriber only
//! after a failed write and cannot flush. The client is small:
//! `session.rs` (connect, shut down), `node.rs` (master and slave APIs),
//! `tcpros.rs`, `xmlrpc.rs`, `msg.rs`.

mod msg;
mod node;
mod session;
mod tcpros;
mod xmlrpc;

use std::sync::atomic::Ordering;
use std::time::Duration;

use crate::arm::settings::Ros1Settings;
use crate::arm::{Arm, ArmError, ArmState};
use crate::control::motion::stream::ArmCommand;

use msg::MsgType;
use session::{Node, Plan};
use tcpros::lock;

/// Bytes a subscriber may leave unread before it counts as gone: 100
/// commands (1 s) — a JACO2 would execute a backlog late.
const MAX_PENDING: usize = 100 * msg::MAX_FRAME;

/// A kinova-ros driver over ROS 1.
pub struct Ros1Arm {
    namespace: String,
    settings: Ros1Settings,
    connect_timeout: Duration,
    msg_type: MsgType,
    node: Option<Node>,
    last_sent: ArmCommand,
    poses_seen: u64,
    /// Once the link is lost, the reason (said again on every call).
    lost: Option<String>,
}

impl Ros1Arm {
    /// The arm for `--arm ros1:NAMESPACE` (not connected yet).
    pub fn new(namespace: &str, settings: &Ros1Settings, connect_timeout_ms: u32) -> Ros1Arm {
        let namespace = format!("/{}", namespace.trim_start_matches('/'));
        Ros1Arm {
            namespace,
            settings: settings.clone(),
            connect_timeout: Duration::from_millis(u64::from(connect_timeout_ms)),
            msg_type: if settings.fingers {
                msg::POSE_VELOCITY_WITH_FINGER_VELOCITY
            } else {
                msg::POSE_VELOCITY
            },
            node: None,
            last_sent: ArmCommand::default(),
            poses_seen: 0,
            lost: None,
        }
    }

    /// The command topic.
    pub fn command_topic(&self) -> String {
        if self.settings.fingers {
            format!(
                "{}/in/cartesian_velocity_with_finger_velocity",
                self.namespace
            )
        } else {
            format!("{}/in/cartesian_velocity", self.namespace)
        }
    }

    /// The tool-pose topic.
    pub fn pose_topic(&self) -> String {
        format!("{}/out/tool_pose", self.namespace)
    }

    /// What to start when nothing subscribes: kinova_bringup's launch line
    /// for the robot type the namespace names (`/j2n6s300_driver` →
    /// `j2n6s300`).
    fn launch_hint(&self) -> String {
        let robot = self
            .namespace
            .trim_start_matches('/')
            .rsplit('/')
            .next()
            .unwrap_or("")
            .trim_end_matches("_driver");
        // A robot type is like j2n6s300 (letter digit letter digit letter
        // three digits); another name is kinova_robotName's.
        let is_type = robot.len() == 8
            && robot.chars().enumerate().all(|(i, c)| match i {
                0 | 2 | 4 => c.is_ascii_lowercase(),
                _ => c.is_ascii_digit(),
            });
        let args = if is_type {
            format!("kinova_robotType:={robot}")
        } else {
            format!("kinova_robotType:=j2n6s300 kinova_robotName:={robot}")
        };
        format!(
            "is the kinova driver running: roslaunch kinova_bringup kinova_robot.launch {args}?"
        )
    }

    fn lose(&mut self, reason: String) -> ArmError {
        if self.lost.is_none() {
            self.lost = Some(reason);
        }
        ArmError::Disconnected {
            detail: self.lost.clone().unwrap_or_default(),
        }
    }

    /// The link's state, without blocking: the master (watched by its own
    /// thread) and the subscribers' connections (a non-blocking peek each:
    /// a closed one reads as end of file at once).
    fn link(&mut self) -> Result<(), ArmError> {
        if let Some(reason) = &self.lost {
            return Err(ArmError::Disconnected {
                detail: reason.clone(),
            });
        }
        let Some(node) = &self.node else {
            return Ok(());
        };
        if node.shared.lost_flag.load(Ordering::Acquire) {
            let reason = lock(&node.shared.lost).clone().unwrap_or_default();
            return Err(self.lose(reason));
        }
        let mut gone = Vec::new();
        {
            let mut subscribers = lock(&node.subscribers);
            subscribers.retain(|s| {
                let closed = tcpros::closed(&s.stream);
                if closed {
                    gone.push(s.caller_id.clone());
                }
                !closed
            });
            if gone.is_empty() {
                return Ok(());
            }
            let driver_gone = gone.contains(&self.namespace);
            if !driver_gone && !subscribers.is_empty() {
                return Ok(());
            }
        }
        let topic = self.command_topic();
        Err(self.lose(format!(
            "{} closed its connection to {topic}: the kinova driver is gone (killed, or its node stopped); the arm stops when its stream stops",
            gone.join(", ")
        )))
    }
}

impl Arm for Ros1Arm {
    fn describe(&self) -> String {
        format!(
            "ros1:{} ({} on {})",
            self.namespace,
            self.msg_type.name,
            self.command_topic()
        )
    }

    fn connect(&mut self) -> Result<(), ArmError> {
        if self.node.is_none() {
            let plan = Plan {
                topic: self.command_topic(),
                msg_type: self.msg_type,
                pose_topic: self.settings.tool_pose.then(|| self.pose_topic()),
                connect_timeout: self.connect_timeout,
                master_check: Duration::from_millis(u64::from(
                    self.settings.master_check_ms.max(1),
                )),
                launch_hint: self.launch_hint(),
            };
            self.node = Some(session::start(&plan)?);
        }
        Ok(())
    }

    /// Once the link is lost, only zero commands go out (to whoever still
    /// listens: the driver when only the master is gone), so the stream's
    /// end still reaches the arm; a moving command is refused.
    fn send(&mut self, command: &ArmCommand) -> Result<(), ArmError> {
        let link = self.link();
        if link.is_err() && !command.is_zero() {
            return link;
        }
        let Some(node) = &self.node else {
            return Err(ArmError::Disconnected {
                detail: "the ROS 1 node is not connected".into(),
            });
        };
        let mut frame = [0u8; msg::MAX_FRAME];
        let len = msg::encode_command(command, self.settings.fingers, &mut frame);
        let mut failed = None;
        {
            let mut subscribers = lock(&node.subscribers);
            subscribers.retain_mut(|sub| match tcpros::write_frame(sub, &frame[..len]) {
                Ok(()) if sub.pending.len() > MAX_PENDING => {
                    failed = Some(format!(
                        "{} stopped reading {} ({} bytes unread): a JACO2 would run the backlog late",
                        sub.caller_id,
                        node.shared.pub_topic,
                        sub.pending.len()
                    ));
                    false
                }
                Ok(()) => true,
                Err(e) => {
                    failed = Some(format!(
                        "writing to {} on {} failed: {e}",
                        sub.caller_id, node.shared.pub_topic
                    ));
                    false
                }
            });
            if failed.is_none() && subscribers.is_empty() {
                failed = Some(format!(
                    "nothing subscribes to {} any more",
                    node.shared.pub_topic
                ));
            }
        }
        self.last_sent = *command;
        match failed {
            Some(reason) => Err(self.lose(reason)),
            None => Ok(()),
        }
    }

    fn feedback(&mut self) -> Option<ArmState> {
        let node = self.node.as_ref()?;
        let slot = lock(&node.shared.poses);
        if slot.count == self.poses_seen {
            return None;
        }
        self.poses_seen = slot.count;
        let (_, pose) = slot.newest.as_ref()?;
        Some(ArmState {
            pose: *pose,
            fingers: None,
            executing: self.last_sent,
        })
    }

    fn measures_pose(&self) -> bool {
        self.settings.tool_pose
    }

    fn check_link(&mut self) -> Result<(), ArmError> {
        self.link()
    }

    fn stop(&mut self) -> Result<(), ArmError> {
        let Some(mut node) = self.node.take() else {
            return Ok(());
        };
        match session::shutdown(&mut node, true) {
            None => Ok(()),
            Some(who) => Err(ArmError::Disconnected {
                detail: format!(
                    "{who} did not confirm the end of {} (the zero command may not have arrived; a JACO2 stops anyway when its stream stops)",
                    self.command_topic()
                ),
            }),
        }
    }
}

impl Drop for Ros1Arm {
    fn drop(&mut self) {
        if let Some(mut node) = self.node.take() {
            let _ = session::shutdown(&mut node, true);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn topics_and_hint_follow_the_namespace() {
        let mut settings = Ros1Settings {
            fingers: false,
            ..Ros1Settings::default()
        };
        let arm = Ros1Arm::new("j2n6s300_driver", &settings, 100);
        assert_eq!(
            arm.command_topic(),
            "/j2n6s300_driver/in/cartesian_velocity"
        );
        assert_eq!(arm.pose_topic(), "/j2n6s300_driver/out/tool_pose");
        assert!(arm.launch_hint().contains("kinova_robotType:=j2n6s300?"));
        settings.fingers = true;
        let arm = Ros1Arm::new("/m1n6s200_driver", &settings, 100);
        assert_eq!(
            arm.command_topic(),
            "/m1n6s200_driver/in/cartesian_velocity_with_finger_velocity"
        );
        assert!(arm.launch_hint().contains("kinova_robotType:=m1n6s200?"));
        let arm = Ros1Arm::new("/left_driver", &settings, 100);
        assert!(
            arm.launch_hint()
                .contains("kinova_robotType:=j2n6s300 kinova_robotName:=left?")
        );
    }
}
