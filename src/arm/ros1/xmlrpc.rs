//! The XML-RPC subset ROS 1 speaks (its master and slave APIs): values
//! (int, boolean, string, double, array), calls over HTTP POST with a
//! timeout, and the server side's request parsing and response writing.
//! Every input is bounded (1 MiB) and every failure is an error, never a
//! panic: the other side may be anything listening on that port.

use std::fmt::Write as _;
use std::io::{Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::time::Duration;

/// The largest HTTP message read.
const MAX_MESSAGE: usize = 1 << 20;

/// An XML-RPC value.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Int(i32),
    Bool(bool),
    Str(String),
    Double(f64),
    Array(Vec<Value>),
    /// A struct (only skipped over: ROS's APIs do not use them).
    Struct,
}

impl Value {
    pub fn as_int(&self) -> Option<i32> {
        match self {
            Value::Int(i) => Some(*i),
            _ => None,
        }
    }
    pub fn as_str(&self) -> Option<&str> {
        match self {
            Value::Str(s) => Some(s),
            _ => None,
        }
    }
    pub fn as_array(&self) -> Option<&[Value]> {
        match self {
            Value::Array(a) => Some(a),
            _ => None,
        }
    }

    fn write(&self, out: &mut String) {
        out.push_str("<value>");
        match self {
            Value::Int(i) => {
                let _ = write!(out, "<i4>{i}</i4>");
            }
            Value::Bool(b) => {
                let _ = write!(out, "<boolean>{}</boolean>", u8::from(*b));
            }
            Value::Str(s) => {
                out.push_str("<string>");
                escape(s, out);
                out.push_str("</string>");
            }
            Value::Double(d) => {
                let _ = write!(out, "<double>{d}</double>");
            }
            Value::Array(items) => {
                out.push_str("<array><data>");
                for item in items {
                    item.write(out);
                }
                out.push_str("</data></array>");
            }
            Value::Struct => out.push_str("<struct></struct>"),
        }
        out.push_str("</value>");
    }
}

/// A string value.
pub fn s(text: &str) -> Value {
    Value::Str(text.into())
}

fn escape(text: &str, out: &mut String) {
    for c in text.chars() {
        match c {
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '&' => out.push_str("&amp;"),
            '"' => out.push_str("&quot;"),
            c => out.push(c),
        }
    }
}

fn unescape(text: &str) -> String {
    if !text.contains('&') {
        return text.into();
    }
    text.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&amp;", "&")
}

/// A `methodCall` document.
pub fn call_body(method: &str, params: &[Value]) -> String {
    let mut out = String::from("<?xml version=\"1.0\"?><methodCall><methodName>");
    escape(method, &mut out);
    out.push_str("</methodName><params>");
    for p in params {
        out.push_str("<param>");
        p.write(&mut out);
        out.push_str("</param>");
    }
    out.push_str("</params></methodCall>");
    out
}

/// A `methodResponse` document carrying `value`.
pub fn response_body(value: &Value) -> String {
    let mut out = String::from("<?xml version=\"1.0\"?><methodResponse><params><param>");
    value.write(&mut out);
    out.push_str("</param></params></methodResponse>");
    out
}

/// Why a call failed.
#[derive(Debug)]
pub enum CallError {
    /// Nothing answered (refused, unreachable, timed out).
    Io(std::io::Error),
    /// Something answered, but not XML-RPC we understand.
    Protocol(String),
}

impl std::fmt::Display for CallError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CallError::Io(e) => write!(f, "{e}"),
            CallError::Protocol(e) => write!(f, "{e}"),
        }
    }
}

impl From<std::io::Error> for CallError {
    fn from(e: std::io::Error) -> Self {
        CallError::Io(e)
    }
}

/// An `http://host:port[/path]` address.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HttpUri {
    pub host: String,
    pub port: u16,
    pub path: String,
}

