//! TCPROS: the connection header (a 4-byte length, then `key=value`
//! fields each with its own 4-byte length), our publication (a listener
//! the driver's subscriber connects to; each connection gets the framed
//! commands) and our subscription to the tool pose.

use std::collections::HashMap;
use std::io::{self, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread;
use std::time::Duration;

use nalgebra::Isometry3;

use super::msg::{self, MsgType};

/// The largest header or message read (a PoseStamped is ~70 bytes).
const MAX_READ: usize = 1 << 16;

/// A connection header's bytes.
pub fn encode_header(fields: &[(&str, &str)]) -> Vec<u8> {
    let mut body = Vec::new();
    for (key, value) in fields {
        let field = format!("{key}={value}");
        body.extend_from_slice(&(field.len() as u32).to_le_bytes());
        body.extend_from_slice(field.as_bytes());
    }
    let mut out = (body.len() as u32).to_le_bytes().to_vec();
    out.extend_from_slice(&body);
    out
}

/// Reads one length-prefixed block (a header or a message).
pub fn read_block(stream: &mut impl Read) -> io::Result<Vec<u8>> {
    let mut len = [0u8; 4];
    stream.read_exact(&mut len)?;
    let len = u32::from_le_bytes(len) as usize;
    if len > MAX_READ {
        return Err(io::Error::new(
            io::ErrorKind::InvalidData,
            format!("a TCPROS block of {len} bytes"),
        ));
    }
    let mut block = vec![0u8; len];
    stream.read_exact(&mut block)?;
    Ok(block)
}

/// A header block's fields.
pub fn decode_header(block: &[u8]) -> io::Result<HashMap<String, String>> {
    let bad = |what: &str| io::Error::new(io::ErrorKind::InvalidData, what.to_owned());
    let mut fields = HashMap::new();
    let mut at = 0;
    while at < block.len() {
        let len = block
            .get(at..at + 4)
            .ok_or_else(|| bad("a truncated header field length"))?;
        let len = u32::from_le_bytes([len[0], len[1], len[2], len[3]]) as usize;
        at += 4;
        let field = block
            .get(at..at + len)
            .ok_or_else(|| bad("a truncated header field"))?;
        at += len;
        let field = String::from_utf8_lossy(field);
        let (key, value) = field
            .split_once('=')
            .ok_or_else(|| bad("a header field without `=`"))?;
        fields.insert(key.to_owned(), value.to_owned());
    }
    Ok(fields)
}

/// One subscriber of our topic.
pub struct Subscriber {
    pub stream: TcpStream,
    /// Its node (`callerid`).
    pub caller_id: String,
    /// Bytes not yet taken by the socket (it was full).
    pub pending: Vec<u8>,
}

/// The subscribers connected to our publication.
pub type Subscribers = Arc<Mutex<Vec<Subscriber>>>;

/// Locks, whatever a panicking holder left (the list stays usable).
pub fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Accepts subscribers of `topic` until `stop`: checks each one's header
/// (topic, and type and md5sum equal to ours or `*`, as rospy's AnyMsg and
/// `rostopic` send), answers with ours, and adds it (non-blocking, no
/// Nagle) to `subscribers`.
pub fn serve_publication(
    listener: TcpListener,
    topic: String,
    caller_id: String,
    msg_type: MsgType,
    subscribers: Subscribers,
    stop: Arc<AtomicBool>,
) {
    if listener.set_nonblocking(true).is_err() {
        return;
    }
    while !stop.load(Ordering::Relaxed) {
        match listener.accept() {
            Ok((stream, _)) => {
                if let Some(subscriber) = handshake(stream, &topic, &caller_id, msg_type) {
                    lock(&subscribers).push(subscriber);
                }
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                thread::sleep(Duration::from_millis(2));
            }
            Err(_) => thread::sleep(Duration::from_millis(20)),
        }
    }
}

fn handshake(
    mut stream: TcpStream,
    topic: &str,
    caller_id: &str,
    msg_type: MsgType,
) -> Option<Subscriber> {
    stream.set_nonblocking(false).ok()?;
    stream.set_read_timeout(Some(Duration::from_secs(2))).ok()?;
    stream
        .set_write_timeout(Some(Duration::from_secs(2)))
        .ok()?;
    stream.set_nodelay(true).ok()?;
    let fields = decode_header(&read_block(&mut stream).ok()?).ok()?;
    let field = |key: &str| fields.get(key).map(String::as_str).unwrap_or("");
    let error = if field("topic") != topic {
        Some(format!("topic {} is not {topic}", field("topic")))
    } else if !matches!(field("md5sum"), "*" | "") && field("md5sum") != msg_type.md5sum {
        Some(format!(
            "md5sum {} of {} is not {} of {}",
            field("md5sum"),
            field("type"),
            msg_type.md5sum,
            msg_type.name
        ))
    } else if !matches!(field("type"), "*" | "") && field("type") != msg_type.name {
        Some(format!("type {} is not {}", field("type"), msg_type.name))
    } else {
        None
    };
    if let Some(error) = error {
        let _ = stream.write_all(&encode_header(&[("error", &error)]));
        return None;
    }
    let header = encode_header(&[
        ("callerid", caller_id),
        ("latching", "0"),
        ("md5sum", msg_type.md5sum),
        ("message_definition", msg_type.definition),
        ("topic", topic),
        ("type", msg_type.name),
    ]);
    stream.write_all(&header).ok()?;
    stream.set_nonblocking(true).ok()?;
    Some(Subscriber {
        stream,
        caller_id: field("callerid").to_owned(),
        pending: Vec::new(),
    })
}

/// Whether a subscriber's connection has closed (its end sent FIN or
/// RST), without blocking: a non-blocking peek.
pub fn closed(stream: &TcpStream) -> bool {
    let mut byte = [0u8; 1];
    match stream.peek(&mut byte) {
        Ok(0) => true,
        Ok(_) => false,
        Err(e) => !matches!(
            e.kind(),
            io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted
        ),
    }
}

/// Writes `frame` (after anything still pending) without blocking; what
/// the socket does not take stays pending. An error: the connection is
/// gone.
pub fn write_frame(subscriber: &mut Subscriber, frame: &[u8]) -> io::Result<()> {
    subscriber.pending.extend_from_slice(frame);
    flush_some(subscriber)
}

/// Writes what is pending, as far as the socket takes it.
pub fn flush_some(subscriber: &mut Subscriber) -> io::Result<()> {
    while !subscriber.pending.is_empty() {
        match subscriber.stream.write(&subscriber.pending) {
            Ok(0) => return Err(io::ErrorKind::WriteZero.into()),
            Ok(n) => {
                subscriber.pending.drain(..n);
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => return Ok(()),
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

/// The newest tool pose and how many have arrived.
#[derive(Debug, Default)]
pub struct PoseSlot {
    pub newest: Option<(String, Isometry3<f64>)>,
    pub count: u64,
    /// The last undecodable message's reason, if any.
    pub error: Option<String>,
}

/// Reads `PoseStamped` messages from a publisher at `host:port` into
/// `slot` until `stop` or the connection ends.
pub fn receive_poses(
    host: String,
    port: u16,
    topic: String,
    caller_id: String,
    slot: Arc<Mutex<PoseSlot>>,
    stop: Arc<AtomicBool>,
) -> io::Result<()> {
    let mut stream = super::xmlrpc::connect_any(&host, port, Duration::from_secs(2))?;
    stream.set_nodelay(true)?;
    stream.set_write_timeout(Some(Duration::from_secs(2)))?;
    stream.set_read_timeout(Some(Duration::from_secs(2)))?;
    stream.write_all(&encode_header(&[
        ("callerid", &caller_id),
        ("md5sum", msg::POSE_STAMPED.md5sum),
        ("topic", &topic),
        ("type", msg::POSE_STAMPED.name),
        ("tcp_nodelay", "1"),
    ]))?;
    let fields = decode_header(&read_block(&mut stream)?)?;
    if let Some(error) = fields.get("error") {
        return Err(io::Error::new(io::ErrorKind::InvalidData, error.clone()));
    }
    // Short reads so `stop` is seen; a partial read is kept, never lost.
    stream.set_read_timeout(Some(Duration::from_millis(50)))?;
    let mut len = [0u8; 4];
    let mut body = Vec::new();
    loop {
        if !read_full(&mut stream, &mut len, &stop)? {
            return Ok(());
        }
        let n = u32::from_le_bytes(len) as usize;
        if n > MAX_READ {
            return Err(io::Error::new(io::ErrorKind::InvalidData, "a huge message"));
        }
        body.resize(n, 0);
        if !read_full(&mut stream, &mut body, &stop)? {
            return Ok(());
        }
        let mut slot = lock(&slot);
        match msg::decode_pose_stamped(&body) {
            Ok(pose) => {
                slot.newest = Some(pose);
                slot.count += 1;
            }
            Err(e) => slot.error = Some(e),
        }
    }
}

/// Fills `buf` from a stream with a read timeout, through timeouts, until
/// `stop` (then `false`); the end of the stream is an error.
fn read_full(stream: &mut TcpStream, buf: &mut [u8], stop: &AtomicBool) -> io::Result<bool> {
    let mut at = 0;
    while at < buf.len() {
        if stop.load(Ordering::Relaxed) {
            return Ok(false);
        }
        match stream.read(&mut buf[at..]) {
            Ok(0) => return Err(io::ErrorKind::UnexpectedEof.into()),
            Ok(n) => at += n,
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock
                        | io::ErrorKind::TimedOut
                        | io::ErrorKind::Interrupted
                ) => {}
            Err(e) => return Err(e),
        }
    }
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headers_read_back() {
        let bytes = encode_header(&[("topic", "/a/b"), ("md5sum", "*"), ("x", "1=2")]);
        let fields = decode_header(&read_block(&mut &bytes[..]).unwrap()).unwrap();
        assert_eq!(fields["topic"], "/a/b");
        assert_eq!(fields["x"], "1=2");
        assert!(decode_header(&[9, 0, 0, 0, b'a']).is_err());
        assert!(read_block(&mut &[255u8, 255, 255, 255][..]).is_err());
    }

    /// A client's handshake with our publication: its response header.
    fn subscribe(port: u16, md5sum: &str, kind: &str) -> (TcpStream, HashMap<String, String>) {
        let mut stream = TcpStream::connect(("127.0.0.1", port)).unwrap();
        let header = encode_header(&[
            ("callerid", "/driver"),
            ("topic", "/ns/in/cartesian_velocity"),
            ("md5sum", md5sum),
            ("type", kind),
        ]);
        stream.write_all(&header).unwrap();
        let fields = decode_header(&read_block(&mut stream).unwrap()).unwrap();
        (stream, fields)
    }

    #[test]
    fn the_publication_checks_headers_and_sees_a_closed_subscriber() {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let port = listener.local_addr().unwrap().port();
        let subscribers: Subscribers = Arc::new(Mutex::new(Vec::new()));
        let stop = Arc::new(AtomicBool::new(false));
        let (s, st) = (subscribers.clone(), stop.clone());
        let server = thread::spawn(move || {
            serve_publication(
                listener,
                "/ns/in/cartesian_velocity".into(),
                "/sipnpuff".into(),
                msg::POSE_VELOCITY,
                s,
                st,
            )
        });
        // A wrong md5sum: an error header, not added.
        let (_, fields) = subscribe(port, "0123", "kinova_msgs/PoseVelocity");
        assert!(fields["error"].contains("md5sum 0123"), "{fields:?}");
        // AnyMsg's `*`: our header, added.
        let (mut client, fields) = subscribe(port, "*", "*");
        assert_eq!(fields["md5sum"], msg::POSE_VELOCITY.md5sum);
        assert_eq!(fields["type"], "kinova_msgs/PoseVelocity");
        while lock(&subscribers).is_empty() {
            thread::sleep(Duration::from_millis(1));
        }
        let mut frame = [0u8; msg::MAX_FRAME];
        let c = crate::control::motion::stream::ArmCommand {
            linear: [0.1, 0.0, 0.0],
            ..Default::default()
        };
        let len = msg::encode_command(&c, false, &mut frame);
        {
            let mut subs = lock(&subscribers);
            assert_eq!(subs[0].caller_id, "/driver");
            assert!(!closed(&subs[0].stream));
            write_frame(&mut subs[0], &frame[..len]).unwrap();
        }
        assert_eq!(read_block(&mut client).unwrap(), frame[4..len].to_vec());
        drop(client);
        // The close is seen without blocking, at once.
        let started = std::time::Instant::now();
        while !closed(&lock(&subscribers)[0].stream) {
            assert!(started.elapsed() < Duration::from_secs(5));
            thread::sleep(Duration::from_millis(1));
        }
        stop.store(true, Ordering::Relaxed);
        server.join().unwrap();
    }
}
