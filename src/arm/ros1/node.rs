//! Our ROS 1 node: the master's API (register, unregister, getPid) and
//! the slave API other nodes call on us (requestTopic from the driver's
//! subscriber, publisherUpdate from the master about the tool pose's
//! publishers, shutdown when another node takes our name).

use std::collections::HashSet;
use std::io::Write;
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

use super::tcpros::{self, PoseSlot, lock};
use super::xmlrpc::{self, CallError, HttpUri, Value, s};

/// This node's name.
pub const NODE_NAME: &str = "/sipnpuff";

/// What the node's threads share.
pub struct NodeContext {
    /// Our node name, e.g. `/sipnpuff`.
    pub caller_id: String,
    /// The host other nodes reach us at.
    pub host: String,
    /// Our slave API, `http://host:port/`.
    pub api_uri: String,
    pub master: HttpUri,
    pub master_text: String,
    /// The command topic and the TCPROS port serving it.
    pub pub_topic: String,
    pub tcpros_port: u16,
    /// The tool-pose topic, when subscribed.
    pub sub_topic: Option<String>,
    pub poses: Arc<Mutex<PoseSlot>>,
    /// Publishers of the tool pose we are connected to (their slave URIs).
    pub pose_publishers: Mutex<HashSet<String>>,
    /// Set when the master told us to shut down (another node took our
    /// name) or stopped answering: the reason.
    pub lost: Mutex<Option<String>>,
    pub lost_flag: AtomicBool,
    /// Ends every thread.
    pub stop: Arc<AtomicBool>,
}

impl NodeContext {
    pub fn set_lost(&self, reason: String) {
        let mut lost = lock(&self.lost);
        if lost.is_none() {
            *lost = Some(reason);
        }
        self.lost_flag.store(true, Ordering::Release);
    }
}

/// A master call's result: `[code, status, value]` with code 1, else an
/// error carrying the status.
pub fn master_call(
    shared: &NodeContext,
    method: &str,
    params: &[Value],
    timeout: Duration,
) -> Result<Value, CallError> {
    api_call(&shared.master, method, params, timeout)
}

/// A ROS API call (master or slave): `[code, status, value]`, code 1.
pub fn api_call(
    uri: &HttpUri,
    method: &str,
    params: &[Value],
    timeout: Duration,
) -> Result<Value, CallError> {
    let v = xmlrpc::call(uri, method, params, timeout)?;
    let parts = v.as_array().unwrap_or(&[]);
    match parts {
        [code, status, value] if code.as_int() == Some(1) => {
            let _ = status;
            Ok(value.clone())
        }
        [code, status, _] => Err(CallError::Protocol(format!(
            "{method} answered {}: {}",
            code.as_int().unwrap_or(-1),
            status.as_str().unwrap_or("")
        ))),
        _ => Err(CallError::Protocol(format!(
            "{method} answered something that is not [code, status, value]"
        ))),
    }
}

/// Serves our slave API on `listener` until `shared.stop`.
pub fn serve_slave_api(listener: TcpListener, shared: Arc<NodeContext>) {
    if listener.set_nonblocking(true).is_err() {
        return;
    }
    while !shared.stop.load(Ordering::Relaxed) {
        match listener.accept() {
            Ok((stream, _)) => {
                // One at a time: these calls are rare and short.
                let _ = handle(stream, &shared);
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                thread::sleep(Duration::from_millis(5));
            }
            Err(_) => thread::sleep(Duration::from_millis(20)),
        }
    }
}

fn handle(mut stream: TcpStream, shared: &Arc<NodeContext>) -> Result<(), CallError> {
    stream.set_nonblocking(false)?;
    stream.set_read_timeout(Some(Duration::from_secs(2)))?;
    stream.set_write_timeout(Some(Duration::from_secs(2)))?;
    let (_, body) = xmlrpc::read_http(&mut stream)?;
    let reply = match xmlrpc::parse_call(&body) {
        Ok((method, params)) => answer(&method, &params, shared),
        Err(e) => api_reply(-1, &e.to_string(), Value::Int(0)),
    };
    let body = xmlrpc::response_body(&reply);
    let response = format!(
        "HTTP/1.1 200 OK\r\nContent-Type: text/xml\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{}",
        body.len(),
        body
    );
    stream.write_all(response.as_bytes())?;
    Ok(())
}

fn api_reply(code: i32, status: &str, value: Value) -> Value {
    Value::Array(vec![Value::Int(code), s(status), value])
}