impl HttpUri {
    pub fn parse(uri: &str) -> Option<HttpUri> {
        let rest = uri.strip_prefix("http://")?;
        let (authority, path) = match rest.find('/') {
            Some(i) => (&rest[..i], &rest[i..]),
            None => (rest, "/"),
        };
        let (host, port) = authority.rsplit_once(':')?;
        let port = port.parse().ok()?;
        if host.is_empty() {
            return None;
        }
        Some(HttpUri {
            host: host.trim_start_matches('[').trim_end_matches(']').into(),
            port,
            path: path.into(),
        })
    }
}

/// Calls `method` at `uri`; every step bounded by `timeout`. Returns the
/// response's single value.
pub fn call(
    uri: &HttpUri,
    method: &str,
    params: &[Value],
    timeout: Duration,
) -> Result<Value, CallError> {
    let mut stream = connect_any(&uri.host, uri.port, timeout)?;
    stream.set_read_timeout(Some(timeout))?;
    stream.set_write_timeout(Some(timeout))?;
    stream.set_nodelay(true)?;
    let body = call_body(method, params);
    let request = format!(
        "POST {} HTTP/1.1\r\nHost: {}:{}\r\nContent-Type: text/xml\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{}",
        uri.path,
        uri.host,
        uri.port,
        body.len(),
        body
    );
    stream.write_all(request.as_bytes())?;
    let (_, body) = read_http(&mut stream)?;
    parse_response(&body)
}

/// Connects to the first of `host`'s addresses that answers (`localhost`
/// may name ::1 first, and a ROS 1 master listens on IPv4).
pub fn connect_any(host: &str, port: u16, timeout: Duration) -> std::io::Result<TcpStream> {
    let mut last = std::io::Error::new(
        std::io::ErrorKind::NotFound,
        format!("`{host}` has no address"),
    );
    for address in (host, port).to_socket_addrs()? {
        match TcpStream::connect_timeout(&address, timeout) {
            Ok(stream) => return Ok(stream),
            Err(e) => last = e,
        }
    }
    Err(last)
}

/// Reads one HTTP message: (head, body). The body's length is the
/// `Content-Length`, or up to the end of the stream.
pub fn read_http(stream: &mut TcpStream) -> Result<(String, String), CallError> {
    let mut data = Vec::with_capacity(1024);
    let mut chunk = [0u8; 4096];
    let head_end = loop {
        if let Some(i) = find(&data, b"\r\n\r\n") {
            break i;
        }
        let n = stream.read(&mut chunk)?;
        if n == 0 {
            return Err(CallError::Protocol(
                "the connection closed mid-header".into(),
            ));
        }
        data.extend_from_slice(&chunk[..n]);
        if data.len() > MAX_MESSAGE {
            return Err(CallError::Protocol("an HTTP header over 1 MiB".into()));
        }
    };
    let head = String::from_utf8_lossy(&data[..head_end]).into_owned();
    let length = head.lines().find_map(|line| {
        let (name, value) = line.split_once(':')?;
        name.trim()
            .eq_ignore_ascii_case("content-length")
            .then(|| value.trim().parse::<usize>().ok())?
    });
    let mut body = data[head_end + 4..].to_vec();
    match length {
        Some(length) if length > MAX_MESSAGE => {
            return Err(CallError::Protocol("an HTTP body over 1 MiB".into()));
        }
        Some(length) => {
            while body.len() < length {
                let n = stream.read(&mut chunk)?;
                if n == 0 {
                    return Err(CallError::Protocol("the connection closed mid-body".into()));
                }
                body.extend_from_slice(&chunk[..n]);
            }
            body.truncate(length);
        }
        None => loop {
            let n = stream.read(&mut chunk)?;
            if n == 0 {
                break;
            }
            body.extend_from_slice(&chunk[..n]);
            if body.len() > MAX_MESSAGE {
                return Err(CallError::Protocol("an HTTP body over 1 MiB".into()));
            }
        },
    }
    let body = String::from_utf8(body)
        .map_err(|_| CallError::Protocol("an XML-RPC body that is not UTF-8".into()))?;
    Ok((head, body))
}

fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

