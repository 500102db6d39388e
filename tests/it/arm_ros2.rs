//! `--arm ros2:TOPIC` against an independent ROS 2 peer: Eclipse Cyclone
//! DDS (PyPI `cyclonedds`, the DDS under rmw_cyclonedds), running
//! `tests/peers/ros2/peer.py` (installed by `tests/peers/ros2/install.sh`).
//! The peer subscribes as a ROS 2 node would and writes every message with
//! its receive time; the tests compare that with the core's commands
//! (`run --record`'s `commands.bin`).
//!
//! Each test runs the peer and sipnpuff in a private network namespace (a
//! thread that `unshare`s its own, loopback only, multicast on): DDS
//! discovery stays on this machine, and parallel tests cannot cross. Needs
//! root (CI runs as root). Without the peer or root a test prints why and
//! passes, unless `SIPNPUFF_REQUIRE_PEERS=1`.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use sipnpuff::control::motion::stream::ArmCommand;
use sipnpuff::tools::recording::format::commands::CommandItem;
use sipnpuff::tools::recording::read::Recording;

use crate::common::{assert_rate, have_peer, monotonic_ns};

/// The peer's Python, if installed.
fn peer_python() -> Option<PathBuf> {
    let python = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/peers/cyclonedds/bin/python");
    python.exists().then_some(python)
}

fn peer_script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/peers/ros2/peer.py")
}

/// Whether the test can run; says why not (or fails, when peers are
/// required).
fn ready(test: &str) -> bool {
    // SAFETY: geteuid has no preconditions.
    let root = unsafe { libc::geteuid() } == 0;
    let missing = if peer_python().is_none() {
        Some("the Cyclone DDS peer is not installed (tests/peers/ros2/install.sh)".into())
    } else if !root {
        Some("not root: no private network namespace for DDS".into())
    } else {
        None
    };
    have_peer(test, missing)
}

/// Runs `body` on a thread in a new network namespace with only loopback
/// (up, multicast on, the multicast route on it): every process it spawns
/// is in there too.
fn in_private_network<T: Send + 'static>(body: impl FnOnce() -> T + Send + 'static) -> T {
    std::thread::spawn(move || {
        // SAFETY: unshare affects only this thread (a network namespace
        // is per task); no pointer is passed.
        let rc = unsafe { libc::unshare(libc::CLONE_NEWNET) };
        assert_eq!(
            rc,
            0,
            "unshare(CLONE_NEWNET): {}",
            std::io::Error::last_os_error()
        );
        for args in [
            &["link", "set", "lo", "up"][..],
            &["link", "set", "lo", "multicast", "on"],
            &["route", "add", "224.0.0.0/4", "dev", "lo"],
        ] {
            let status = Command::new("ip").args(args).status().expect("ip runs");
            assert!(status.success(), "ip {args:?}");
        }
        body()
    })
    .join()
    .unwrap_or_else(|e| std::panic::resume_unwind(e))
}

/// A scratch directory.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "sipnpuff-ros2-{name}-{}-{}",
        std::process::id(),
        monotonic_ns()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The running peer.
struct Peer {
    child: Child,
    out: PathBuf,
}

impl Peer {
    /// Starts the peer on `topic` and waits until its reader exists.
    fn start(dir: &Path, topic: &str, message: &str, pose_topic: Option<&str>) -> Peer {
        Peer::start_with(dir, topic, message, pose_topic, &[])
    }

