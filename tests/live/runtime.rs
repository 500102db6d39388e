//! The real-time runtime in short real runs that assert structure, never
//! timing (these machines are shared and noisy): the report, no
//! allocation over ten seconds, signals, privileges, a refusing arm, a
//! stopped process, a measuring arm and a lost link.

use std::process::Command;
use std::sync::Arc;
use std::sync::Mutex;
use std::time::Duration;

use sipnpuff::arm::sim::SimArm;
use sipnpuff::arm::{Arm, ArmError, ArmState};
use sipnpuff::config::Config;
use sipnpuff::control::event::Event;
use sipnpuff::control::motion::stream::ArmCommand;
use sipnpuff::rt::control_loop::StopReason;
use sipnpuff::rt::report::RunReport;
use sipnpuff::rt::setup::RtOptions;
use sipnpuff::rt::stop::StopRequest;
use sipnpuff::rt::threads::{LoopSettings, RunOptions, run};
use sipnpuff::sim::synthetic_sensor::SyntheticSensor;

use crate::common::Running;

/// Real runs one at a time: they share the pinned CPU.
static REAL_RUN: Mutex<()> = Mutex::new(());

fn settings(seconds: f64) -> LoopSettings {
    LoopSettings {
        seconds: Some(seconds),
        rt: RtOptions::default(),
        spin_margin_ns: None,
        stop: StopRequest::new(),
    }
}

/// `run` for `seconds` with the built-in user and the simulated arm.
fn real_run(seconds: f64) -> RunReport {
    // Load stalls on this shared machine must not fault the scripted user.
    let config = Config::from_file(&crate::common::fixture("shared-machine.toml")).unwrap();
    let sensor = SyntheticSensor::built_in_user(&config);
    let arm = Box::new(SimArm::new(config.core()));
    run(
        config.core(),
        RunOptions::new(sensor, arm, settings(seconds)),
    )
    .unwrap()
}

fn check_structure(report: &RunReport, seconds: f64) {
    let st = report.stats;
    let ticks = (seconds * 1000.0) as u64;
    // Ticks run and skipped cover the run (plus the safe stop's ticks).
    assert!(st.ticks_run + st.skipped_ticks >= ticks, "{st:?}");
    assert!(st.skipped_ticks >= st.missed_deadlines);
    assert_eq!(report.drift_ticks, 0);
    assert_eq!(report.full.wake.len(), st.ticks_run);
    assert_eq!(report.control_thread_allocations, 0);
    assert_eq!(report.final_velocity, [0.0; 7]);
    assert!(report.last_arm_command.is_zero());
    // One command per 10 ticks run: motion advances only on ticks run, and
    // through a stall the arm gets nothing (a JACO2 stops when its stream
    // stops), so the arm and the core's pose estimate stay in step.
    assert_eq!(report.arm_commands, st.ticks_run / 10);
    let text = report.to_text();
    for section in [
        "real-time settings:",
        "SCHED_FIFO priority 80",
        "ticks: ",
        "wake-up latency",
        "compute",
        "period",
        "rings: dropped",
        "control thread heap allocations after start: 0",
        "arm: ",
        "final commanded velocity",
    ] {
        assert!(text.contains(section), "no {section:?} in\n{text}");
    }
}

#[test]
fn a_short_real_run_reports_its_structure() {
    let _one = REAL_RUN.lock().unwrap_or_else(|e| e.into_inner());
    let report = real_run(2.0);
    check_structure(&report, 2.0);
    assert_eq!(report.stop_reason, StopReason::Time);
    // The arm thread woke once for each command handed to it, timed from
    // its control tick's wake-up.
    let arm = &report.serving[0];
    assert_eq!(arm.thread, "arm");
    assert_eq!(arm.wake.len(), report.arm_commands);
    assert!(
        report.to_text().contains("  arm    "),
        "{}",
        report.to_text()
    );

    // --histogram-dir: one .hgrm per histogram, in the plotter's format,
    // its total the number of ticks.
    let dir = crate::scratch::Scratch::new();
    let written = report.write_histograms(&dir).unwrap();
    let names: Vec<_> = written
        .iter()
        .map(|p| p.file_name().unwrap().to_str().unwrap().to_string())
        .collect();
    assert_eq!(names, ["wake_latency.hgrm", "compute.hgrm", "period.hgrm"]);
    let text = std::fs::read_to_string(&written[0]).unwrap();
    assert!(
        text.starts_with("       Value     Percentile TotalCount 1/(1-Percentile)"),
        "{text}"
    );
    let total = format!("Total count    = {:>12}]", report.stats.ticks_run);
    assert!(text.contains(&total), "{text}");
}