/// A `methodResponse`'s value (a `fault` is an error).
pub fn parse_response(xml: &str) -> Result<Value, CallError> {
    let mut p = Parser::new(xml);
    p.open("methodResponse")?;
    if p.peek_open("fault") {
        p.open("fault")?;
        let fault = p.value()?;
        return Err(CallError::Protocol(format!("XML-RPC fault: {fault:?}")));
    }
    p.open("params")?;
    p.open("param")?;
    p.value()
}

/// A `methodCall`: its method and parameters.
pub fn parse_call(xml: &str) -> Result<(String, Vec<Value>), CallError> {
    let mut p = Parser::new(xml);
    p.open("methodCall")?;
    p.open("methodName")?;
    let method = unescape(p.text().trim());
    p.close("methodName")?;
    let mut params = Vec::new();
    if p.peek_open("params") {
        p.open("params")?;
        while p.peek_open("param") {
            p.open("param")?;
            params.push(p.value()?);
            p.close("param")?;
        }
    }
    Ok((method, params))
}

/// A forward-only reader of the XML-RPC subset: tags and text, no
/// attributes, no CDATA.
struct Parser<'a> {
    rest: &'a str,
}

impl<'a> Parser<'a> {
    fn new(xml: &'a str) -> Self {
        Parser { rest: xml }
    }

    fn error(&self, what: &str) -> CallError {
        let near: String = self.rest.chars().take(40).collect();
        CallError::Protocol(format!("XML-RPC: expected {what} near `{near}`"))
    }

    /// Skips whitespace, the XML declaration and comments.
    fn skip(&mut self) {
        loop {
            self.rest = self.rest.trim_start();
            if let Some(r) = self.rest.strip_prefix("<?") {
                self.rest = r.find("?>").map_or("", |i| &r[i + 2..]);
            } else if let Some(r) = self.rest.strip_prefix("<!--") {
                self.rest = r.find("-->").map_or("", |i| &r[i + 3..]);
            } else {
                return;
            }
        }
    }

    /// The next tag's name if it is an opening tag (`<name>` or `<name/>`).
    fn next_open(&mut self) -> Option<(&'a str, bool)> {
        self.skip();
        let r = self.rest.strip_prefix('<')?;
        if r.starts_with('/') {
            return None;
        }
        let end = r.find('>')?;
        let inner = &r[..end];
        let empty = inner.ends_with('/');
        let name = inner.trim_end_matches('/').split_whitespace().next()?;
        Some((name, empty))
    }

    fn peek_open(&mut self, name: &str) -> bool {
        self.next_open().is_some_and(|(n, _)| n == name)
    }

    /// Consumes `<name>`; returns whether it was `<name/>`.
    fn open(&mut self, name: &str) -> Result<bool, CallError> {
        match self.next_open() {
            Some((n, empty)) if n == name => {
                let end = self.rest.find('>').unwrap_or(self.rest.len());
                self.rest = self.rest.get(end + 1..).unwrap_or("");
                Ok(empty)
            }
            _ => Err(self.error(&format!("<{name}>"))),
        }
    }

    fn close(&mut self, name: &str) -> Result<(), CallError> {
        self.skip();
        let tag = format!("</{name}>");
        match self.rest.strip_prefix(tag.as_str()) {
            Some(r) => {
                self.rest = r;
                Ok(())
            }
            None => Err(self.error(&tag)),
        }
    }