    /// [`Peer::start`] with more of the peer's options (`--follow`, …).
    fn start_with(
        dir: &Path,
        topic: &str,
        message: &str,
        pose_topic: Option<&str>,
        extra: &[&str],
    ) -> Peer {
        let out = dir.join("peer.jsonl");
        let mut command = Command::new(peer_python().unwrap());
        command
            .arg(peer_script())
            .args(["--topic", topic, "--message", message, "--out"])
            .arg(&out)
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit());
        if let Some(pose) = pose_topic {
            command.args(["--pose-topic", pose]);
        }
        command.args(extra);
        let mut child = crate::watchdog::spawn(&mut command);
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        assert_eq!(line.trim(), "ready", "the peer did not start");
        Peer { child, out }
    }

    /// Ends it cleanly (SIGTERM) and returns what it received.
    fn finish(mut self) -> Vec<Received> {
        self.signal(libc::SIGTERM);
        crate::watchdog::watch(
            &self.child,
            "the Cyclone DDS peer after SIGTERM",
            crate::watchdog::AFTER_SIGNAL,
        );
        let status = crate::watchdog::wait(&mut self.child);
        assert!(status.success(), "the peer failed: {status}");
        received(&self.out)
    }

    fn signal(&self, signal: libc::c_int) {
        // SAFETY: kill(2) on our own child's pid.
        unsafe { libc::kill(self.child.id() as libc::pid_t, signal) };
    }
}

impl Drop for Peer {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// One message as the peer received it.
#[derive(Debug, Clone)]
struct Received {
    t_ns: i64,
    /// The floats' IEEE bits (f64 for a TwistStamped, f32 for kinova's).
    bits: Vec<u64>,
    frame_id: Option<String>,
    stamp_ns: Option<i64>,
}

impl Received {
    fn is_zero(&self) -> bool {
        self.bits.iter().all(|&b| b == 0)
    }
}

fn received(path: &Path) -> Vec<Received> {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    // Only whole lines: the peer may be writing the last one right now.
    let whole = text.rfind('\n').map_or("", |end| &text[..end]);
    whole
        .lines()
        .map(|line| {
            let v: serde_json::Value = serde_json::from_str(line).unwrap();
            Received {
                t_ns: v["t_ns"].as_i64().unwrap(),
                bits: v["bits"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|b| b.as_u64().unwrap())
                    .collect(),
                frame_id: v["frame_id"].as_str().map(String::from),
                stamp_ns: v["sec"]
                    .as_i64()
                    .map(|s| s * 1_000_000_000 + v["nanosec"].as_i64().unwrap()),
            }
        })
        .collect()
}

/// The bits a command should arrive as.
fn expected_bits(command: &ArmCommand, message: &str) -> Vec<u64> {
    let values: Vec<f64> = command
        .linear
        .iter()
        .chain(&command.angular)
        .copied()
        .chain(if message == "pose_velocity_with_finger_velocity" {
            vec![command.fingers; 3]
        } else {
            vec![]
        })
        .collect();
    if message == "twist_stamped" {
        values.iter().map(|v| v.to_bits()).collect()
    } else {
        values
            .iter()
            .map(|&v| u64::from((v as f32).to_bits()))
            .collect()
    }
}

/// The core's commands, from a recording.
fn recorded_commands(dir: &Path) -> Vec<ArmCommand> {
    let recording = Recording::open(dir).unwrap();
    let mut decoder = recording.commands().unwrap();
    let mut commands = Vec::new();
    while let Some(item) = decoder.next_item().unwrap() {
        match item {
            CommandItem::Command(c) => commands.push(c),
            CommandItem::Lost(n) => panic!("{n} commands lost before the recording"),
        }
    }
    commands
}

/// Writes a config with these `[arm]` / `[arm.ros2]` lines.
fn config(dir: &Path, arm: &str, ros2: &str) -> PathBuf {
    let path = dir.join("config.toml");
    std::fs::write(&path, format!("[arm]\n{arm}\n[arm.ros2]\n{ros2}\n")).unwrap();
    path
}

/// sipnpuff's end.
struct Outcome {
    status: std::process::ExitStatus,
    stdout: String,
    stderr: String,
    report: Option<serde_json::Value>,
    /// When the process was seen to exit (CLOCK_MONOTONIC, ns).
    exited_ns: i64,
}

/// Starts `sipnpuff run` with `args` (as a user would: real-time
/// priority where the machine grants it).
fn spawn_run(args: &[&str]) -> Child {
    let mut command = crate::common::sipnpuff();
    command
        .arg("run")
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    crate::watchdog::spawn(&mut command)
}

fn finish_run(child: Child) -> Outcome {
    let output = crate::watchdog::wait_with_output(child);
    let exited_ns = monotonic_ns();
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    crate::common::witness(&stdout);
    let report = stdout
        .lines()
        .rev()
        .find_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|v| v.get("arm_commands").is_some());
    Outcome {
        status: output.status,
        stdout,
        stderr: String::from_utf8_lossy(&output.stderr).into_owned(),
        report,
        exited_ns,
    }
}