#[test]
fn ten_seconds_of_running_allocate_nothing_on_the_control_thread() {
    crate::common::real_time(|| {
        let _one = REAL_RUN.lock().unwrap_or_else(|e| e.into_inner());
        let report = real_run(10.0);
        check_structure(&report, 10.0);
        // It did real work: selections, a save, motion.
        assert!(report.events >= 8, "{} events", report.events);
        let arm = report.arm.expect("the simulated arm reports its state");
        assert!(arm.pose.translation.x > 0.3, "moved forward");
        // Memory locked before the threads start, each touched before its
        // loop: no thread the loop waits on faults while running.
        let locked = report
            .settings
            .iter()
            .any(|s| s.name.contains("mlockall") && s.granted);
        if !locked {
            return;
        }
        assert_eq!(report.control_thread_page_faults, 0);
        assert_eq!(report.serving[0].thread, "arm");
        assert_eq!(report.serving[0].page_faults, 0);
    });
}

fn binary() -> Command {
    crate::common::sipnpuff()
}

#[test]
fn bench_cpu_sets_the_runs_cpu_beside_cyclictests() {
    let _one = REAL_RUN.lock().unwrap_or_else(|e| e.into_inner());
    let config = crate::common::fixture("shared-machine.toml");
    let out = binary()
        .args(["bench", "cpu", "--seconds", "1", "--rounds", "2", "--json"])
        .arg("--config")
        .arg(&config)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(
        report["cyclictest"]
            .as_str()
            .unwrap()
            .starts_with("cyclictest --mlockall --priority=80 --affinity="),
        "{report}"
    );
    let rounds = report["rounds"].as_array().unwrap();
    assert_eq!(rounds.len(), 2);
    let mut ratios = Vec::new();
    for round in rounds {
        let ours = round["sipnpuff_s"].as_f64().unwrap();
        let theirs = round["cyclictest_s"].as_f64().unwrap();
        // Both woke a thousand times a second for a second: each used CPU.
        assert!(ours > 0.0 && theirs > 0.0, "{round}");
        let ratio = round["ratio"].as_f64().unwrap();
        assert!((ratio - ours / theirs).abs() < 1e-9, "{round}");
        ratios.push(ratio);
    }
    let median = report["median_ratio"].as_f64().unwrap();
    assert!((median - (ratios[0] + ratios[1]) / 2.0).abs() < 1e-9);
}

/// The real binary: `run` for `seconds` with the built-in user, on the
/// shared machine's settings.
fn spawn_run(seconds: &str) -> Running {
    let config = crate::common::fixture("shared-machine.toml");
    Running::spawn(&[
        "run",
        "--seconds",
        seconds,
        "--config",
        config.to_str().unwrap(),
    ])
}

#[test]
fn sigint_stops_safely_with_a_report() {
    crate::common::real_time(|| {
        let _one = REAL_RUN.lock().unwrap_or_else(|e| e.into_inner());
        let mut run = spawn_run("60");
        // Wait for translate_x, then interrupt 0.9 s later, mid-puff.
        run.wait_for("\"mode\":\"translate_x\"");
        std::thread::sleep(Duration::from_millis(900));
        run.signal(libc::SIGINT);
        let (status, seen, _) = run.finish();
        let text = seen.join("\n");
        assert_eq!(status.code(), Some(130), "{status}\n{text}");
        assert!(text.contains("stopped by: signal SIGINT"), "{text}");
        assert!(
            text.contains("\"event\":\"detection\",\"reason\":\"stop\""),
            "{text}"
        );
        assert!(text.contains(crate::common::STOPPED_AT_REST), "{text}");
        assert!(text.contains(crate::common::NO_ALLOCATIONS), "{text}");
    });
}

#[test]
fn a_user_without_privileges_runs_and_is_told_what_it_lacks() {
    let _one = REAL_RUN.lock().unwrap_or_else(|e| e.into_inner());
    // SAFETY: geteuid has no preconditions.
    let root = unsafe { libc::geteuid() } == 0;
    let mut command = if root {
        let mut c = Command::new("setpriv");
        c.args(["--reuid=65534", "--regid=65534", "--clear-groups", "--"]);
        c.arg(env!("CARGO_BIN_EXE_sipnpuff"));
        c.env("SIPNPUFF_NO_DISPLAY", "1");
        c
    } else {
        binary()
    };
    command.args(["run", "--seconds", "1.5"]);
    let output = crate::watchdog::output(&mut command);
    let text = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{}\n{text}",
        String::from_utf8_lossy(&output.stderr)
    );
    let line = |name: &str| {
        text.lines()
            .find(|l| l.trim_start().starts_with(name))
            .unwrap_or("")
            .to_string()
    };
    assert!(line("SCHED_FIFO priority 80").contains("DENIED"), "{text}");
    assert!(line("mlockall").contains("DENIED"), "{text}");
    assert!(line("/dev/cpu_dma_latency").contains("DENIED"), "{text}");
    assert!(
        text.contains("final commanded velocity: linear (0, 0, 0)"),
        "{text}"
    );
    assert!(text.contains(crate::common::NO_ALLOCATIONS), "{text}");
}

