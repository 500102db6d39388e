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
//! Why not a crate (both read at their current releases): roslibrust
//! 0.26's publisher cannot tell whether a subscriber is connected (its
//! `has_connected_clients` counts the broadcast receiver its own accept
//! task holds, so it is always true), says nothing when one goes away,
//! and its `publish` only queues (a lagging connection skips messages), so
//! neither the wait for the driver, nor the link check, nor "the zero was
//! written" can be built on it. rosrust 0.9.12 is a process-wide
//! singleton that takes SIGINT unless told not to, notices a closed
//! subscriber only after a failed write in its own thread, and cannot
//! flush. What is needed here is small: see `node.rs`, `tcpros.rs`,
//! `xmlrpc.rs`, `msg.rs`.

mod msg;
mod node;
mod tcpros;
mod xmlrpc;

use std::collections::HashSet;
use std::io::Read;
use std::net::{Shutdown, TcpListener};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use crate::arm::settings::Ros1Settings;
use crate::arm::{Arm, ArmError, ArmState};
use crate::control::motion::stream::ArmCommand;

use msg::MsgType;
use node::Shared;
use tcpros::{PoseSlot, Subscribers, lock};
use xmlrpc::{HttpUri, s};

/// This node's name.
pub const NODE_NAME: &str = "/sipnpuff";

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

/// A connected node.
struct Node {
    shared: Arc<Shared>,
    subscribers: Subscribers,
    /// Stops accepting subscribers (first step of the stop).
    accept_stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
    subscribed: bool,
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