/// A topic no other test uses.
fn topic(name: &str) -> String {
    format!("/sipnpuff_test_{name}_{}/cmd", std::process::id())
}

/// Mean rate and the inter-arrival figures (ms) of `messages`.
fn timing(messages: &[Received]) -> (f64, f64, f64) {
    let gaps: Vec<f64> = messages
        .windows(2)
        .map(|w| (w[1].t_ns - w[0].t_ns) as f64 / 1e6)
        .collect();
    let span_s = (messages.last().unwrap().t_ns - messages[0].t_ns) as f64 / 1e9;
    let rate = gaps.len() as f64 / span_s;
    let mean = gaps.iter().sum::<f64>() / gaps.len() as f64;
    let sd = (gaps.iter().map(|g| (g - mean).powi(2)).sum::<f64>() / gaps.len() as f64).sqrt();
    let max = gaps.iter().copied().fold(0.0, f64::max);
    (rate, sd, max)
}

/// Checks a whole stream against the core's commands: every command
/// arrived, in order, with its values exactly; a zero command after the
/// last; nothing after it. The connect handshake's zero may come first.
/// Returns the messages of the stream proper.
fn assert_stream(received: &[Received], commands: &[ArmCommand], message: &str) -> Vec<Received> {
    assert!(!commands.is_empty());
    let extra = received.len() as i64 - commands.len() as i64 - 1;
    assert!(
        extra == 0 || extra == 1,
        "{} received for {} commands + the final zero (+ at most the connect handshake's zero): lost or extra messages",
        received.len(),
        commands.len()
    );
    let stream = &received[extra as usize..];
    if extra == 1 {
        assert!(received[0].is_zero(), "the handshake is a zero command");
    }
    for (i, (got, command)) in stream.iter().zip(commands).enumerate() {
        assert_eq!(
            got.bits,
            expected_bits(command, message),
            "command {i} (seq {}) arrived with other values",
            command.seq
        );
    }
    let last = stream.last().unwrap();
    assert!(last.is_zero(), "the stream ends with a zero command");
    stream.to_vec()
}