/// Under systemd (`Type=notify`, `WatchdogSec=`): READY=1 once the loop
/// runs, WATCHDOG=1 every half interval while its ticks keep coming,
/// none for the window in which the process was stopped (SIGSTOP, as a
/// stalled loop), STOPPING=1 at the end. The notify socket is this
/// test's, bound where systemd would bind its own.
#[test]
fn the_service_is_ready_once_the_loop_runs_and_petted_only_while_it_keeps_time() {
    let _one = REAL_RUN.lock().unwrap_or_else(|e| e.into_inner());
    let dir = crate::scratch::Scratch::new();
    let path = dir.join("notify");
    let socket = std::os::unix::net::UnixDatagram::bind(&path).unwrap();
    socket
        .set_read_timeout(Some(Duration::from_millis(200)))
        .unwrap();
    let config = crate::common::fixture("shared-machine.toml");
    let mut command = binary();
    command
        .args([
            "run",
            "--seconds",
            "4",
            "--config",
            config.to_str().unwrap(),
        ])
        .env("NOTIFY_SOCKET", &path)
        .env("WATCHDOG_USEC", "200000");
    let run = Running::start(command);
    // (message, ms since the start) as they come.
    let start = std::time::Instant::now();
    let mut got: Vec<(String, u128)> = Vec::new();
    let mut buffer = [0u8; 512];
    let mut paused = None;
    while got.last().is_none_or(|(m, _)| !m.starts_with("STOPPING=1")) {
        if start.elapsed() > Duration::from_secs(30) {
            break;
        }
        if let Ok(n) = socket.recv(&mut buffer) {
            got.push((
                String::from_utf8_lossy(&buffer[..n]).to_string(),
                start.elapsed().as_millis(),
            ));
        }
        if paused.is_none() && got.iter().filter(|(m, _)| m == "WATCHDOG=1\n").count() == 5 {
            paused = Some(start.elapsed().as_millis());
            run.pause(Duration::from_millis(600));
        }
    }
    let (status, _, stderr) = run.finish();
    assert!(status.success(), "{status}: {stderr}");
    let text = format!("{got:?}");
    assert!(
        got[0].0.starts_with("READY=1\nSTATUS=running: sensor "),
        "{text}"
    );
    assert!(
        got.last()
            .is_some_and(|(m, _)| m.starts_with("STOPPING=1\nSTATUS=stopped by: ")),
        "{text}"
    );
    let pets: Vec<u128> = got
        .iter()
        .filter(|(m, _)| m == "WATCHDOG=1\n")
        .map(|(_, t)| *t)
        .collect();
    // About every 100 ms over ~4 s, less the stall and the window after it.
    assert!(pets.len() >= 20, "{text}");
    let paused = paused.expect("paused after the 5th pet");
    let resumed = paused + 600;
    // No pet for the window that holds the stall: petted regardless, the
    // first pet would come the moment the process resumed (its interval
    // long past); judged, that window goes unpetted and the next pet
    // comes a whole interval (100 ms) later or more. (`resumed` is at or
    // before the real SIGCONT.)
    let next = pets.iter().find(|&&t| t > paused).copied().unwrap_or(0);
    assert!(
        next >= resumed + 90,
        "resumed at {resumed} ms, petted at {next} ms: {text}"
    );
}