    fn unavailable(detail: String) -> ArmError {
        ArmError::Unavailable { detail }
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

    /// Starts the node: registers the publisher, waits for the driver's
    /// subscriber, then (with `tool_pose`) for the first pose.
    fn start(&mut self) -> Result<Node, ArmError> {
        let topic = self.command_topic();
        let master_text = std::env::var("ROS_MASTER_URI").map_err(|_| {
            Self::unavailable(format!(
                "ROS_MASTER_URI is not set: export ROS_MASTER_URI=http://HOST:11311 (the machine running roscore, e.g. http://localhost:11311) to publish {topic}"
            ))
        })?;
        let master = HttpUri::parse(&master_text).ok_or_else(|| {
            Self::unavailable(format!(
                "ROS_MASTER_URI `{master_text}` is not http://HOST:PORT (e.g. http://localhost:11311)"
            ))
        })?;
        let no_master = |e: &dyn std::fmt::Display| {
            Self::unavailable(format!(
                "no ROS master answers at {master_text} (ROS_MASTER_URI): {e}; is roscore running there (roscore, or the kinova launch file, which starts one)?"
            ))
        };
        let ask = self
            .connect_timeout
            .clamp(Duration::from_millis(100), Duration::from_secs(3));
        // Our address: ROS_IP, ROS_HOSTNAME, else the one the master is
        // reached from (loopback for a local master).
        let host = match std::env::var("ROS_IP").or_else(|_| std::env::var("ROS_HOSTNAME")) {
            Ok(host) if !host.is_empty() => host,
            _ => {
                let probe = xmlrpc::connect_any(&master.host, master.port, ask)
                    .map_err(|e| no_master(&e))?;
                probe
                    .local_addr()
                    .map_err(|e| no_master(&e))?
                    .ip()
                    .to_string()
            }
        };
        let io = |what: &str, e: std::io::Error| Self::unavailable(format!("{what}: {e}"));
        let slave = TcpListener::bind("0.0.0.0:0").map_err(|e| io("the node's XML-RPC port", e))?;
        let publication = TcpListener::bind("0.0.0.0:0").map_err(|e| io("the TCPROS port", e))?;
        let api_port = slave
            .local_addr()
            .map_err(|e| io("the XML-RPC port", e))?
            .port();
        let tcpros_port = publication
            .local_addr()
            .map_err(|e| io("the TCPROS port", e))?
            .port();
        let stop = Arc::new(AtomicBool::new(false));
        let shared = Arc::new(Shared {
            caller_id: NODE_NAME.into(),
            host: host.clone(),
            api_uri: format!("http://{host}:{api_port}/"),
            master,
            master_text: master_text.clone(),
            pub_topic: topic.clone(),
            tcpros_port,
            sub_topic: self.settings.tool_pose.then(|| self.pose_topic()),
            poses: Arc::new(Mutex::new(PoseSlot::default())),
            pose_publishers: Mutex::new(HashSet::new()),
            lost: Mutex::new(None),
            lost_flag: AtomicBool::new(false),
            stop: stop.clone(),
        });
        let pid = node::master_call(&shared, "getPid", &[s(NODE_NAME)], ask)
            .map_err(|e| no_master(&e))?
            .as_int()
            .unwrap_or(0);
        // One controller per arm: a live /sipnpuff is not displaced (the
        // master would shut it down); a stale registration (a killed
        // sipnpuff) does not answer and is taken over.
        if let Ok(other) =
            node::master_call(&shared, "lookupNode", &[s(NODE_NAME), s(NODE_NAME)], ask)
            && let Some(uri) = other.as_str().and_then(HttpUri::parse)
            && let Ok(other_pid) = node::api_call(&uri, "getPid", &[s(NODE_NAME)], ask)
        {
            return Err(Self::unavailable(format!(
                "another {NODE_NAME} (pid {}, {}) is registered with the ROS master at {master_text} and answering: one controller per arm; stop it first",
                other_pid.as_int().unwrap_or(0),
                other.as_str().unwrap_or("")
            )));
        }
        let subscribers: Subscribers = Arc::new(Mutex::new(Vec::new()));
        let accept_stop = Arc::new(AtomicBool::new(false));
        let mut node = Node {
            shared: shared.clone(),
            subscribers: subscribers.clone(),
            accept_stop: accept_stop.clone(),
            threads: Vec::new(),
            subscribed: false,
        };
        let spawn = |name: &str, f: Box<dyn FnOnce() + Send>| {
            thread::Builder::new()
                .name(name.into())
                .spawn(f)
                .map_err(|e| Self::unavailable(format!("a thread for ROS 1: {e}")))
        };
        let s2 = shared.clone();
        node.threads.push(spawn(
            "ros1-xmlrpc",
            Box::new(move || node::serve_slave_api(slave, s2)),
        )?);
        let (t, c, m, subs) = (
            topic.clone(),
            NODE_NAME.to_owned(),
            self.msg_type,
            subscribers,
        );
        node.threads.push(spawn(
            "ros1-tcpros",
            Box::new(move || tcpros::serve_publication(publication, t, c, m, subs, accept_stop)),
        )?);
        let result = self.register(&mut node, pid, ask);
        if let Err(e) = result {
            Self::shutdown(&mut node, false);
            return Err(e);
        }
        Ok(node)
    }

    fn register(&mut self, node: &mut Node, pid: i32, ask: Duration) -> Result<(), ArmError> {
        let shared = node.shared.clone();
        let topic = self.command_topic();
        let registering = |what: &str, e: xmlrpc::CallError| {
            Self::unavailable(format!(
                "the ROS master at {} refused {what}: {e}",
                shared.master_text
            ))
        };
        node::master_call(
            &shared,
            "registerPublisher",
            &[
                s(NODE_NAME),
                s(&topic),
                s(self.msg_type.name),
                s(&shared.api_uri),
            ],
            ask,
        )
        .map_err(|e| registering("registerPublisher", e))?;
        let deadline = Instant::now() + self.connect_timeout;
        while lock(&node.subscribers).is_empty() {
            if shared.lost_flag.load(Ordering::Acquire) {
                return Err(Self::unavailable(
                    lock(&shared.lost).clone().unwrap_or_default(),
                ));
            }
            if Instant::now() >= deadline {
                return Err(Self::unavailable(format!(
                    "nothing subscribed to {topic} ({}) within {} ms (master {}): {}",
                    self.msg_type.name,
                    self.connect_timeout.as_millis(),
                    shared.master_text,
                    self.launch_hint()
                )));
            }
            thread::sleep(Duration::from_millis(5));
        }
        if let Some(pose_topic) = shared.sub_topic.clone() {
            let publishers = node::master_call(
                &shared,
                "registerSubscriber",
                &[
                    s(NODE_NAME),
                    s(&pose_topic),
                    s(msg::POSE_STAMPED.name),
                    s(&shared.api_uri),
                ],
                ask,
            )
            .map_err(|e| registering("registerSubscriber", e))?;
            node.subscribed = true;
            let uris: Vec<String> = publishers
                .as_array()
                .unwrap_or(&[])
                .iter()
                .filter_map(|v| v.as_str().map(str::to_owned))
                .collect();
            node::connect_publishers(&shared, &uris);
            let deadline = Instant::now() + self.connect_timeout;
            while lock(&shared.poses).count == 0 {
                if Instant::now() >= deadline {
                    let why = lock(&shared.poses)
                        .error
                        .clone()
                        .map_or(String::new(), |e| format!(" (last problem: {e})"));
                    return Err(Self::unavailable(format!(
                        "no {} on {pose_topic} within {} ms{why}: is the kinova driver publishing its tool pose? (or set [arm.ros1] tool_pose = false to run on dead reckoning)",
                        msg::POSE_STAMPED.name,
                        self.connect_timeout.as_millis()
                    )));
                }
                thread::sleep(Duration::from_millis(5));
            }
        }
        let period = Duration::from_millis(u64::from(self.settings.master_check_ms.max(1)));
        let s2 = shared.clone();
        node.threads.push(
            thread::Builder::new()
                .name("ros1-master".into())
                .spawn(move || node::watch_master(s2, period, pid))
                .map_err(|e| Self::unavailable(format!("a thread for ROS 1: {e}")))?,
        );
        Ok(())
    }

    /// Ends a node: stops accepting; (with `flush`) writes what is pending
    /// to each subscriber, half-closes and waits (up to 0.5 s) for the
    /// subscriber to close its side — it has then read everything, the
    /// zero command included; unregisters from the master if it answers;
    /// ends the threads. Returns what could not be confirmed.
    fn shutdown(node: &mut Node, flush: bool) -> Option<String> {
        node.accept_stop.store(true, Ordering::Relaxed);
        let mut unconfirmed = Vec::new();
        if flush {
            let deadline = Instant::now() + Duration::from_millis(500);
            let mut subscribers = std::mem::take(&mut *lock(&node.subscribers));
            for sub in &mut subscribers {
                let wrote = sub
                    .stream
                    .set_nonblocking(false)
                    .and_then(|()| {
                        sub.stream
                            .set_write_timeout(Some(Duration::from_millis(200)))
                    })
                    .and_then(|()| std::io::Write::write_all(&mut sub.stream, &sub.pending))
                    .and_then(|()| sub.stream.shutdown(Shutdown::Write));
                if wrote.is_err() {
                    unconfirmed.push(sub.caller_id.clone());
                    continue;
                }
                // The subscriber closes once it has read up to our FIN.
                let mut sink = [0u8; 256];
                let confirmed = loop {
                    let left = deadline.saturating_duration_since(Instant::now());
                    if left.is_zero() || sub.stream.set_read_timeout(Some(left)).is_err() {
                        break false;
                    }
                    match sub.stream.read(&mut sink) {
                        Ok(0) => break true,
                        Ok(_) => {}
                        Err(e) if e.kind() == std::io::ErrorKind::ConnectionReset => break true,
                        Err(_) => break false,
                    }
                };
                if !confirmed {
                    unconfirmed.push(sub.caller_id.clone());
                }
            }
        }
        let shared = &node.shared;
        if !shared.lost_flag.load(Ordering::Acquire) {
            let ask = Duration::from_millis(500);
            let _ = node::master_call(
                shared,
                "unregisterPublisher",
                &[s(NODE_NAME), s(&shared.pub_topic), s(&shared.api_uri)],
                ask,
            );
            if let (true, Some(topic)) = (node.subscribed, &shared.sub_topic) {
                let _ = node::master_call(
                    shared,
                    "unregisterSubscriber",
                    &[s(NODE_NAME), s(topic), s(&shared.api_uri)],
                    ask,
                );
            }
        }
        shared.stop.store(true, Ordering::Relaxed);
        for t in node.threads.drain(..) {
            let _ = t.join();
        }
        lock(&node.subscribers).clear();
        (!unconfirmed.is_empty()).then(|| unconfirmed.join(", "))
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
            self.node = Some(self.start()?);
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
        match Self::shutdown(&mut node, true) {
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
            let _ = Self::shutdown(&mut node, true);
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