/// (1) A TwistStamped stream, 10 s of the built-in user (it moves after
/// ~6 s): all of it at the peer, at 100 Hz ± 2 %, values bit for bit,
/// stamped now in the configured frame, a zero at the end, nothing after.
#[test]
fn a_twist_stream_reaches_cyclone_dds_whole_at_100_hz() {
    crate::common::real_time(|| {
        if !ready("a_twist_stream_reaches_cyclone_dds_whole_at_100_hz") {
            return;
        }
        let dir = scratch("rate");
        let topic = topic("rate");
        let (messages, outcome, dir) = in_private_network(move || {
            let peer = Peer::start(&dir, &topic, "twist_stamped", None);
            let config = config(
                &dir,
                "connect_timeout_ms = 10000",
                "frame_id = \"tool_base\"",
            );
            let rec = dir.join("rec");
            let run = spawn_run(&[
                "--config",
                config.to_str().unwrap(),
                "--arm",
                &format!("ros2:{topic}"),
                "--seconds",
                "10",
                "--json",
                "--record",
                rec.to_str().unwrap(),
            ]);
            let outcome = finish_run(run);
            // Anything after the end would arrive now.
            std::thread::sleep(Duration::from_millis(500));
            (peer.finish(), outcome, dir)
        });
        assert!(
            outcome.status.success(),
            "{}\n{}",
            outcome.stdout,
            outcome.stderr
        );
        let report = outcome.report.expect("a JSON report");
        assert_eq!(report["stream_ended_with_zero"], true, "{report}");
        let commands = recorded_commands(&dir.join("rec"));
        assert_eq!(report["arm_commands"].as_u64(), Some(commands.len() as u64));
        assert!(
            commands.iter().any(|c| !c.is_zero()),
            "the built-in user moved the arm"
        );
        let stream = assert_stream(&messages, &commands, "twist_stamped");
        // Stamped now (the peer's wall clock is ours), in the configured frame.
        for m in &stream {
            assert_eq!(m.frame_id.as_deref(), Some("tool_base"));
        }
        let now_ns = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap()
            .as_nanos() as i64;
        let first = stream[0].stamp_ns.unwrap();
        assert!(now_ns - first > 9_000_000_000 && now_ns - first < 60_000_000_000);
        assert!(stream.windows(2).all(|w| w[1].stamp_ns >= w[0].stamp_ns));
        // Rate at the peer over the commands (the final zero follows at once).
        let (rate, sd, max) = timing(&stream[..stream.len() - 1]);
        eprintln!(
            "ros2 → Cyclone DDS (TwistStamped): {} commands + final zero, 0 lost; rate {rate:.2} Hz, inter-arrival sd {sd:.3} ms, max {max:.2} ms",
            commands.len()
        );
        assert_rate(rate, &report);
    });
}

/// (2) The JACO2 ports' messages: float32, the three fingers equal.
#[test]
fn the_kinova_messages_arrive_as_float32() {
    crate::common::real_time(|| {
        if !ready("the_kinova_messages_arrive_as_float32") {
            return;
        }
        for (message, seconds) in [
            ("pose_velocity_with_finger_velocity", "9"),
            ("pose_velocity", "2"),
        ] {
            let dir = scratch(message);
            let topic = topic(message);
            let (messages, outcome, dir) = in_private_network(move || {
                let peer = Peer::start(&dir, &topic, message, None);
                let config = config(&dir, "", &format!("message = \"{message}\""));
                let rec = dir.join("rec");
                let run = spawn_run(&[
                    "--config",
                    config.to_str().unwrap(),
                    "--arm",
                    &format!("ros2:{topic}"),
                    "--seconds",
                    seconds,
                    "--json",
                    "--record",
                    rec.to_str().unwrap(),
                ]);
                let outcome = finish_run(run);
                std::thread::sleep(Duration::from_millis(300));
                (peer.finish(), outcome, dir)
            });
            assert!(outcome.status.success(), "{message}: {}", outcome.stderr);
            let commands = recorded_commands(&dir.join("rec"));
            let stream = assert_stream(&messages, &commands, message);
            let (rate, sd, max) = timing(&stream[..stream.len() - 1]);
            eprintln!(
                "ros2 → Cyclone DDS ({message}): {} commands, 0 lost; rate {rate:.2} Hz, sd {sd:.3} ms, max {max:.2} ms",
                commands.len()
            );
        }
    });
}