/// `doctor` as root gets what a run gets as root; as a user without
/// privileges (nobody, via setpriv), SCHED_FIFO (the control thread's
/// and the arm thread's) and the memory lock are denied, each with the
/// limit it met and the unit setting that grants it, and the exit
/// status is 1.
#[test]
fn doctor_says_what_the_real_time_set_up_gets_and_what_grants_it() {
    // SAFETY: geteuid has no preconditions.
    let root = unsafe { libc::geteuid() } == 0;
    if !crate::common::have_peer(
        (!root).then(|| "not root: comparing with an unprivileged user needs root".into()),
    ) {
        return;
    }
    let doctor = |command: &mut Command| {
        command.args(["doctor", "--no-display"]);
        let output = crate::watchdog::output(command);
        (
            output.status.code(),
            String::from_utf8_lossy(&output.stdout).to_string(),
        )
    };
    let line = |text: &str, name: &str| {
        text.lines()
            .position(|l| l.contains(name))
            .map(|i| text.lines().skip(i).take(2).collect::<Vec<_>>().join("\n"))
            .unwrap_or_default()
    };
    let (status, text) = doctor(&mut binary());
    assert_eq!(status, Some(0), "{text}");
    assert!(
        line(&text, "SCHED_FIFO priority 80").starts_with("  ok"),
        "{text}"
    );
    assert!(
        line(&text, "arm thread: SCHED_FIFO priority 60").starts_with("  ok"),
        "{text}"
    );
    assert!(line(&text, "mlockall").starts_with("  ok"), "{text}");
    assert!(text.contains("as root (uid 0;"), "{text}");

    let mut nobody = Command::new("setpriv");
    nobody.args(["--reuid=65534", "--regid=65534", "--clear-groups", "--"]);
    nobody.arg(env!("CARGO_BIN_EXE_sipnpuff"));
    let (status, text) = doctor(&mut nobody);
    assert_eq!(status, Some(1), "{text}");
    assert!(text.contains("(uid 65534;"), "{text}");
    let fifo = line(&text, "SCHED_FIFO priority 80");
    assert!(fifo.starts_with("  DENIED"), "{text}");
    assert!(
        fifo.contains("its RLIMIT_RTPRIO is 0") && fifo.contains("LimitRTPRIO="),
        "{text}"
    );
    let lock = line(&text, "mlockall");
    assert!(
        lock.starts_with("  DENIED") && lock.contains("LimitMEMLOCK=infinity"),
        "{text}"
    );
    // The arm's streamer (the synthetic user has no reader thread), below
    // the control thread, denied for the same limit.
    let arm = line(&text, "arm thread: SCHED_FIFO priority 60");
    assert!(
        arm.starts_with("  DENIED") && arm.contains("LimitRTPRIO="),
        "{text}"
    );
    assert!(!text.contains("sensor thread"), "{text}");
    assert!(text.contains("3 needed things DENIED"), "{text}");
}

/// An arm that takes `good` commands, then refuses the next; it records
/// every call so the test can see how the stream ended.
struct RefusingArm {
    good: usize,
    sends: usize,
    calls: Arc<Mutex<Vec<String>>>,
}

impl Arm for RefusingArm {
    fn describe(&self) -> String {
        "refusing".into()
    }
    fn connect(&mut self) -> Result<(), ArmError> {
        Ok(())
    }
    fn send(&mut self, command: &ArmCommand) -> Result<(), ArmError> {
        self.sends += 1;
        if self.sends == self.good + 1 {
            return Err(ArmError::Rejected {
                detail: "over current".into(),
            });
        }
        let mut calls = self.calls.lock().unwrap();
        calls.push(format!("send {} zero {}", command.seq, command.is_zero()));
        Ok(())
    }
    fn feedback(&mut self) -> Option<ArmState> {
        None
    }
    fn stop(&mut self) -> Result<(), ArmError> {
        self.calls.lock().unwrap().push("stop".into());
        Ok(())
    }
}

#[test]
fn an_arm_that_refuses_a_command_stops_the_run_safely() {
    let _one = REAL_RUN.lock().unwrap_or_else(|e| e.into_inner());
    let config = Config::default();
    let calls = Arc::new(Mutex::new(Vec::new()));
    let arm = Box::new(RefusingArm {
        good: 300,
        sends: 0,
        calls: calls.clone(),
    });
    let sensor = SyntheticSensor::built_in_user(&config);
    let report = run(config.core(), RunOptions::new(sensor, arm, settings(60.0))).unwrap();
    assert_eq!(report.stop_reason, StopReason::ArmFault);
    assert_eq!(report.errors, ["arm refused a command: over current"]);
    assert!(report.stream_ended_with_zero);
    assert!(report.to_text().contains("stopped by: arm fault"));
    assert!(
        report
            .to_text()
            .contains("ERROR: arm refused a command: over current")
    );
    // 300 commands, then the refused one: a zero command numbered after the
    // last sent, then stop, and nothing after.
    let calls = calls.lock().unwrap();
    assert_eq!(calls.len(), 302, "{calls:?}");
    assert_eq!(calls[300], "send 300 zero true");
    assert_eq!(calls[301], "stop");
    // The loop stopped well before its 60 s.
    assert!(report.stats.ticks_run + report.stats.skipped_ticks < 60_000);
    assert_eq!(report.final_velocity, [0.0; 7]);
}