    /// Text up to the next `<` (not trimmed).
    fn text(&mut self) -> &'a str {
        let end = self.rest.find('<').unwrap_or(self.rest.len());
        let (text, rest) = self.rest.split_at(end);
        self.rest = rest;
        text
    }

    /// One `<value>…</value>`.
    fn value(&mut self) -> Result<Value, CallError> {
        if self.open("value")? {
            return Ok(Value::Str(String::new()));
        }
        // A bare string: <value>text</value>.
        let before = self.rest;
        let bare = self.text();
        if self.rest.starts_with("</value>") {
            self.close("value")?;
            return Ok(Value::Str(unescape(bare)));
        }
        self.rest = before;
        let Some((kind, empty)) = self.next_open() else {
            return Err(self.error("a value type"));
        };
        let kind = kind.to_owned();
        self.open(&kind)?;
        let value = if empty {
            match kind.as_str() {
                "string" => Value::Str(String::new()),
                "array" => Value::Array(Vec::new()),
                "struct" => Value::Struct,
                _ => return Err(self.error("a value")),
            }
        } else {
            let v = match kind.as_str() {
                "int" | "i4" | "i8" => {
                    let t = self.text().trim();
                    Value::Int(t.parse().map_err(|_| self.error("an int"))?)
                }
                "boolean" => Value::Bool(self.text().trim() == "1"),
                "string" => Value::Str(unescape(self.text())),
                "double" => {
                    let t = self.text().trim();
                    Value::Double(t.parse().map_err(|_| self.error("a double"))?)
                }
                "array" => {
                    let mut items = Vec::new();
                    if !self.open("data")? {
                        while self.peek_open("value") {
                            items.push(self.value()?);
                        }
                        self.close("data")?;
                    }
                    Value::Array(items)
                }
                "struct" => {
                    while self.peek_open("member") {
                        self.open("member")?;
                        self.open("name")?;
                        self.text();
                        self.close("name")?;
                        self.value()?;
                        self.close("member")?;
                    }
                    Value::Struct
                }
                _ => return Err(self.error("a known value type")),
            };
            self.close(&kind)?;
            v
        };
        self.close("value")?;
        Ok(value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_call_reads_back() {
        let params = [
            s("/sipnpuff"),
            s("a<b&c"),
            Value::Array(vec![Value::Array(vec![s("TCPROS")]), Value::Int(-3)]),
            Value::Bool(true),
            Value::Double(0.5),
        ];
        let body = call_body("requestTopic", &params);
        let (method, read) = parse_call(&body).unwrap();
        assert_eq!(method, "requestTopic");
        assert_eq!(read, params);
    }

    #[test]
    fn pythons_responses_read() {
        // As Python's xmlrpc.server writes them (rosmaster, rospy).
        let xml = "<?xml version='1.0'?>\n<methodResponse>\n<params>\n<param>\n<value><array><data>\n<value><int>1</int></value>\n<value><string>Registered [/x] as publisher of [/t]</string></value>\n<value><array><data>\n<value><string>http://host:4321/</string></value>\n</data></array></value>\n</data></array></value>\n</param>\n</params>\n</methodResponse>\n";
        let v = parse_response(xml).unwrap();
        let a = v.as_array().unwrap();
        assert_eq!(a[0].as_int(), Some(1));
        assert_eq!(
            a[2].as_array().unwrap()[0].as_str(),
            Some("http://host:4321/")
        );
        // A bare string and an empty array.
        let xml = "<methodResponse><params><param><value><array><data><value>ok</value><value><array><data/></array></value><value><struct><member><name>a</name><value><int>1</int></value></member></struct></value></data></array></value></param></params></methodResponse>";
        let v = parse_response(xml).unwrap();
        assert_eq!(
            v,
            Value::Array(vec![s("ok"), Value::Array(vec![]), Value::Struct])
        );
    }

    #[test]
    fn garbage_is_an_error_not_a_panic() {
        for xml in [
            "",
            "<methodResponse>",
            "<methodResponse><params><param><value><int>x</int></value>",
            "<methodResponse><fault><value><string>no</string></value></fault></methodResponse>",
            "<<<>>>",
            "<methodCall><methodName>a",
        ] {
            assert!(parse_response(xml).is_err(), "{xml}");
            let _ = parse_call(xml);
        }
    }

    #[test]
    fn uris_parse() {
        let u = HttpUri::parse("http://127.0.0.1:11311/").unwrap();
        assert_eq!(
            (u.host.as_str(), u.port, u.path.as_str()),
            ("127.0.0.1", 11311, "/")
        );
        let u = HttpUri::parse("http://robot:1234").unwrap();
        assert_eq!(
            (u.host.as_str(), u.port, u.path.as_str()),
            ("robot", 1234, "/")
        );
        for bad in [
            "",
            "robot:11311",
            "http://robot",
            "http://:1/",
            "http://h:x/",
        ] {
            assert!(HttpUri::parse(bad).is_none(), "{bad}");
        }
    }
}