/// (3) The receiver killed mid-run: SIGKILL (no goodbye: the unacknowledged
/// commands tell) and SIGTERM (Cyclone deletes its participant: the
/// unmatch tells). The run ends with a fault naming the receiver.
#[test]
fn a_receiver_killed_mid_run_is_a_fault() {
    crate::common::real_time(|| {
        if !ready("a_receiver_killed_mid_run_is_a_fault") {
            return;
        }
        for (signal, name) in [(libc::SIGKILL, "SIGKILL"), (libc::SIGTERM, "SIGTERM")] {
            let dir = scratch(name);
            let topic = topic(name);
            let wanted = topic.clone();
            let (killed_ns, got, outcome) = in_private_network(move || {
                let peer = Peer::start(&dir, &topic, "twist_stamped", None);
                let run = spawn_run(&[
                    "--arm",
                    &format!("ros2:{topic}"),
                    "--seconds",
                    "30",
                    "--json",
                ]);
                // Killed once the stream has run a while.
                let deadline = Instant::now() + Duration::from_secs(20);
                while received(&peer.out).len() < 200 && Instant::now() < deadline {
                    std::thread::sleep(Duration::from_millis(20));
                }
                let killed_ns = monotonic_ns();
                peer.signal(signal);
                let outcome = finish_run(run);
                let got = received(&peer.out);
                (killed_ns, got, outcome)
            });
            assert!(got.len() >= 200, "{name}: the stream ran");
            let detected_s = (outcome.exited_ns - killed_ns) as f64 / 1e9;
            let report = outcome.report.expect("a JSON report");
            let errors = report["errors"].to_string();
            eprintln!(
                "ros2: receiver killed with {name}: the run ended {detected_s:.2} s later (of 30 s); errors: {errors}"
            );
            assert!(!outcome.status.success(), "{name}: the run fails");
            assert!(
                errors.contains("the receiver of ROS 2 topic") && errors.contains(&wanted),
                "{name}: {report}"
            );
            assert!(
                detected_s < 25.0,
                "{name}: the run ended on the fault, not at its end"
            );
        }
    });
}

/// (4) A pose published by the peer is the report's measured arm pose.
#[test]
fn a_pose_from_the_peer_is_the_measured_pose() {
    crate::common::real_time(|| {
        if !ready("a_pose_from_the_peer_is_the_measured_pose") {
            return;
        }
        let dir = scratch("pose");
        let topic = topic("pose");
        let pose_topic = format!("/sipnpuff_test_pose_{}/tool_pose", std::process::id());
        let outcome = in_private_network(move || {
            let peer = Peer::start(&dir, &topic, "twist_stamped", Some(&pose_topic));
            let config = config(&dir, "", &format!("pose_topic = \"{pose_topic}\""));
            let run = spawn_run(&[
                "--config",
                config.to_str().unwrap(),
                "--arm",
                &format!("ros2:{topic}"),
                "--seconds",
                "2",
                "--json",
            ]);
            let outcome = finish_run(run);
            drop(peer);
            outcome
        });
        let report = outcome.report.expect("a JSON report");
        let arm = &report["arm"];
        let position: Vec<f64> = arm["position_m"]
            .as_array()
            .unwrap_or_else(|| panic!("no measured pose: {report}\n{}", outcome.stderr))
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        assert_eq!(position, [0.3, -0.2, 0.45], "{arm}");
        assert_eq!(
            arm["rotation_vector_rad"],
            serde_json::json!([0.0, 0.0, 0.0])
        );
        assert_eq!(arm["fingers"], serde_json::Value::Null);
    });
}

/// (5) Nobody subscribed: a clear error within the timeout, status non-zero.
#[test]
fn no_subscriber_is_a_clear_error_within_the_timeout() {
    crate::common::real_time(|| {
        if !ready("no_subscriber_is_a_clear_error_within_the_timeout") {
            return;
        }
        let dir = scratch("none");
        let topic = topic("none");
        let (outcome, started_ns) = in_private_network(move || {
            let config = config(&dir, "connect_timeout_ms = 1500", "domain_id = 7");
            let started_ns = monotonic_ns();
            let run = spawn_run(&[
                "--config",
                config.to_str().unwrap(),
                "--arm",
                &format!("ros2:{topic}"),
                "--seconds",
                "5",
            ]);
            (finish_run(run), started_ns)
        });
        assert!(!outcome.status.success());
        let took = (outcome.exited_ns - started_ns) as f64 / 1e9;
        eprintln!(
            "ros2: no subscriber: gave up after {took:.2} s (timeout 1.5 s): {}",
            outcome.stderr.trim()
        );
        for part in [
            "no subscriber matched ROS 2 topic",
            "geometry_msgs::msg::dds_::TwistStamped_",
            "rt/sipnpuff_test_none_",
            "domain 7",
            "ROS_DOMAIN_ID",
            "within 1500 ms",
        ] {
            assert!(outcome.stderr.contains(part), "{part}: {}", outcome.stderr);
        }
    });
}