/// The real binary stopped for about 2 s (SIGSTOP, as a debugger or a
/// paused VM would) and continued: the event log has the stall as a fault
/// giving the gap, and the run still ends with its safe stop and report.
#[test]
fn a_stopped_and_continued_process_reports_the_stall_and_stops_safely() {
    crate::common::real_time(|| {
        let _one = REAL_RUN.lock().unwrap_or_else(|e| e.into_inner());
        let mut run = spawn_run("8");
        // The loop is running once the first selection is logged.
        run.wait_for("\"event\":\"match\"");
        run.pause(Duration::from_millis(2000));
        let (status, seen, _) = run.finish();
        let text = seen.join("\n");
        // The stall is a fault: it stopped the arm, and the run fails.
        assert_eq!(status.code(), Some(1), "{status}\n{text}");
        let gaps: Vec<u64> = seen
            .iter()
            .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
            .filter(|v| v["event"] == "fault")
            .filter_map(|v| {
                let reason = v["reason"].as_str()?.to_string();
                let rest = reason.split("stalled for ").nth(1)?;
                rest.split(' ').next()?.parse().ok()
            })
            .collect();
        assert!(gaps.iter().any(|&ms| ms >= 1900), "{gaps:?}\n{text}");
        assert!(text.contains("stopped by: time"), "{text}");
        assert!(text.contains(crate::common::STOPPED_AT_REST), "{text}");
    });
}

/// An arm that measures its pose (the commands executed exactly, reported
/// every 10 ms) until `silent_after` sends, and whose link breaks after
/// `lost_after` sends.
struct MeasuringArm {
    arm: SimArm,
    sends: usize,
    silent_after: usize,
    lost_after: usize,
    fresh: bool,
}

impl MeasuringArm {
    fn new(config: &Config, silent_after: usize, lost_after: usize) -> Box<MeasuringArm> {
        Box::new(MeasuringArm {
            arm: SimArm::new(config.core()),
            sends: 0,
            silent_after,
            lost_after,
            fresh: true,
        })
    }
}

impl Arm for MeasuringArm {
    fn describe(&self) -> String {
        "measuring".into()
    }
    fn connect(&mut self) -> Result<(), ArmError> {
        Ok(())
    }
    fn send(&mut self, command: &ArmCommand) -> Result<(), ArmError> {
        self.sends += 1;
        self.fresh = true;
        self.arm.send(command)
    }
    fn feedback(&mut self) -> Option<ArmState> {
        let fresh = std::mem::take(&mut self.fresh) && self.sends <= self.silent_after;
        fresh.then(|| self.arm.feedback()).flatten()
    }
    fn measures_pose(&self) -> bool {
        true
    }
    fn check_link(&mut self) -> Result<(), ArmError> {
        if self.sends > self.lost_after {
            return Err(ArmError::Disconnected {
                detail: "the receiver went away".into(),
            });
        }
        Ok(())
    }
    fn stop(&mut self) -> Result<(), ArmError> {
        self.arm.stop()
    }
}

/// Runs the built-in user with `arm` for up to 30 s; returns the report
/// and the arm-fault events.
fn measured_run(arm: Box<MeasuringArm>) -> (RunReport, Vec<String>) {
    let _one = REAL_RUN.lock().unwrap_or_else(|e| e.into_inner());
    let config = Config::default();
    let sensor = SyntheticSensor::built_in_user(&config);
    let mut faults = Vec::new();
    let mut arm_faults = |e: &sipnpuff::control::event::TimedEvent| {
        if let Event::ArmFault { reason } = e.event {
            faults.push(reason.to_string());
        }
    };
    let options = RunOptions::new(sensor, arm, settings(30.0)).events(&mut arm_faults);
    let report = run(config.core(), options).unwrap();
    (report, faults)
}

#[test]
fn a_measuring_arm_closes_the_loop_and_its_silence_stops_the_run() {
    crate::common::real_time(|| {
        let config = Config::default();
        let (report, faults) = measured_run(MeasuringArm::new(&config, 400, usize::MAX));
        assert!(report.arm_measured);
        assert!(report.measured_poses >= 300, "{}", report.measured_poses);
        assert_eq!(report.stop_reason, StopReason::ArmFault);
        assert_eq!(faults.len(), 1, "{faults:?}");
        // 251 ms after the last pose, or a little more if the loop skipped a
        // tick just then (a loaded machine).
        let ms: u64 = faults[0]
            .strip_prefix("no measured arm pose for ")
            .and_then(|rest| rest.split(' ').next())
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("{faults:?}"));
        assert!((251..1000).contains(&ms), "{faults:?}");
        let text = report.to_text();
        assert!(
            text.contains(&format!("ERROR: arm: {}", faults[0])),
            "{text}"
        );
        assert!(text.contains("final measured position"), "{text}");
        assert!(text.contains("arm feedback: "), "{text}");
        assert!(report.stream_ended_with_zero && report.last_arm_command.is_zero());
        assert_eq!(report.final_velocity, [0.0; 7]);
        assert_eq!(report.control_thread_allocations, 0);
    });
}

