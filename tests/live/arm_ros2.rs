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

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use sipnpuff::control::motion::stream::ArmCommand;

use crate::common::{Running, assert_rate, have_peer, monotonic_ns, poll_until, setting_granted};
use crate::peers::{Gaps, recorded_commands};
use crate::scratch::{Scratch, on_a_thread_of_this_test, test_name};

/// The peer's Python, if installed.
fn peer_python() -> Option<PathBuf> {
    let python = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/peers/cyclonedds/bin/python");
    python.exists().then_some(python)
}

fn peer_script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/peers/ros2/peer.py")
}

/// Runs a real-time test (see [`crate::common::real_time`]) if the peer
/// and root are here; says why not otherwise (or fails, when peers are
/// required).
fn ros2_test(test: impl Fn()) {
    crate::common::real_time(|| {
        // SAFETY: geteuid has no preconditions.
        let root = unsafe { libc::geteuid() } == 0;
        let missing = if peer_python().is_none() {
            Some("the Cyclone DDS peer is not installed (tests/peers/ros2/install.sh)".into())
        } else if !root {
            Some("not root: no private network namespace for DDS".into())
        } else {
            None
        };
        if have_peer(missing) {
            test();
        }
    });
}

/// Runs `body` on a thread of this test in a new network namespace with
/// only loopback (up, multicast on, the multicast route on it): every
/// process it spawns is in there too.
fn in_private_network<T: Send>(body: impl FnOnce() -> T + Send) -> T {
    let private_network = || {
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
    };
    on_a_thread_of_this_test(private_network, body)
}

/// A topic of this test's own, `/sipnpuff_test_<test>_<pid>/<leaf>`.
fn topic(leaf: &str) -> String {
    format!(
        "/sipnpuff_test_{}_{}/{leaf}",
        test_name(),
        std::process::id()
    )
}

/// The `[arm.ros2]` line that reads the pose the peer publishes.
fn pose_topic_line() -> String {
    format!("pose_topic = \"{}\"", topic("tool_pose"))
}

/// What a run needs: a scratch folder, the command topic, sipnpuff's
/// config (if any).
struct Setup {
    dir: Scratch,
    topic: String,
    config: Option<PathBuf>,
}

impl Setup {
    /// A config with these `[arm]` / `[arm.ros2]` lines; none when both
    /// are empty.
    fn new(arm: &str, ros2: &str) -> Setup {
        let dir = Scratch::new();
        let config = (!arm.is_empty() || !ros2.is_empty()).then(|| {
            let path = dir.join("config.toml");
            std::fs::write(&path, format!("[arm]\n{arm}\n[arm.ros2]\n{ros2}\n")).unwrap();
            path
        });
        Setup {
            dir,
            topic: topic("cmd"),
            config,
        }
    }

    /// Starts the peer on the topic, sending `message`s, and waits until
    /// its reader exists; with `pose`, it also publishes a pose on
    /// [`pose_topic_line`]'s topic, with these options (`--follow`, …).
    fn peer(&self, message: &str, pose: Option<&[&str]>) -> Peer {
        let out = self.dir.join("peer.jsonl");
        let mut command = Command::new(peer_python().unwrap());
        command
            .arg(peer_script())
            .args(["--topic", &self.topic, "--message", message, "--out"])
            .arg(&out);
        if let Some(options) = pose {
            command.args(["--pose-topic", &topic("tool_pose")]);
            command.args(options);
        }
        let mut run = Running::start(command);
        run.wait_for("ready");
        Peer { run, out }
    }

    /// Starts `sipnpuff run --arm ros2:TOPIC` with the config and `args`
    /// (as a user would: real-time priority where the machine grants it).
    fn run(&self, args: &[&str]) -> Running {
        let mut command = crate::common::sipnpuff();
        command.args(["run", "--arm", &format!("ros2:{}", self.topic)]);
        if let Some(config) = &self.config {
            command.arg("--config").arg(config);
        }
        command.args(args);
        Running::start(command)
    }