/// The stop: SIGINT to sipnpuff mid-motion; the zero twist and the last
/// message at the peer, and how long after the signal they came.
#[test]
fn a_stop_request_ends_the_stream_with_a_zero_at_the_peer() {
    crate::common::real_time(|| {
        if !ready("a_stop_request_ends_the_stream_with_a_zero_at_the_peer") {
            return;
        }
        let dir = scratch("sigint");
        let topic = topic("sigint");
        let (messages, signalled_ns, outcome) = in_private_network(move || {
            let peer = Peer::start(&dir, &topic, "twist_stamped", None);
            let run = spawn_run(&[
                "--arm",
                &format!("ros2:{topic}"),
                "--seconds",
                "30",
                "--json",
            ]);
            // Mid-motion: once the arm moves.
            let deadline = Instant::now() + Duration::from_secs(25);
            while !received(&peer.out).iter().any(|m| !m.is_zero()) && Instant::now() < deadline {
                std::thread::sleep(Duration::from_millis(10));
            }
            std::thread::sleep(Duration::from_millis(200));
            let signalled_ns = monotonic_ns();
            crate::watchdog::watch(&run, "sipnpuff after SIGINT", crate::watchdog::AFTER_SIGNAL);
            // SAFETY: kill(2) on our own child's pid.
            unsafe { libc::kill(run.id() as libc::pid_t, libc::SIGINT) };
            let outcome = finish_run(run);
            std::thread::sleep(Duration::from_millis(300));
            (peer.finish(), signalled_ns, outcome)
        });
        let report = outcome.report.expect("a JSON report");
        assert_eq!(report["stream_ended_with_zero"], true, "{report}");
        let first_zero_after = messages
            .iter()
            .position(|m| m.t_ns > signalled_ns && m.is_zero())
            .expect("a zero after the signal");
        let last = messages.last().unwrap();
        assert!(last.is_zero(), "the last message is a zero");
        let zero_ms = (messages[first_zero_after].t_ns - signalled_ns) as f64 / 1e6;
        let last_ms = (last.t_ns - signalled_ns) as f64 / 1e6;
        eprintln!(
            "ros2: SIGINT → first zero twist at the peer {zero_ms:.1} ms, last message {last_ms:.1} ms (the core brakes to zero first: {} messages after the signal)",
            messages.iter().filter(|m| m.t_ns > signalled_ns).count()
        );
        // Nothing moving after the last zero.
        assert!(messages[first_zero_after..].iter().all(|m| m.is_zero()));
    });
}

/// Runs the built-in user for `seconds` against a peer that publishes the
/// pose of an arm executing the commands it receives (`--follow`), with
/// `extra` peer options; returns sipnpuff's outcome and the arm-fault
/// reasons it printed.
fn closed_loop(
    name: &str,
    seconds: &'static str,
    extra: &'static [&'static str],
) -> (Outcome, Vec<String>) {
    let dir = scratch(name);
    let topic = topic(name);
    let pose_topic = format!("/sipnpuff_test_{name}_{}/tool_pose", std::process::id());
    let outcome = in_private_network(move || {
        let mut options = vec!["--follow"];
        options.extend(extra);
        let peer = Peer::start_with(&dir, &topic, "twist_stamped", Some(&pose_topic), &options);
        let config = config(&dir, "", &format!("pose_topic = \"{pose_topic}\""));
        let run = spawn_run(&[
            "--config",
            config.to_str().unwrap(),
            "--arm",
            &format!("ros2:{topic}"),
            "--seconds",
            seconds,
            "--json",
        ]);
        let outcome = finish_run(run);
        drop(peer);
        outcome
    });
    let faults = outcome
        .stdout
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|v| v["event"] == "arm_fault")
        .map(|v| v["reason"].as_str().unwrap().to_string())
        .collect();
    (outcome, faults)
}

