//! `--output mqtt` against Debian's Mosquitto (`tests/peers/mqtt/install.sh`):
//! each test starts a broker of its own on a free port of 127.0.0.1 and an
//! independent subscriber (paho-mqtt 2.x, `tests/peers/mqtt/subscriber.py`)
//! that prints every message on every topic with its wall-clock receive
//! time, retain, QoS and DUP flags.
//!
//! What only a real broker shows, through `sipnpuff run --sensor csv:…
//! --output mqtt:127.0.0.1:PORT`: the discovery payloads field by field
//! against Home Assistant's documented schema and retained as the broker
//! keeps them (a stale trigger deleted), each match received exactly once
//! by an independent subscriber, availability `online` then `offline`,
//! discovery again when Home Assistant says `online`, the last will after
//! SIGKILL, a broker stalled and restarted mid-run (the event in flight
//! lost and never resent by the client or the broker), and the loop's
//! figures with and without MQTT; credentials against a broker's password
//! file, and `open`'s errors with no broker. The delivery's rules case by
//! case (waiting, expiry, the queue's cap, order, the close's bounds) are
//! unit tests on a simulated clock (`src/output/mqtt/delivery/tests.rs`).
//!
//! Skipped with a notice when the peers are not installed, unless
//! `SIPNPUFF_REQUIRE_PEERS=1` (CI), where that is a failure.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use serde_json::{Value, json};
use sipnpuff::control::target::HomeEvent;
use sipnpuff::output::Output;
use sipnpuff::output::mqtt::MqttOutput;
use sipnpuff::output::settings::MqttSettings;
use sipnpuff::sim::sensor_model::{SignalGenerator, SignalParams, Step, write_csv};

use crate::common::{Running, free_port, have_peer, poll_until, puff, rest, sip};
use crate::peers::quantile;
use crate::scratch::Scratch;

const MOSQUITTO: &str = "/usr/sbin/mosquitto";
const MOSQUITTO_PUB: &str = "/usr/bin/mosquitto_pub";
const MOSQUITTO_PASSWD: &str = "/usr/bin/mosquitto_passwd";
/// Longest wait for anything the broker or the subscriber should do.
const PATIENCE: Duration = Duration::from_secs(10);

const AVAILABILITY: &str = "sipnpuff/availability";
const EVENTS: &str = "sipnpuff/event";
const LIGHTS_CONFIG: &str = "homeassistant/device_automation/sipnpuff/lights_toggle/config";
const HELP_CONFIG: &str = "homeassistant/device_automation/sipnpuff/call_for_help/config";
const ENTITY_CONFIG: &str = "homeassistant/event/sipnpuff/home_events/config";
/// A trigger of an event no longer in [`LIBRARY`].
const OLD_CONFIG: &str = "homeassistant/device_automation/sipnpuff/old_event/config";

/// The library: two home events and an arm mode.
const LIBRARY: &str = "\
[detector]
stale_ms = 1000

[[sequence]]
actions = [-1, -1]
event = \"lights_toggle\"

[[sequence]]
actions = [1, 1]
event = \"call_for_help\"

[[sequence]]
actions = [-2, -2]
mode = \"translate_x\"
";

fn python() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("target/peers/paho/bin/python")
}

fn peer_script(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/peers/mqtt")
        .join(name)
}

/// Runs `test` in a scratch folder if Mosquitto and paho-mqtt are here; a
/// notice (or, under `SIPNPUFF_REQUIRE_PEERS=1`, a failure) when not.
fn mqtt_test(test: impl Fn(&Scratch)) {
    let paho = Command::new(python())
        .args(["-c", "import paho.mqtt"])
        .output()
        .is_ok_and(|o| o.status.success());
    let ok = Path::new(MOSQUITTO).exists() && Path::new(MOSQUITTO_PUB).exists() && paho;
    let missing = (!ok).then(|| {
        "Mosquitto (mosquitto, mosquitto-clients) or paho-mqtt in target/peers/paho is not installed: run tests/peers/mqtt/install.sh as root".into()
    });
    if have_peer(missing) {
        let dir = Scratch::new();
        // The broker drops root for the `mosquitto` user: it reads its
        // password file from here.
        std::fs::set_permissions(&*dir, std::os::unix::fs::PermissionsExt::from_mode(0o755))
            .unwrap();
        test(&dir);
    }
}

