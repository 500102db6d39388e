//! Every way a real run ends brakes and reports: a signal mid-motion (its
//! exit status 128 + N), a second signal, stdout's reader gone, a full
//! disk, a bad row in the sensor's recording. These run the real binary
//! for real seconds.

use std::process::Stdio;

use crate::common::{ENDED_WITH_ZERO, Running, STOPPED_AT_REST, assert_exit};
use crate::scratch::scratch_file;

use crate::common::sipnpuff_output as sipnpuff;

/// A recording with a bad row half a second in: the run stops the arm
/// safely, the report names the file and line, and the exit is a failure.
#[test]
fn a_bad_row_mid_run_stops_safely_and_names_its_line() {
    let mut text = String::from("tick,volts\n");
    for t in 0..500 {
        text += &format!("{t},2.5\n");
    }
    text += "500,two point five\n";
    let (_dir, path) = scratch_file("cut.csv", &text);
    let sensor = format!("csv:{}", path.display());
    let out = sipnpuff(&["run", "--sensor", &sensor, "--priority", "0", "--no-mlock"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(!out.status.success(), "{stdout}");
    let expected = format!(
        "ERROR: sensor: {} line 502: the volts value \"two point five\" is not a number",
        path.display()
    );
    assert!(stdout.contains(&expected), "{stdout}");
    assert!(stdout.contains("stopped by: sensor ended"), "{stdout}");
    assert!(stdout.contains(ENDED_WITH_ZERO), "{stdout}");
}

// ---------------------------------------------------------------- exits
//
// Every way `run` stops brakes and reports. These spawn the
// real binary with the synthetic sensor, whose scripted user selects
// `translate_x` and then holds a 1.5 s puff: the arm moves forward. Waits
// are for events, never wall-clock bounds on the run.

/// `run`'s arguments for these tests: long enough never to end by itself,
/// without SCHED_FIFO or locked memory (several run at once).
/// With `fixtures/shared-machine.toml`: load stalls on this shared machine
/// must not fault the scripted user's selections.
const LONG_RUN: [&str; 8] = [
    "run",
    "--seconds",
    "60",
    "--priority",
    "0",
    "--no-mlock",
    "--config",
    concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/shared-machine.toml"),
];

/// A `LONG_RUN` with `extra` arguments.
fn start(extra: &[&str]) -> Running {
    Running::spawn(&[&LONG_RUN[..], extra].concat())
}

/// The `--json` report (the last JSON object in `text`).
fn json_report(text: &str) -> serde_json::Value {
    let line = text
        .lines()
        .rev()
        .find(|l| l.starts_with("{\"sensor\""))
        .unwrap_or_else(|| panic!("no JSON report in\n{text}"));
    serde_json::from_str(line).unwrap()
}

/// The report says the arm was moving when the stop began, braked over
/// more than one 10 ms arm cycle (no jump to zero), ended still and the
/// stream ended with a zero command.
fn assert_braked_to_zero(report: &serde_json::Value) {
    let moving = report["velocity_at_stop"].as_array().unwrap();
    assert!(
        moving[0].as_f64().unwrap() > 0.0,
        "the arm was moving forward when the stop began: {report}"
    );
    let braking = report["braking_ticks"].as_u64().unwrap();
    assert!(braking > 10, "braked over {braking} ticks: {report}");
    for v in report["final_velocity"].as_array().unwrap() {
        assert_eq!(v.as_f64(), Some(0.0), "{report}");
    }
    let last = &report["last_arm_command"];
    assert_eq!(
        last["linear"],
        serde_json::json!([0.0, 0.0, 0.0]),
        "{report}"
    );
    assert_eq!(
        last["angular"],
        serde_json::json!([0.0, 0.0, 0.0]),
        "{report}"
    );
    assert_eq!(last["fingers"], serde_json::json!(0.0), "{report}");
    assert_eq!(report["stream_ended_with_zero"], true, "{report}");
    assert_eq!(report["errors"], serde_json::json!([]), "{report}");
}

/// A signal while the arm moves: the safe stop, the report naming the
/// signal, exit status 128 + the signal's number.
fn signal_mid_motion(signal: libc::c_int, name: &str) {
    let mut run = start(&["--json"]);
    run.wait_until_moving();
    run.signal(signal);
    let (status, lines, stderr) = run.finish();
    let text = lines.join("\n");
    assert_eq!(
        status.code(),
        Some(128 + signal),
        "{name}: {status}\n{text}\n{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(
        text.contains("\"event\":\"detection\",\"reason\":\"stop\""),
        "{text}"
    );
    let report = json_report(&text);
    assert_eq!(report["stop_reason"], format!("signal {name}"), "{report}");
    assert_braked_to_zero(&report);
}

/// One test a signal: [`signal_mid_motion`].
macro_rules! signal_mid_motion_tests {
    ($($test:ident: $signal:ident),* $(,)?) => {$(
        #[test]
        fn $test() {
            crate::common::real_time(|| signal_mid_motion(libc::$signal, stringify!($signal)));
        }
    )*};
}

signal_mid_motion_tests!(
    sighup_mid_motion_brakes_reports_and_exits_129: SIGHUP,
    sigint_mid_motion_brakes_reports_and_exits_130: SIGINT,
    sigquit_mid_motion_brakes_reports_and_exits_131: SIGQUIT,
    sigterm_mid_motion_brakes_reports_and_exits_143: SIGTERM,
);

/// A second signal (a closed SSH session can send SIGHUP twice: from the
/// kernel and from the shell) does not cut the safe stop short.
#[test]
fn a_second_signal_does_not_cut_the_safe_stop_short() {
    crate::common::real_time(|| {
        let mut run = start(&["--json"]);
        run.wait_until_moving();
        run.signal(libc::SIGHUP);
        // The stop has begun (signals sent back to back may be taken by
        // different threads in either order): the brake is under way.
        run.wait_for("\"event\":\"detection\",\"reason\":\"stop\"");
        run.signal(libc::SIGHUP);
        run.signal(libc::SIGTERM);
        run.signal(libc::SIGINT);
        let (status, lines, stderr) = run.finish();
        let text = lines.join("\n");
        assert_eq!(status.code(), Some(129), "{status}\n{text}\n{stderr}");
        let report = json_report(&text);
        assert_eq!(report["stop_reason"], "signal SIGHUP", "{report}");
        assert_braked_to_zero(&report);
    });
}

/// `sipnpuff run | head -3`: stdout's reader goes away. No panic; the safe
/// stop; the report on stderr, saying why; exit 141 (as SIGPIPE).
#[test]
fn run_piped_into_head_stops_safely_and_reports_on_stderr() {
    crate::common::real_time(|| {
        let mut run = start(&[]);
        for _ in 0..3 {
            let line = run.lines.recv().expect("three event lines");
            run.seen.push(line);
        }
        // Close our end of the pipe, as `head -3` exits.
        let (status, mut seen, stderr) = run.close_stdout();
        seen.truncate(3);
        assert_exit(status, &stderr, 141, "run");
        assert!(
            stderr.contains("stdout failed") && stderr.contains("the report follows on stderr"),
            "{stderr}"
        );
        assert!(stderr.contains("== sipnpuff run report"), "{stderr}");
        assert!(stderr.contains("stopped by: output failed"), "{stderr}");
        assert!(stderr.contains(STOPPED_AT_REST), "{stderr}");
        assert!(stderr.contains(ENDED_WITH_ZERO), "{stderr}");
    });
}

/// Stdout's reader goes away while the arm moves: noticed without waiting
/// for the next event to print, the arm brakes, the JSON report goes to
/// stderr.
#[test]
fn stdout_closed_mid_motion_brakes_and_reports_on_stderr() {
    crate::common::real_time(|| {
        let mut run = start(&["--json"]);
        run.wait_until_moving();
        let (status, _, stderr) = run.close_stdout();
        assert_exit(status, &stderr, 141, "run");
        let report = json_report(&stderr);
        assert_eq!(report["stop_reason"], "output failed", "{report}");
        assert!(
            report["output_error"]
                .as_str()
                .is_some_and(|e| e.starts_with("stdout")),
            "{report}"
        );
        assert_braked_to_zero(&report);
    });
}

/// `sipnpuff run > /dev/full` (a full disk): the first event cannot be
/// written; the safe stop, the report on stderr, exit 1 (failed).
#[test]
fn run_onto_a_full_disk_stops_safely_and_fails() {
    let full = std::fs::File::options()
        .write(true)
        .open("/dev/full")
        .unwrap();
    let out = crate::watchdog::wait_with_output(crate::watchdog::spawn(
        crate::common::sipnpuff()
            .args(LONG_RUN)
            .stdin(Stdio::null())
            .stdout(full)
            .stderr(Stdio::piped()),
    ));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_exit(out.status, &stderr, 1, "run");
    assert!(stderr.contains("No space left on device"), "{stderr}");
    assert!(stderr.contains("stopped by: output failed"), "{stderr}");
    assert!(stderr.contains(ENDED_WITH_ZERO), "{stderr}");
}