/// One arm fault whose reason contains `reason`; the run braked to zero,
/// ended the stream with a zero and exited 1. Returns the report.
fn assert_one_braked_arm_fault(
    outcome: &Outcome,
    faults: &[String],
    reason: &str,
) -> serde_json::Value {
    assert_eq!(outcome.status.code(), Some(1), "{}", outcome.stderr);
    assert_eq!(faults.len(), 1, "{faults:?}");
    assert!(faults[0].contains(reason), "{faults:?}");
    let report = outcome.report.clone().expect("a JSON report");
    assert_eq!(report["stop_reason"], "arm fault");
    assert_eq!(report["stream_ended_with_zero"], true, "{report}");
    assert_eq!(
        report["final_velocity"],
        serde_json::json!([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    );
    report
}

/// The loop closed through a real receiver: the peer's arm executes each
/// command and publishes its pose; sipnpuff's limits run on it for the
/// whole session without a fault.
#[test]
fn the_loop_closes_on_the_peers_pose() {
    crate::common::real_time(|| {
        if !ready("the_loop_closes_on_the_peers_pose") {
            return;
        }
        let (outcome, faults) = closed_loop("follow", "12", &[]);
        assert!(
            outcome.status.success(),
            "{}\n{}",
            outcome.stdout,
            outcome.stderr
        );
        assert_eq!(faults, Vec::<String>::new());
        let report = outcome.report.expect("a JSON report");
        assert_eq!(report["arm_measured"], true);
        let poses = report["measured_poses"].as_u64().unwrap();
        assert!(poses > 900, "{poses} measured poses in 12 s");
        // The peer executes the commands exactly: what is corrected is the
        // transport's lag at most, never centimetres.
        let largest = report["largest_correction_m"].as_f64().unwrap();
        assert!(largest < 0.002, "largest correction {largest} m");
        assert!(report["stream_ended_with_zero"] == true);
        eprintln!(
            "closed loop through Cyclone DDS: {poses} poses in 12 s, largest correction {:.2} mm",
            largest * 1000.0
        );
    });
}

/// The peer's pose falls silent mid-session: an arm fault, a brake, a
/// clear report, exit status 1.
#[test]
fn a_silent_pose_topic_is_a_fault_with_a_brake() {
    crate::common::real_time(|| {
        if !ready("a_silent_pose_topic_is_a_fault_with_a_brake") {
            return;
        }
        let (outcome, faults) = closed_loop("silent", "20", &["--pose-silent-after", "8"]);
        let report = assert_one_braked_arm_fault(&outcome, &faults, "no measured arm pose for ");
        let errors = report["errors"].to_string();
        assert!(errors.contains("arm: no measured arm pose"), "{errors}");
    });
}

/// The peer's arm is pushed 10 cm mid-session: an arm fault naming what
/// was measured and what was expected, a brake, exit status 1.
#[test]
fn a_pose_far_from_the_commanded_one_is_a_fault_with_a_brake() {
    crate::common::real_time(|| {
        if !ready("a_pose_far_from_the_commanded_one_is_a_fault_with_a_brake") {
            return;
        }
        let (outcome, faults) = closed_loop("pushed", "20", &["--pose-jump-after", "8", "0.1"]);
        let report = assert_one_braked_arm_fault(
            &outcome,
            &faults,
            "from the commanded one (arm blocked or moved by hand?)",
        );
        let errors = report["errors"].to_string();
        assert!(errors.contains("arm: the measured arm pose is"), "{errors}");
    });
}