/// A Mosquitto broker on its own port.
struct Broker {
    port: u16,
    conf: PathBuf,
    process: Option<Running>,
}

impl Broker {
    /// Anonymous clients allowed.
    fn start(dir: &Path) -> Broker {
        Broker::with(dir, "allow_anonymous true\n")
    }

    /// With `auth` lines in its configuration.
    fn with(dir: &Path, auth: &str) -> Broker {
        let port = free_port();
        let conf = dir.join(format!("mosquitto-{port}.conf"));
        std::fs::write(
            &conf,
            format!("listener {port} 127.0.0.1\npersistence false\n{auth}"),
        )
        .unwrap();
        let mut broker = Broker {
            port,
            conf,
            process: None,
        };
        broker.spawn();
        broker
    }

    fn spawn(&mut self) {
        let mut command = Command::new(MOSQUITTO);
        command.arg("-c").arg(&self.conf);
        self.process = Some(Running::start(command));
        let port = self.port;
        assert!(
            poll_until(PATIENCE, Duration::from_millis(10), || {
                std::net::TcpStream::connect(("127.0.0.1", port)).is_ok()
            }),
            "mosquitto did not open port {port}"
        );
    }

    /// SIGKILL: no goodbye to anyone, nothing kept.
    fn kill(&mut self) {
        if let Some(process) = self.process.take() {
            process.signal(libc::SIGKILL);
            let _ = process.finish();
        }
    }

    /// Killed, then started again on the same port.
    fn restart(&mut self) {
        self.kill();
        self.spawn();
    }

    fn signal(&self, signal: libc::c_int) {
        if let Some(process) = &self.process {
            process.signal(signal);
        }
    }

    /// Publishes as a third client (Home Assistant's birth, a stale config).
    fn publish(&self, topic: &str, payload: &str, retain: bool) {
        let mut command = Command::new(MOSQUITTO_PUB);
        command
            .args(["-h", "127.0.0.1", "-p", &self.port.to_string()])
            .args(["-q", "1", "-t", topic, "-m", payload]);
        if retain {
            command.arg("-r");
        }
        let status = crate::watchdog::output(&mut command).status;
        assert!(status.success(), "mosquitto_pub {topic}");
    }

    fn mqtt_arg(&self) -> String {
        format!("mqtt:127.0.0.1:{}", self.port)
    }

    fn settings(&self) -> MqttSettings {
        MqttSettings {
            port: self.port,
            ..MqttSettings::default()
        }
    }
}

impl Drop for Broker {
    fn drop(&mut self) {
        self.kill();
    }
}

/// One message as the independent subscriber received it.
#[derive(Debug, Clone)]
struct Msg {
    t_ns: i64,
    topic: String,
    payload: String,
    retain: bool,
    qos: u64,
    dup: bool,
}

impl Msg {
    fn json(&self) -> Value {
        serde_json::from_str(&self.payload)
            .unwrap_or_else(|e| panic!("{}: {e}: {}", self.topic, self.payload))
    }
}

/// The independent subscriber: every topic, QoS 1.
struct Subscriber {
    process: Running,
    got: Vec<Msg>,
    subscribed: u64,
}

impl Subscriber {
    /// Started and subscribed.
    fn start(port: u16) -> Subscriber {
        let mut command = Command::new(python());
        command
            .arg(peer_script("subscriber.py"))
            .args(["--port", &port.to_string()])
            .env("PYTHONUNBUFFERED", "1");
        let mut subscriber = Subscriber {
            process: Running::start(command),
            got: Vec::new(),
            subscribed: 0,
        };
        subscriber.wait("its subscription", |s| s.subscribed >= 1);
        subscriber
    }