#[test]
fn a_lost_link_reaches_the_core_and_stops_the_run() {
    crate::common::real_time(|| {
        let config = Config::default();
        let (report, faults) = measured_run(MeasuringArm::new(&config, usize::MAX, 500));
        assert_eq!(report.stop_reason, StopReason::ArmFault);
        assert_eq!(faults, ["arm link lost or a command refused — arm stopped"]);
        assert_eq!(report.errors, ["arm disconnected: the receiver went away"]);
        assert!(report.stream_ended_with_zero);
        assert_eq!(report.final_velocity, [0.0; 7]);
    });
}

/// A person who moves rather than breathes, live: a simulated IMU user's
/// recording played through `run` (`--sensor csv:IMU.csv`) with the
/// fixture's gesture set: a nod selects translate_x, a wobble fires the
/// home event, and the run ends with the recording, at rest, having
/// allocated nothing on the control thread.
#[test]
fn a_run_reads_gestures_from_an_imu_recording() {
    use sipnpuff::control::imu::Channels;
    use sipnpuff::sim::head_gesture::GestureName;
    use sipnpuff::sim::imu_session::practice_session;
    use sipnpuff::sim::imu_user::ImuUser;
    use sipnpuff::tools::imu_csv::write_imu_csv;

    let user = ImuUser::builtin("typical").unwrap();
    let session = practice_session(&user, &[GestureName::Nod, GestureName::Wobble], 1, 3);
    let dir = crate::scratch::Scratch::new();
    let csv = dir.join("imu.csv");
    let mut text = Vec::new();
    write_imu_csv(&mut text, Channels::ALL, &session.samples).unwrap();
    std::fs::write(&csv, text).unwrap();
    let sensor = format!("csv:{}", csv.display());
    let shared = crate::common::fixture("shared-machine.toml");
    let rec = dir.join("rec");
    crate::common::real_time(|| {
        let _one = REAL_RUN.lock().unwrap_or_else(|e| e.into_inner());
        let _ = std::fs::remove_dir_all(&rec);
        let out = binary()
            .args([
                "run",
                "--sensor",
                &sensor,
                "--config",
                "fixtures/gesture-user/config.toml",
                "--config",
                shared.to_str().unwrap(),
                "--record",
                rec.to_str().unwrap(),
            ])
            .output()
            .unwrap();
        let (stdout, stderr) = (
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr),
        );
        assert_eq!(out.status.code(), Some(0), "{stderr}\n{stdout}");
        for said in [
            r#""event":"gesture","name":"nod""#,
            r#""event":"match","sequence":["nod"],"mode":"translate_x""#,
            r#""event":"gesture","name":"wobble""#,
            r#""event":"match","sequence":["wobble"],"home_event":"lights_toggle""#,
        ] {
            assert!(stdout.contains(said), "{said}\n{stdout}");
        }
        // The report.
        for said in [
            "sensor: IMU recording",
            "stopped by: sensor ended",
            crate::common::STOPPED_AT_REST,
            crate::common::NO_ALLOCATIONS,
        ] {
            assert!(stdout.contains(said), "{said}\n{stdout}");
        }
        // The session recording holds the IMU's samples and a copy of the
        // set: its replay is the run, bit for bit.
        let set = std::fs::read("fixtures/gesture-user/gestures.toml").unwrap();
        assert_eq!(std::fs::read(rec.join("gestures.toml")).unwrap(), set);
        let out = binary()
            .args(["replay", rec.to_str().unwrap()])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(0), "{stderr}");
        assert!(
            stderr.contains("identical to the recording, bit for bit"),
            "{stderr}"
        );
        let replayed = String::from_utf8_lossy(&out.stdout);
        assert!(
            replayed.contains(r#""event":"gesture","name":"wobble""#),
            "{replayed}"
        );
    });
}