    /// A run of `seconds` recorded against a peer receiving `message`s,
    /// then `settle` for anything after the end to arrive: what the peer
    /// received, sipnpuff's end and the core's commands.
    fn recorded_stream(
        &self,
        message: &str,
        seconds: &str,
        settle: Duration,
    ) -> (Vec<Received>, Outcome, Vec<ArmCommand>) {
        let rec = self.dir.join("rec");
        let (messages, outcome) = in_private_network(|| {
            let peer = self.peer(message, None);
            let args = [
                "--seconds",
                seconds,
                "--json",
                "--record",
                rec.to_str().unwrap(),
            ];
            let outcome = finish_run(self.run(&args));
            std::thread::sleep(settle);
            (peer.finish(), outcome)
        });
        assert!(
            outcome.status.success(),
            "{message}: {}\n{}",
            outcome.stdout,
            outcome.stderr
        );
        (messages, outcome, recorded_commands(&rec))
    }
}

/// The running peer.
struct Peer {
    run: Running,
    out: PathBuf,
}

impl Peer {
    /// What it has received so far.
    fn received(&self) -> Vec<Received> {
        received(&self.out)
    }

    /// Ends it cleanly (SIGTERM) and returns what it received.
    fn finish(self) -> Vec<Received> {
        self.run.signal(libc::SIGTERM);
        let (status, _, stderr) = self.run.finish();
        assert!(status.success(), "the peer failed: {status}\n{stderr}");
        received(&self.out)
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

/// sipnpuff's end.
struct Outcome {
    status: std::process::ExitStatus,
    stdout: String,
    stderr: String,
    report: Option<serde_json::Value>,
    /// When the process was seen to exit (CLOCK_MONOTONIC, ns).
    exited_ns: i64,
}

fn finish_run(run: Running) -> Outcome {
    let (status, lines, stderr) = run.finish();
    let exited_ns = monotonic_ns();
    let report = lines
        .iter()
        .rev()
        .find_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|v| v.get("arm_commands").is_some());
    Outcome {
        status,
        stdout: lines.join("\n"),
        stderr,
        report,
        exited_ns,
    }
}

/// The timing at the peer of `messages`.
fn timing(messages: &[Received]) -> Gaps {
    Gaps::of(&messages.iter().map(|m| m.t_ns).collect::<Vec<_>>())
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
    ros2_test(|| {
        let setup = Setup::new("connect_timeout_ms = 10000", "frame_id = \"tool_base\"");
        let (messages, outcome, commands) =
            setup.recorded_stream("twist_stamped", "10", Duration::from_millis(500));
        let report = outcome.report.expect("a JSON report");
        assert_eq!(report["stream_ended_with_zero"], true, "{report}");
        assert_eq!(report["arm_commands"].as_u64(), Some(commands.len() as u64));
        assert!(
            commands.iter().any(|c| !c.is_zero()),
            "the built-in user moved the arm"
        );
        let stream = assert_stream(&messages, &commands, "twist_stamped");
        // The DDS event loop sends each command the writer queues: it runs
        // at the arm thread's priority whenever the arm thread does.
        assert_eq!(
            setting_granted(&report, "dds-event-loop thread: SCHED_FIFO priority 60"),
            setting_granted(&report, "arm thread: SCHED_FIFO priority 60")
        );
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
        let gaps = timing(&stream[..stream.len() - 1]);
        eprintln!(
            "ros2 → Cyclone DDS (TwistStamped): {} commands + final zero, 0 lost; rate {:.2} Hz, inter-arrival sd {:.3} ms, max {:.2} ms",
            commands.len(),
            gaps.rate_hz(),
            gaps.sd_ms(),
            gaps.quantile(1.0)
        );
        assert_rate(gaps.rate_hz(), &report);
    });
}

/// (2) The JACO2 ports' messages: float32, the three fingers equal.
#[test]
fn the_kinova_messages_arrive_as_float32() {
    ros2_test(|| {
        for (message, seconds) in [
            ("pose_velocity_with_finger_velocity", "9"),
            ("pose_velocity", "2"),
        ] {
            let setup = Setup::new("", &format!("message = \"{message}\""));
            let (messages, _, commands) =
                setup.recorded_stream(message, seconds, Duration::from_millis(300));
            let stream = assert_stream(&messages, &commands, message);
            let gaps = timing(&stream[..stream.len() - 1]);
            eprintln!(
                "ros2 → Cyclone DDS ({message}): {} commands, 0 lost; rate {:.2} Hz, sd {:.3} ms, max {:.2} ms",
                commands.len(),
                gaps.rate_hz(),
                gaps.sd_ms(),
                gaps.quantile(1.0)
            );
        }
    });
}

/// (3) The receiver killed mid-run: SIGKILL (no goodbye: the unacknowledged
/// commands tell) and SIGTERM (Cyclone deletes its participant: the
/// unmatch tells). The run ends with a fault naming the receiver.
#[test]
fn a_receiver_killed_mid_run_is_a_fault() {
    ros2_test(|| {
        for (signal, name) in [(libc::SIGKILL, "SIGKILL"), (libc::SIGTERM, "SIGTERM")] {
            let setup = Setup::new("", "");
            let (killed_ns, got, outcome) = in_private_network(|| {
                let peer = setup.peer("twist_stamped", None);
                let run = setup.run(&["--seconds", "30", "--json"]);
                // Killed once the stream has run a while.
                poll_until(Duration::from_secs(20), Duration::from_millis(20), || {
                    peer.received().len() >= 200
                });
                let killed_ns = monotonic_ns();
                peer.run.signal(signal);
                let outcome = finish_run(run);
                (killed_ns, peer.received(), outcome)
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
                errors.contains("the receiver of ROS 2 topic") && errors.contains(&setup.topic),
                "{name}: {report}"
            );
            assert!(
                detected_s < 25.0,
                "{name}: the run ended on the fault, not at its end"
            );
        }
    });
}

/// Runs the built-in user for `seconds` against a peer that publishes a
/// pose, with these `options` (`--follow`, …); returns sipnpuff's outcome
/// and the arm-fault reasons it printed.
fn run_with_pose(options: &[&str], seconds: &str) -> (Outcome, Vec<String>) {
    let setup = Setup::new("", &pose_topic_line());
    let outcome = in_private_network(|| {
        let _peer = setup.peer("twist_stamped", Some(options));
        finish_run(setup.run(&["--seconds", seconds, "--json"]))
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

/// (4) A pose published by the peer is the report's measured arm pose.
#[test]
fn a_pose_from_the_peer_is_the_measured_pose() {
    ros2_test(|| {
        let (outcome, _) = run_with_pose(&[], "2");
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
    ros2_test(|| {
        let setup = Setup::new("connect_timeout_ms = 1500", "domain_id = 7");
        let (outcome, started_ns) = in_private_network(|| {
            let started_ns = monotonic_ns();
            (finish_run(setup.run(&["--seconds", "5"])), started_ns)
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
            &format!("rt{}", setup.topic),
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
    ros2_test(|| {
        let setup = Setup::new("", "");
        let (messages, signalled_ns, outcome) = in_private_network(|| {
            let peer = setup.peer("twist_stamped", None);
            let run = setup.run(&["--seconds", "30", "--json"]);
            // Mid-motion: once the arm moves.
            poll_until(Duration::from_secs(25), Duration::from_millis(10), || {
                peer.received().iter().any(|m| !m.is_zero())
            });
            std::thread::sleep(Duration::from_millis(200));
            let signalled_ns = monotonic_ns();
            run.signal(libc::SIGINT);
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
fn closed_loop(seconds: &str, extra: &[&str]) -> (Outcome, Vec<String>) {
    let options = [&["--follow"], extra].concat();
    run_with_pose(&options, seconds)
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
    ros2_test(|| {
        let (outcome, faults) = closed_loop("12", &[]);
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
    ros2_test(|| {
        let (outcome, faults) = closed_loop("20", &["--pose-silent-after", "8"]);
        let report = assert_one_braked_arm_fault(&outcome, &faults, "no measured arm pose for ");
        let errors = report["errors"].to_string();
        assert!(errors.contains("arm: no measured arm pose"), "{errors}");
    });
}

/// The peer's arm is pushed 10 cm mid-session: an arm fault naming what
/// was measured and what was expected, a brake, exit status 1.
#[test]
fn a_pose_far_from_the_commanded_one_is_a_fault_with_a_brake() {
    ros2_test(|| {
        let (outcome, faults) = closed_loop("20", &["--pose-jump-after", "8", "0.1"]);
        let report = assert_one_braked_arm_fault(
            &outcome,
            &faults,
            "from the commanded one (arm blocked or moved by hand?)",
        );
        let errors = report["errors"].to_string();
        assert!(errors.contains("arm: the measured arm pose is"), "{errors}");
    });
}