    /// Reads lines until `done` holds; fails the test after [`PATIENCE`].
    fn wait(&mut self, what: &str, done: impl Fn(&Subscriber) -> bool) {
        let deadline = Instant::now() + PATIENCE;
        while !done(self) {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.process.lines.recv_timeout(left) {
                Ok(line) => self.take(&line),
                Err(_) => panic!(
                    "the subscriber never saw {what}; it got:\n{}",
                    self.listing()
                ),
            }
        }
    }

    /// Reads whatever arrives for `span`.
    fn linger(&mut self, span: Duration) {
        let deadline = Instant::now() + span;
        while let Ok(line) = self
            .process
            .lines
            .recv_timeout(deadline.saturating_duration_since(Instant::now()))
        {
            self.take(&line);
        }
    }

    fn take(&mut self, line: &str) {
        let v: Value = serde_json::from_str(line).unwrap_or_else(|e| panic!("{line}: {e}"));
        if let Some(n) = v["subscribed"].as_u64() {
            self.subscribed = n;
        } else if v.get("t_ns").is_some() {
            self.got.push(Msg {
                t_ns: v["t_ns"].as_i64().unwrap(),
                topic: v["topic"].as_str().unwrap().into(),
                payload: v["payload"].as_str().unwrap().into(),
                retain: v["retain"].as_bool().unwrap(),
                qos: v["qos"].as_u64().unwrap(),
                dup: v["dup"].as_bool().unwrap(),
            });
        }
    }

    fn on(&self, topic: &str) -> Vec<&Msg> {
        self.got.iter().filter(|m| m.topic == topic).collect()
    }

    /// The event messages, parsed.
    fn events(&self) -> Vec<Value> {
        self.on(EVENTS).iter().map(|m| m.json()).collect()
    }

    fn listing(&self) -> String {
        self.got
            .iter()
            .map(|m| {
                format!(
                    "  {} retain={} qos={} dup={} {}",
                    m.topic, m.retain, m.qos, m.dup, m.payload
                )
            })
            .collect::<Vec<_>>()
            .join("\n")
    }
}

fn event(name: &str) -> HomeEvent {
    HomeEvent::new(name).unwrap()
}

/// One home event breathed: two short puffs (`lights_toggle`) or two
/// short sips (`call_for_help`), then a rest.
fn breathe(script: &mut Vec<Step>, lights: bool) {
    let breath = if lights { puff } else { sip };
    script.extend([breath(150), rest(350), breath(150), rest(700)]);
}

/// Writes the library and a recording of `events` (true: lights, false:
/// help) with `pause_after` ms of rest after the event of that index;
/// returns their paths.
fn session(dir: &Path, events: &[bool], pause_after: Option<(usize, u32)>) -> (String, String) {
    let library = dir.join("library.toml");
    std::fs::write(&library, LIBRARY).unwrap();
    let config = sipnpuff::config::Config::from_file(&library).unwrap();
    let mut script = vec![rest(1000)];
    for (i, &lights) in events.iter().enumerate() {
        breathe(&mut script, lights);
        if let Some((after, ms)) = pause_after
            && after == i
        {
            script.push(rest(ms));
        }
    }
    script.push(rest(500));
    let params = SignalParams::clean(config.core().detector(), 7);
    let csv = dir.join("session.csv");
    let mut file = std::io::BufWriter::new(std::fs::File::create(&csv).unwrap());
    write_csv(&mut file, SignalGenerator::new(params, &script)).unwrap();
    drop(file);
    (
        library.to_str().unwrap().into(),
        csv.to_str().unwrap().into(),
    )
}

/// The run's own match lines of home events: (tick, event, sequence).
fn matches(lines: &[String]) -> Vec<(u64, String, Value)> {
    lines
        .iter()
        .filter(|l| l.contains("\"home_event\""))
        .map(|l| {
            let v: Value = serde_json::from_str(l).unwrap();
            (
                v["tick"].as_u64().unwrap(),
                v["home_event"].as_str().unwrap().to_owned(),
                v["sequence"].clone(),
            )
        })
        .collect()
}

fn report(lines: &[String]) -> Value {
    let last = lines.last().expect("a report line");
    serde_json::from_str(last).unwrap_or_else(|e| panic!("{last}: {e}"))
}