/// A person who breathes and moves: a breath recording with an IMU
/// recording beside it (`--imu`). A nod then a short puff is one
/// sequence; the recording keeps both sensors and replays bit for bit.
#[test]
fn a_run_reads_a_breath_sensor_and_an_imu_side_by_side() {
    use sipnpuff::config::Config;
    use sipnpuff::control::action::Breath;
    use sipnpuff::control::imu::Channels;
    use sipnpuff::sim::head_gesture::GestureName;
    use sipnpuff::sim::imu_session::practice_session;
    use sipnpuff::sim::imu_user::ImuUser;
    use sipnpuff::sim::sensor_model::{SignalGenerator, SignalParams, Step};
    use sipnpuff::tools::imu_csv::write_imu_csv;

    let dir = crate::scratch::Scratch::new();
    let user = ImuUser::builtin("typical").unwrap();
    let session = practice_session(&user, &[GestureName::Nod], 1, 3);
    let imu = dir.join("imu.csv");
    let mut text = Vec::new();
    write_imu_csv(&mut text, Channels::ALL, &session.samples).unwrap();
    std::fs::write(&imu, text).unwrap();
    let set = crate::common::fixture("gesture-user/gestures.toml");
    let config = dir.join("both.toml");
    std::fs::write(
        &config,
        format!(
            "[gestures]\nset = {:?}\n\n[[sequence]]\nactions = [\"nod\"]\nmode = \"translate_x\"\n\n[[sequence]]\nactions = [\"nod\", -1]\nmode = \"translate_y\"\n",
            set.to_str().unwrap()
        ),
    )
    .unwrap();
    // Where the nod is read: the IMU recording replayed alone.
    let out = binary()
        .args(["replay", imu.to_str().unwrap(), "--config"])
        .arg(&config)
        .output()
        .unwrap();
    let events = String::from_utf8_lossy(&out.stdout);
    let nod_read: u64 = events
        .lines()
        .find(|l| l.contains(r#""event":"gesture","name":"nod""#))
        .and_then(|l| {
            l.strip_prefix(r#"{"tick":"#)?
                .split(',')
                .next()?
                .parse()
                .ok()
        })
        .unwrap_or_else(|| panic!("no nod in the IMU's replay:\n{events}"));
    let nod_at = nod_read - session.samples[0].0;
    // The breath recording: at rest, a short puff 300 ms after the nod is
    // read, at rest again past the IMU recording's end.
    let detector = Config::default().core().detector().clone();
    let script = [
        Step::Rest {
            ms: nod_at as u32 + 300,
        },
        Step::Breath {
            breath: Breath::Puff,
            ms: 150,
        },
        Step::Rest { ms: 5_000 },
    ];
    let volts = SignalGenerator::new(SignalParams::clean(&detector, 9), &script);
    let length = nod_at as usize + 5_450;
    let breath = dir.join("breath.csv");
    let mut text = String::from("tick,volts\n");
    for (tick, v) in volts.take(length).enumerate() {
        text += &format!("{tick},{v:.4}\n");
    }
    std::fs::write(&breath, text).unwrap();
    let shared = crate::common::fixture("shared-machine.toml");
    let rec = dir.join("rec");
    crate::common::real_time(|| {
        let _one = REAL_RUN.lock().unwrap_or_else(|e| e.into_inner());
        let _ = std::fs::remove_dir_all(&rec);
        let out = binary()
            .args(["run", "--sensor"])
            .arg(format!("csv:{}", breath.display()))
            .arg("--imu")
            .arg(format!("csv:{}", imu.display()))
            .arg("--config")
            .arg(&config)
            .arg("--config")
            .arg(&shared)
            .arg("--record")
            .arg(&rec)
            .output()
            .unwrap();
        let (stdout, stderr) = (
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr),
        );
        assert_eq!(out.status.code(), Some(0), "{stderr}\n{stdout}");
        for said in [
            r#""event":"gesture","name":"nod""#,
            r#""event":"burst","action":-1"#,
            r#""event":"match","sequence":["nod",-1],"mode":"translate_y""#,
            "beside it the IMU IMU recording",
            "stopped by: sensor ended",
            crate::common::STOPPED_AT_REST,
            crate::common::NO_ALLOCATIONS,
        ] {
            assert!(stdout.contains(said), "{said}\n{stdout}");
        }
        assert!(!stdout.contains(r#""event":"fault""#), "{stdout}");
        // The recording says both sensors were read: its replay's core
        // reads both, and gives the run bit for bit.
        let meta = std::fs::read_to_string(rec.join("meta.json")).unwrap();
        assert!(meta.contains(r#""breath_and_imu": true"#), "{meta}");
        let out = binary()
            .args(["replay", rec.to_str().unwrap()])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(0), "{stderr}");
        assert!(
            stderr.contains("identical to the recording, bit for bit"),
            "{stderr}"
        );
    });
}

/// A live thread's scheduling, as `chrt -p` and `taskset -p` see it.
#[derive(Debug)]
struct ThreadScheduling {
    name: String,
    policy: i32,
    priority: i32,
    cpus: Vec<usize>,
}

/// A CPU list as the kernel writes it: `0-2,5`.
fn cpu_list(text: &str) -> Vec<usize> {
    text.split(',')
        .flat_map(|part| {
            let (from, to) = part.split_once('-').unwrap_or((part, part));
            from.parse::<usize>().unwrap()..=to.parse::<usize>().unwrap()
        })
        .collect()
}

/// Every thread of process `pid`.
fn threads_of(pid: u32) -> Vec<ThreadScheduling> {
    let mut threads = Vec::new();
    for task in std::fs::read_dir(format!("/proc/{pid}/task"))
        .unwrap()
        .flatten()
    {
        let dir = task.path();
        let (Ok(stat), Ok(status)) = (
            std::fs::read_to_string(dir.join("stat")),
            std::fs::read_to_string(dir.join("status")),
        ) else {
            continue; // ended meanwhile
        };
        // After the name's closing parenthesis, fields 3 on: rt_priority
        // is field 40, policy 41.
        let fields: Vec<&str> = stat[stat.rfind(')').unwrap() + 2..].split(' ').collect();
        let field = |n: usize| fields[n - 3].parse::<i32>().unwrap();
        let cpus = cpu_list(
            status
                .lines()
                .find_map(|l| l.strip_prefix("Cpus_allowed_list:"))
                .unwrap()
                .trim(),
        );
        let name = std::fs::read_to_string(dir.join("comm")).unwrap();
        threads.push(ThreadScheduling {
            name: name.trim().to_string(),
            policy: field(41),
            priority: field(40),
            cpus,
        });
    }
    threads
}

/// `chrt -p` on a live `run`: the control thread SCHED_FIFO 80 on the
/// last CPU; the sensor's reader at 70 and the arm thread at 60 on the
/// others; the display's and the telemetry's threads SCHED_OTHER. The
/// report says each was granted, or (without the privilege) denied, and
/// then the threads stay SCHED_OTHER.
#[test]
fn every_thread_the_loop_waits_on_runs_at_its_priority_below_it() {
    let _one = REAL_RUN.lock().unwrap_or_else(|e| e.into_inner());
    let mut rest = String::from("tick,volts\n");
    for t in 0..20_000 {
        rest += &format!("{t},2.5\n");
    }
    let (_dir, path) = crate::scratch::scratch_file("rest.csv", &rest);
    let sensor = format!("csv:{}", path.display());
    let config = crate::common::fixture("shared-machine.toml");
    let run = Running::spawn(&[
        "run",
        "--sensor",
        &sensor,
        "--seconds",
        "3",
        "--config",
        config.to_str().unwrap(),
    ]);
    // The control thread sets itself up at its start, after the others.
    let pid = run.child.id();
    let mut threads = threads_of(pid);
    for _ in 0..100 {
        if threads.iter().any(|t| t.name == "control" && t.policy != 0) {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
        threads = threads_of(pid);
    }
    let (status, seen, stderr) = run.finish();
    let text = seen.join("\n");
    assert!(status.success(), "{text}\n{stderr}");
    let granted = |name: &str| {
        let line = text
            .lines()
            .find(|l| l.trim_start().starts_with(name))
            .unwrap_or_else(|| panic!("no {name:?} in the report:\n{text}"));
        line.contains("granted")
    };
    let fifo = granted("SCHED_FIFO priority 80");
    let last_cpu = core_affinity::get_core_ids().unwrap().last().unwrap().id;
    let others: Vec<usize> = core_affinity::get_core_ids()
        .unwrap()
        .iter()
        .map(|c| c.id)
        .filter(|&c| c != last_cpu)
        .collect();
    let find = |name: &str| {
        threads
            .iter()
            .find(|t| t.name == name)
            .unwrap_or_else(|| panic!("no {name} thread in {threads:?}"))
    };
    for (name, priority) in [("control", 80), ("sensor", 70), ("arm", 60)] {
        let thread = find(name);
        if name != "control" {
            assert_eq!(
                granted(&format!("{name} thread: SCHED_FIFO priority {priority}")),
                fifo,
                "{text}"
            );
        }
        if fifo {
            assert_eq!(
                (thread.policy, thread.priority),
                (libc::SCHED_FIFO, priority),
                "{thread:?}"
            );
        } else {
            assert_eq!(thread.policy, libc::SCHED_OTHER, "{thread:?}");
        }
        if name == "control" {
            assert_eq!(thread.cpus, [last_cpu], "{thread:?}");
        } else if !others.is_empty() {
            assert!(granted(&format!("{name} thread: CPUs")), "{text}");
            assert_eq!(thread.cpus, others, "{thread:?}");
        }
    }
    for thread in threads
        .iter()
        .filter(|t| !["control", "sensor", "arm"].contains(&t.name.as_str()))
    {
        assert_eq!(thread.policy, libc::SCHED_OTHER, "{thread:?}");
    }
}
