//! A session with the ROS graph: connect (master, our slave API and
//! publication, the driver's subscriber, the tool pose, the master's
//! watch) and shut down (the zero confirmed, unregistered, threads ended).

use std::collections::HashSet;
use std::io::Read;
use std::net::{Shutdown, TcpListener};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use super::msg::{self, MsgType};
use super::node::{self, NODE_NAME, NodeContext};
use super::tcpros::{self, PoseSlot, Subscribers, lock};
use super::xmlrpc::{self, HttpUri, s};
use crate::arm::ArmError;

/// A connected node.
pub(super) struct Node {
    pub(super) shared: Arc<NodeContext>,
    pub(super) subscribers: Subscribers,
    /// Stops accepting subscribers (first step of the stop).
    pub(super) accept_stop: Arc<AtomicBool>,
    pub(super) threads: Vec<JoinHandle<()>>,
    pub(super) subscribed: bool,
}

/// What a session is for.
pub(super) struct Plan {
    /// The command topic and its message.
    pub(super) topic: String,
    pub(super) msg_type: MsgType,
    /// The tool-pose topic, if subscribed.
    pub(super) pose_topic: Option<String>,
    pub(super) connect_timeout: Duration,
    pub(super) master_check: Duration,
    /// What to start when nothing subscribes.
    pub(super) launch_hint: String,
}

fn unavailable(detail: String) -> ArmError {
    ArmError::Unavailable { detail }
}

/// Starts the node: registers the publisher, waits for the driver's
/// subscriber, then (with `tool_pose`) for the first pose.
pub(super) fn start(plan: &Plan) -> Result<Node, ArmError> {
    let topic = plan.topic.clone();
    let master_text = std::env::var("ROS_MASTER_URI").map_err(|_| {
        unavailable(format!(
            "ROS_MASTER_URI is not set: export ROS_MASTER_URI=http://HOST:11311 (the machine running roscore, e.g. http://localhost:11311) to publish {topic}"
        ))
    })?;
    let master = HttpUri::parse(&master_text).ok_or_else(|| {
        unavailable(format!(
            "ROS_MASTER_URI `{master_text}` is not http://HOST:PORT (e.g. http://localhost:11311)"
        ))
    })?;
    let no_master = |e: &dyn std::fmt::Display| {
        unavailable(format!(
            "no ROS master answers at {master_text} (ROS_MASTER_URI): {e}; is roscore running there (roscore, or the kinova launch file, which starts one)?"
        ))
    };
    let ask = plan
        .connect_timeout
        .clamp(Duration::from_millis(100), Duration::from_secs(3));
    // Our address: ROS_IP, ROS_HOSTNAME, else the one the master is
    // reached from (loopback for a local master).
    let host = match std::env::var("ROS_IP").or_else(|_| std::env::var("ROS_HOSTNAME")) {
        Ok(host) if !host.is_empty() => host,
        _ => {
            let probe =
                xmlrpc::connect_any(&master.host, master.port, ask).map_err(|e| no_master(&e))?;
            probe
                .local_addr()
                .map_err(|e| no_master(&e))?
                .ip()
                .to_string()
        }
    };
    let io = |what: &str, e: std::io::Error| unavailable(format!("{what}: {e}"));
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
    let shared = Arc::new(NodeContext {
        caller_id: NODE_NAME.into(),
        host: host.clone(),
        api_uri: format!("http://{host}:{api_port}/"),
        master,
        master_text: master_text.clone(),
        pub_topic: topic.clone(),
        tcpros_port,
        sub_topic: plan.pose_topic.clone(),
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
    if let Ok(other) = node::master_call(&shared, "lookupNode", &[s(NODE_NAME), s(NODE_NAME)], ask)
        && let Some(uri) = other.as_str().and_then(HttpUri::parse)
        && let Ok(other_pid) = node::api_call(&uri, "getPid", &[s(NODE_NAME)], ask)
    {
        return Err(unavailable(format!(
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
            .map_err(|e| unavailable(format!("a thread for ROS 1: {e}")))
    };
    let s2 = shared.clone();
    node.threads.push(spawn(
        "ros1-xmlrpc",
        Box::new(move || node::serve_slave_api(slave, s2)),
    )?);
    let (t, c, m, subs) = (
        topic.clone(),
        NODE_NAME.to_owned(),
        plan.msg_type,
        subscribers,
    );
    node.threads.push(spawn(
        "ros1-tcpros",
        Box::new(move || tcpros::serve_publication(publication, t, c, m, subs, accept_stop)),
    )?);
    let result = register(plan, &mut node, pid, ask);
    if let Err(e) = result {
        shutdown(&mut node, false);
        return Err(e);
    }
    Ok(node)
}

fn register(plan: &Plan, node: &mut Node, pid: i32, ask: Duration) -> Result<(), ArmError> {
    let shared = node.shared.clone();
    let topic = plan.topic.clone();
    let registering = |what: &str, e: xmlrpc::CallError| {
        unavailable(format!(
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
            s(plan.msg_type.name),
            s(&shared.api_uri),
        ],
        ask,
    )
    .map_err(|e| registering("registerPublisher", e))?;
    let deadline = Instant::now() + plan.connect_timeout;
    while lock(&node.subscribers).is_empty() {
        if shared.lost_flag.load(Ordering::Acquire) {
            return Err(unavailable(lock(&shared.lost).clone().unwrap_or_default()));
        }
        if Instant::now() >= deadline {
            return Err(unavailable(format!(
                "nothing subscribed to {topic} ({}) within {} ms (master {}): {}",
                plan.msg_type.name,
                plan.connect_timeout.as_millis(),
                shared.master_text,
                plan.launch_hint
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
        let deadline = Instant::now() + plan.connect_timeout;
        while lock(&shared.poses).count == 0 {
            if Instant::now() >= deadline {
                let why = lock(&shared.poses)
                    .error
                    .clone()
                    .map_or(String::new(), |e| format!(" (last problem: {e})"));
                return Err(unavailable(format!(
                    "no {} on {pose_topic} within {} ms{why}: is the kinova driver publishing its tool pose? (or set [arm.ros1] tool_pose = false to run on dead reckoning)",
                    msg::POSE_STAMPED.name,
                    plan.connect_timeout.as_millis()
                )));
            }
            thread::sleep(Duration::from_millis(5));
        }
    }
    let period = plan.master_check;
    let s2 = shared.clone();
    node.threads.push(
        thread::Builder::new()
            .name("ros1-master".into())
            .spawn(move || node::watch_master(s2, period, pid))
            .map_err(|e| unavailable(format!("a thread for ROS 1: {e}")))?,
    );
    Ok(())
}

/// Ends a node: stops accepting; (with `flush`) writes what is pending
/// to each subscriber, half-closes and waits (up to 0.5 s) for the
/// subscriber to close its side — it has then read everything, the
/// zero command included; unregisters from the master if it answers;
/// ends the threads. Returns what could not be confirmed.
pub(super) fn shutdown(node: &mut Node, flush: bool) -> Option<String> {
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