/// Every match received exactly once, as the run said it (tick, event,
/// sequence), nothing else, none with DUP; returns the delays match →
/// subscriber, ms.
fn assert_each_once(sub: &Subscriber, matched: &[(u64, String, Value)]) -> Vec<f64> {
    let events = sub.events();
    let mut delays = Vec::new();
    for (tick, name, sequence) in matched {
        let got: Vec<(&Msg, Value)> = sub
            .on(EVENTS)
            .into_iter()
            .map(|m| (m, m.json()))
            .filter(|(_, v)| v["tick"] == *tick)
            .collect();
        assert_eq!(
            got.len(),
            1,
            "the match at tick {tick} ({name}) received {} times:\n{}",
            got.len(),
            sub.listing()
        );
        let (msg, v) = &got[0];
        assert_eq!(v["event_type"], name.as_str());
        assert_eq!(v["sequence"], *sequence);
        assert_eq!(
            v.as_object().unwrap().keys().collect::<Vec<_>>(),
            ["event_type", "tick", "sequence", "matched_at_ms"]
        );
        assert!(!msg.retain && !msg.dup, "{msg:?}");
        assert_eq!(msg.qos, 1, "{msg:?}");
        delays.push(msg.t_ns as f64 / 1e6 - v["matched_at_ms"].as_f64().unwrap());
    }
    assert_eq!(
        events.len(),
        matched.len(),
        "event messages vs the run's matches:\n{}",
        sub.listing()
    );
    delays
}

/// Median and worst of `delays`, for the test's output.
fn latency(delays: &[f64]) -> String {
    let mut sorted = delays.to_vec();
    sorted.sort_by(f64::total_cmp);
    format!(
        "match → subscriber over {} events: median {:.2} ms, worst {:.2} ms",
        sorted.len(),
        quantile(&sorted, 0.5),
        quantile(&sorted, 1.0)
    )
}

/// Home Assistant's documented schema of an MQTT device trigger
/// (`device_trigger.mqtt`): the required keys and their types.
fn check_trigger_schema(c: &Value) {
    assert_eq!(c["automation_type"], "trigger", "{c}");
    for key in ["topic", "type", "subtype", "payload", "value_template"] {
        assert!(c[key].is_string(), "{key} in {c}");
    }
    let topic = c["topic"].as_str().unwrap();
    assert!(!topic.contains(['+', '#']), "a topic, not a filter: {c}");
    assert!([0, 1, 2].contains(&c["qos"].as_u64().unwrap()), "{c}");
    check_device_schema(&c["device"]);
}

/// Home Assistant's documented schema of an MQTT `event` entity.
fn check_event_schema(c: &Value) {
    for key in ["state_topic", "unique_id", "availability_topic", "name"] {
        assert!(c[key].is_string(), "{key} in {c}");
    }
    let types = c["event_types"].as_array().unwrap();
    assert!(
        !types.is_empty() && types.iter().all(Value::is_string),
        "{c}"
    );
    assert!(
        ["button", "doorbell", "motion"].contains(&c["device_class"].as_str().unwrap()),
        "{c}"
    );
    check_device_schema(&c["device"]);
}

fn check_device_schema(d: &Value) {
    let ids = d["identifiers"].as_array().unwrap();
    assert!(!ids.is_empty() && ids.iter().all(Value::is_string), "{d}");
    for key in ["name", "manufacturer", "model", "sw_version"] {
        assert!(d[key].is_string(), "{key} in {d}");
    }
}