fn answer(method: &str, params: &[Value], shared: &Arc<NodeContext>) -> Value {
    let param = |i: usize| params.get(i).and_then(Value::as_str).unwrap_or("");
    match method {
        "requestTopic" => {
            let tcpros = params
                .get(2)
                .and_then(Value::as_array)
                .unwrap_or(&[])
                .iter()
                .any(|p| {
                    p.as_array().and_then(|p| p.first()).and_then(Value::as_str) == Some("TCPROS")
                });
            if param(1) != shared.pub_topic {
                api_reply(
                    0,
                    &format!("{} is not published here", param(1)),
                    Value::Array(vec![]),
                )
            } else if !tcpros {
                api_reply(0, "only TCPROS is offered", Value::Array(vec![]))
            } else {
                api_reply(
                    1,
                    "ready",
                    Value::Array(vec![
                        s("TCPROS"),
                        s(&shared.host),
                        Value::Int(i32::from(shared.tcpros_port)),
                    ]),
                )
            }
        }
        "publisherUpdate" => {
            if shared.sub_topic.as_deref() == Some(param(1)) {
                let uris: Vec<String> = params
                    .get(2)
                    .and_then(Value::as_array)
                    .unwrap_or(&[])
                    .iter()
                    .filter_map(|v| v.as_str().map(str::to_owned))
                    .collect();
                let shared = shared.clone();
                // Not on this thread: connecting calls the publisher back.
                thread::spawn(move || connect_publishers(&shared, &uris));
            }
            api_reply(1, "", Value::Int(0))
        }
        "getPid" => api_reply(1, "", Value::Int(std::process::id() as i32)),
        "getMasterUri" => api_reply(1, "", s(&shared.master_text)),
        "getPublications" => api_reply(
            1,
            "",
            Value::Array(vec![Value::Array(vec![
                s(&shared.pub_topic),
                s("kinova_msgs"),
            ])]),
        ),
        "getSubscriptions" => api_reply(
            1,
            "",
            Value::Array(
                shared
                    .sub_topic
                    .iter()
                    .map(|t| Value::Array(vec![s(t), s(super::msg::POSE_STAMPED.name)]))
                    .collect(),
            ),
        ),
        "getBusInfo" | "getBusStats" => api_reply(1, "", Value::Array(vec![])),
        "paramUpdate" => api_reply(1, "", Value::Int(0)),
        "shutdown" => {
            shared.set_lost(format!(
                "the ROS master shut this node down ({}: {}): another node named {} started?",
                param(0),
                param(1),
                shared.caller_id
            ));
            api_reply(1, "", Value::Int(0))
        }
        other => api_reply(-1, &format!("unknown method {other}"), Value::Int(0)),
    }
}

/// Connects to the tool pose's publishers we are not connected to yet
/// (each on its own thread, which forgets it when its connection ends).
pub fn connect_publishers(shared: &Arc<NodeContext>, uris: &[String]) {
    let Some(topic) = shared.sub_topic.clone() else {
        return;
    };
    for uri in uris {
        if shared.stop.load(Ordering::Relaxed) || !lock(&shared.pose_publishers).insert(uri.clone())
        {
            continue;
        }
        let shared = shared.clone();
        let uri = uri.clone();
        let topic = topic.clone();
        thread::spawn(move || {
            let result = HttpUri::parse(&uri)
                .ok_or_else(|| format!("a publisher URI `{uri}` that is not http://host:port/"))
                .and_then(|api| {
                    let protocols = Value::Array(vec![Value::Array(vec![s("TCPROS")])]);
                    let params = [s(&shared.caller_id), s(&topic), protocols];
                    api_call(&api, "requestTopic", &params, Duration::from_secs(2))
                        .map_err(|e| format!("requestTopic at {uri}: {e}"))
                })
                .and_then(|v| match v.as_array().unwrap_or(&[]) {
                    [p, host, port] if p.as_str() == Some("TCPROS") => Ok((
                        host.as_str().unwrap_or("").to_owned(),
                        port.as_int().unwrap_or(0),
                    )),
                    _ => Err(format!("requestTopic at {uri}: no TCPROS address")),
                })
                .and_then(|(host, port)| {
                    let port = u16::try_from(port).map_err(|_| format!("port {port}"))?;
                    tcpros::receive_poses(
                        host,
                        port,
                        topic.clone(),
                        shared.caller_id.clone(),
                        shared.poses.clone(),
                        shared.stop.clone(),
                    )
                    .map_err(|e| format!("{topic} from {uri}: {e}"))
                });
            if let Err(e) = result {
                lock(&shared.poses).error = Some(e);
            }
            lock(&shared.pose_publishers).remove(&uri);
        });
    }
}

/// Asks the master for its pid every `period` until `shared.stop`: no
/// answer, or another pid (a new master), marks the master lost.
pub fn watch_master(shared: Arc<NodeContext>, period: Duration, pid: i32) {
    let timeout = period.max(Duration::from_millis(200));
    let mut next = Instant::now() + period;
    let mut last_ok = Instant::now();
    while !shared.stop.load(Ordering::Relaxed) {
        let now = Instant::now();
        if now < next {
            thread::sleep((next - now).min(Duration::from_millis(20)));
            continue;
        }
        next += period;
        match master_call(&shared, "getPid", &[s(&shared.caller_id)], timeout) {
            Ok(v) if v.as_int() == Some(pid) => last_ok = Instant::now(),
            Ok(v) => {
                shared.set_lost(format!(
                    "the ROS master at {} restarted (pid {} → {:?}): its registrations are gone",
                    shared.master_text, pid, v
                ));
                return;
            }
            Err(e) => {
                if shared.stop.load(Ordering::Relaxed) {
                    return;
                }
                shared.set_lost(format!(
                    "the ROS master at {} stopped answering (getPid: {e}; {} ms after its last answer)",
                    shared.master_text,
                    Instant::now().duration_since(last_ok).as_millis()
                ));
                return;
            }
        }
    }
}