/// The discovery configs, exactly, as Home Assistant must receive them.
fn expected_configs() -> Vec<(&'static str, Value)> {
    let version = env!("CARGO_PKG_VERSION");
    let device = json!({
        "identifiers": ["sipnpuff"],
        "name": "sipnpuff",
        "manufacturer": "sipnpuff",
        "model": "Sip-and-puff interface",
        "sw_version": version,
    });
    let origin = json!({"name": "sipnpuff", "sw_version": version});
    let trigger = |name: &str| {
        json!({
            "automation_type": "trigger",
            "topic": "sipnpuff/event",
            "value_template": "{{ value_json.event_type }}",
            "payload": name,
            "type": "button_short_press",
            "subtype": name,
            "qos": 1,
            "device": device,
            "origin": origin,
        })
    };
    vec![
        (LIGHTS_CONFIG, trigger("lights_toggle")),
        (HELP_CONFIG, trigger("call_for_help")),
        (
            ENTITY_CONFIG,
            json!({
                "name": "Home event",
                "unique_id": "sipnpuff_home_events",
                "state_topic": "sipnpuff/event",
                "event_types": ["lights_toggle", "call_for_help"],
                "device_class": "button",
                "availability_topic": "sipnpuff/availability",
                "payload_available": "online",
                "payload_not_available": "offline",
                "qos": 1,
                "device": device,
                "origin": origin,
            }),
        ),
    ]
}

/// A config as received matches Home Assistant's schema and the expected
/// config exactly, and the entity's triggers fire on the events' own
/// messages (Home Assistant's `value_template`, then `payload`).
fn assert_config(msg: &Msg) {
    let got = msg.json();
    let (_, expected) = expected_configs()
        .into_iter()
        .find(|(t, _)| *t == msg.topic)
        .unwrap_or_else(|| panic!("an unexpected config on {}", msg.topic));
    if msg.topic == ENTITY_CONFIG {
        check_event_schema(&got);
    } else {
        check_trigger_schema(&got);
    }
    assert_eq!(got, expected, "{}", msg.topic);
}

/// `value_template: "{{ value_json.event_type }}"` applied to each event
/// message, compared with each trigger's `payload`: the triggers that fire.
fn triggers_fired(sub: &Subscriber, config_topic: &str) -> usize {
    let config = sub.on(config_topic)[0].json();
    sub.events()
        .iter()
        .filter(|e| e["event_type"] == config["payload"])
        .count()
}

/// `--output mqtt` end to end: discovery (a stale trigger deleted), each
/// event once, availability, discovery again on Home Assistant's
/// `online`, what the broker keeps, the report; and the loop's figures
/// with and without MQTT in the same sitting.
#[test]
fn home_events_reach_an_independent_subscriber_once_each() {
    crate::common::real_time(|| {
        mqtt_test(|dir| {
            let broker = Broker::start(dir);
            // A trigger of an event the library no longer has, retained.
            broker.publish(OLD_CONFIG, r#"{"automation_type":"trigger"}"#, true);
            let mut sub = Subscriber::start(broker.port);
            let (library, csv) = session(dir, &[true, false], None);
            let sensor = format!("csv:{csv}");
            let base = ["run", "--sensor", &sensor, "--config", &library, "--json"];

            // The same recording without MQTT first.
            let (status, without_lines, stderr) = Running::spawn(&base).finish();
            assert!(status.success(), "{stderr}");
            let without = report(&without_lines);

            let mqtt = broker.mqtt_arg();
            let mut args = base.to_vec();
            args.extend(["--output", &mqtt]);
            let run = Running::spawn(&args);
            sub.wait("availability online", |s| {
                s.on(AVAILABILITY).iter().any(|m| m.payload == "online")
            });
            sub.wait("the first event", |s| !s.on(EVENTS).is_empty());
            // Home Assistant restarts: its birth message asks for discovery.
            broker.publish("homeassistant/status", "online", false);
            sub.wait("discovery again", |s| {
                expected_configs().iter().all(|(t, _)| s.on(t).len() == 2)
            });
            let (status, lines, stderr) = run.finish();
            assert!(status.success(), "{stderr}");
            sub.wait("availability offline", |s| {
                s.on(AVAILABILITY)
                    .last()
                    .is_some_and(|m| m.payload == "offline")
            });
            sub.linger(Duration::from_millis(200));

            // Availability: online, then offline after the clean stop, once each.
            let availability: Vec<&str> = sub
                .on(AVAILABILITY)
                .iter()
                .map(|m| m.payload.as_str())
                .collect();
            assert_eq!(
                availability,
                ["online", "online", "offline"],
                "{}",
                sub.listing()
            );

            // Discovery: each config at connect and on `online`, exact.
            for (topic, _) in expected_configs() {
                let got = sub.on(topic);
                assert_eq!(got.len(), 2, "{topic}:\n{}", sub.listing());
                for msg in got {
                    assert_eq!(msg.qos, 1, "{msg:?}");
                    assert_config(msg);
                }
            }

            // Every match once, as the run said it.
            let matched = matches(&lines);
            assert_eq!(
                matched.iter().map(|m| m.1.as_str()).collect::<Vec<_>>(),
                ["lights_toggle", "call_for_help"]
            );
            let delays = assert_each_once(&sub, &matched);
            assert_eq!(triggers_fired(&sub, LIGHTS_CONFIG), 1);
            assert_eq!(triggers_fired(&sub, HELP_CONFIG), 1);

            // The stale trigger deleted: an empty retained config.
            let old: Vec<&str> = sub
                .on(OLD_CONFIG)
                .iter()
                .map(|m| m.payload.as_str())
                .collect();
            assert_eq!(old, [r#"{"automation_type":"trigger"}"#, ""]);

            // The report: every event acknowledged, nothing lost.
            let with = report(&lines);
            let outputs = with["outputs"].as_array().unwrap();
            assert_eq!(outputs.len(), 1, "{with}");
            let o = &outputs[0];
            assert_eq!(
                o["output"],
                format!(
                    "mqtt 127.0.0.1:{} (device \"sipnpuff\", 2 home events)",
                    broker.port
                )
            );
            assert_eq!(
                (&o["applied"], &o["dropped"], &o["lost"]),
                (&json!(2), &json!(0), &json!(0)),
                "{o}"
            );
            assert_eq!(
                o["notes"],
                json!(["deleted 1 Home Assistant trigger(s) of events no longer in the library"]),
                "{o}"
            );

            // Retained: a subscriber that comes later gets the configs
            // and `offline`, flagged retained, and not the stale trigger.
            let mut late = Subscriber::start(broker.port);
            late.wait("the retained configs and availability", |s| {
                s.got.len() >= 4
            });
            late.linger(Duration::from_millis(200));
            let mut retained: Vec<(&str, &str)> = late
                .got
                .iter()
                .filter(|m| m.retain)
                .map(|m| (m.topic.as_str(), m.payload.as_str()))
                .collect();
            retained.sort();
            assert_eq!(retained.len(), 4, "{}", late.listing());
            assert_eq!(retained[0].0, HELP_CONFIG);
            assert_eq!(retained[1].0, LIGHTS_CONFIG);
            assert_eq!(retained[2].0, ENTITY_CONFIG);
            assert_eq!(retained[3], (AVAILABILITY, "offline"));
            for msg in &late.got {
                if msg.topic.ends_with("/config") {
                    assert_config(msg);
                }
            }

            // The loop with and without MQTT, same recording, same sitting.
            let figures = |r: &Value| {
                format!(
                    "{} ticks, {} missed deadlines, {} skipped, wake-up p99 {:.1} µs, max {:.1} µs, {} allocations",
                    r["stats"]["ticks_run"],
                    r["stats"]["missed_deadlines"],
                    r["stats"]["skipped_ticks"],
                    r["full"]["wake_latency_ns"]["p99"].as_f64().unwrap() / 1e3,
                    r["full"]["wake_latency_ns"]["max"].as_f64().unwrap() / 1e3,
                    r["control_thread_allocations"]
                )
            };
            eprintln!(
                "home_events: {}\n  loop without MQTT: {}\n  loop with MQTT:    {}",
                latency(&delays),
                figures(&without),
                figures(&with)
            );
            assert_eq!(without["control_thread_allocations"], 0);
            assert_eq!(with["control_thread_allocations"], 0);
        });
    });
}

/// SIGKILL: no goodbye, so the broker publishes the last will `offline`
/// (retained).
#[test]
fn the_last_will_says_offline_after_sigkill() {
    crate::common::real_time(|| {
        mqtt_test(|dir| {
            let broker = Broker::start(dir);
            let mut sub = Subscriber::start(broker.port);
            let (library, csv) = session(dir, &[true], Some((0, 30_000)));
            let run = Running::spawn(&[
                "run",
                "--sensor",
                &format!("csv:{csv}"),
                "--config",
                &library,
                "--output",
                &broker.mqtt_arg(),
            ]);
            sub.wait("availability online", |s| {
                s.on(AVAILABILITY).iter().any(|m| m.payload == "online")
            });
            run.signal(libc::SIGKILL);
            let killed = Instant::now();
            let (status, _, _) = run.finish();
            assert_eq!(status.code(), None, "killed by a signal");
            sub.wait("the last will", |s| {
                s.on(AVAILABILITY)
                    .last()
                    .is_some_and(|m| m.payload == "offline")
            });
            eprintln!(
                "the_last_will: `offline` {:.0} ms after SIGKILL",
                killed.elapsed().as_secs_f64() * 1e3
            );
            let mut late = Subscriber::start(broker.port);
            late.wait("the retained availability", |s| {
                !s.on(AVAILABILITY).is_empty()
            });
            let kept = late.on(AVAILABILITY)[0];
            assert_eq!((kept.payload.as_str(), kept.retain), ("offline", true));
        });
    });
}

/// The broker stalls mid-run (SIGSTOP: connected, reading nothing) while
/// a match goes out, then is killed and restarted: the loop goes on
/// through it all without allocating; the match in flight is lost and
/// sent again by neither the client nor the new broker; the one after
/// the restart arrives once; the report says so.
#[test]
fn a_broker_stalled_then_restarted_mid_run_loses_the_event_in_flight_only() {
    crate::common::real_time(|| {
        mqtt_test(|dir| {
            let mut broker = Broker::start(dir);
            let mut sub = Subscriber::start(broker.port);
            let (library, csv) = session(dir, &[true, false, true], Some((1, 1500)));
            let mut run = Running::spawn(&[
                "run",
                "--sensor",
                &format!("csv:{csv}"),
                "--config",
                &library,
                "--output",
                &broker.mqtt_arg(),
                "--json",
            ]);
            sub.wait("the first event", |s| s.on(EVENTS).len() == 1);
            // Its acknowledgement back first (stalled before it, the first
            // would be the one lost).
            std::thread::sleep(Duration::from_millis(100));
            broker.signal(libc::SIGSTOP);
            while matches(&run.seen).len() < 2 {
                run.wait_for("\"home_event\"");
            }
            // The second is written to the stalled broker, which dies.
            std::thread::sleep(Duration::from_millis(200));
            let killed = Instant::now();
            broker.restart();
            let away_ms = killed.elapsed().as_secs_f64() * 1e3;
            sub.wait("its subscription again", |s| s.subscribed >= 2);
            let (status, lines, stderr) = run.finish();
            assert!(status.success(), "{stderr}");
            sub.linger(Duration::from_millis(300));

            let matched = matches(&lines);
            assert_eq!(matched.len(), 3, "{lines:?}");
            let delivered = [matched[0].clone(), matched[2].clone()];
            let delays = assert_each_once(&sub, &delivered);
            let r = report(&lines);
            let o = &r["outputs"][0];
            eprintln!(
                "broker_stalled_then_restarted: broker away {away_ms:.0} ms; {}; report: {o}",
                latency(&delays)
            );
            assert_eq!(r["control_thread_allocations"], 0);
            assert_eq!((&o["applied"], &o["lost"]), (&json!(2), &json!(1)), "{o}");
            let notes = o["notes"].as_array().unwrap();
            assert_eq!(notes.len(), 2, "{o}");
            assert!(
                notes[0]
                    .as_str()
                    .unwrap()
                    .starts_with("the broker was unreachable for "),
                "{o}"
            );
            assert_eq!(
                notes[1],
                "1 event was lost: 1 sent as the connection broke, never acknowledged (not sent again: it may have arrived, never twice)"
            );
            // Discovery and `online` again on the new broker, which kept nothing.
            let online = sub
                .on(AVAILABILITY)
                .iter()
                .filter(|m| m.payload == "online")
                .count();
            assert_eq!(online, 2, "{}", sub.listing());
            assert_eq!(sub.on(ENTITY_CONFIG).len(), 2, "{}", sub.listing());
        });
    });
}

/// Credentials from an owner-only file are accepted by a broker that
/// needs them; a wrong password and a world-readable file are refused
/// before anything runs, and no error shows the password.
#[test]
fn credentials_come_from_an_owner_only_file() {
    mqtt_test(|dir| {
        let passwords = dir.join("passwords");
        let made = crate::watchdog::output(
            Command::new(MOSQUITTO_PASSWD)
                .arg("-c")
                .arg("-b")
                .arg(&passwords)
                .args(["home", "br3ath-s3cret"]),
        );
        assert!(made.status.success(), "{made:?}");
        std::fs::set_permissions(
            &passwords,
            std::os::unix::fs::PermissionsExt::from_mode(0o644),
        )
        .unwrap();
        let broker = Broker::with(
            dir,
            &format!(
                "allow_anonymous false\npassword_file {}\n",
                passwords.display()
            ),
        );
        let write = |name: &str, password: &str, mode: u32| {
            let path = dir.join(name);
            std::fs::write(
                &path,
                format!("username = \"home\"\npassword = \"{password}\"\n"),
            )
            .unwrap();
            std::fs::set_permissions(&path, std::os::unix::fs::PermissionsExt::from_mode(mode))
                .unwrap();
            path
        };
        let open = |file: Option<PathBuf>| {
            let settings = MqttSettings {
                credentials_file: file,
                ..broker.settings()
            };
            MqttOutput::open(&settings, &[event("lights_toggle")])
        };

        let mut output = open(Some(write("good.toml", "br3ath-s3cret", 0o600))).unwrap();
        let report = output.close();
        assert_eq!(report.notes, Vec::<String>::new());

        let wrong = open(Some(write("wrong.toml", "guess", 0o600)))
            .err()
            .unwrap();
        assert!(wrong.detail.contains("not authorised"), "{wrong}");
        assert!(!wrong.to_string().contains("guess"), "{wrong}");
        let anonymous = open(None).err().unwrap();
        assert!(anonymous.detail.contains("not authorised"), "{anonymous}");

        // A world-readable file: the command line refuses to start,
        // naming the file.
        write("open.toml", "br3ath-s3cret", 0o644);
        let config = dir.join("config.toml");
        std::fs::write(
            &config,
            format!(
                "{LIBRARY}\n[output.mqtt]\ncredentials_file = \"{}\"\n",
                dir.join("open.toml").display()
            ),
        )
        .unwrap();
        let (status, _, stderr) = Running::spawn(&[
            "run",
            "--config",
            config.to_str().unwrap(),
            "--output",
            &broker.mqtt_arg(),
        ])
        .finish();
        assert_eq!(status.code(), Some(1), "{stderr}");
        assert!(
            stderr.contains("open.toml is readable by every user"),
            "{stderr}"
        );
        assert!(!stderr.contains("br3ath"), "{stderr}");
    });
}

/// `open`'s errors, before anything runs: no broker, no event, TLS not
/// built in.
#[test]
fn open_says_what_is_wrong_before_the_run() {
    let settings = MqttSettings {
        port: free_port(),
        ..MqttSettings::default()
    };
    let e = MqttOutput::open(&settings, &[event("lights_toggle")])
        .err()
        .unwrap();
    assert_eq!(
        e.to_string(),
        format!(
            "output mqtt: cannot connect to the broker at 127.0.0.1:{}: connection refused (no broker listens there)",
            settings.port
        )
    );
    let e = MqttOutput::open(&settings, &[]).err().unwrap();
    assert!(e.detail.contains("fires no home event"), "{e}");
    if !cfg!(feature = "mqtt-tls") {
        let tls = MqttSettings {
            tls: true,
            ..settings
        };
        let e = MqttOutput::open(&tls, &[event("lights_toggle")])
            .err()
            .unwrap();
        assert!(e.detail.contains("--features mqtt-tls"), "{e}");
    }
}
