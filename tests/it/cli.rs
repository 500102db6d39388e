//! The command line as a user meets it: bad options are refused at once
//! with the choices or the range, a bad file names its line, a sensor
//! that fails mid-run stops the arm and says where, and the `--json`
//! outputs carry every field of their structs.

use std::path::PathBuf;
use std::process::{ExitStatus, Output, Stdio};

use sipnpuff::config::Config;

use crate::common::{ENDED_WITH_ZERO, Running, STOPPED_AT_REST, fixture};
use crate::scratch::Scratch;

use crate::common::sipnpuff_output as sipnpuff;

/// Runs a command that must fail, returning its standard error.
fn refused(args: &[&str]) -> String {
    let out = sipnpuff(args);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{args:?} succeeded:\n{stderr}");
    assert!(
        out.stdout.is_empty(),
        "{args:?} started before refusing:\n{}",
        String::from_utf8_lossy(&out.stdout)
    );
    stderr
}

/// The command ended with exit status `code` without panicking (`what`
/// it was, for the message).
fn assert_exit(status: ExitStatus, stderr: &str, code: i32, what: &str) {
    assert_eq!(status.code(), Some(code), "{what}: {status}\n{stderr}");
    assert!(!stderr.contains("panicked"), "{what}: {stderr}");
}

/// A file named `name` holding `contents`, in a new scratch folder.
fn scratch_file(name: &str, contents: &str) -> (Scratch, PathBuf) {
    let dir = Scratch::new();
    let path = dir.join(name);
    std::fs::write(&path, contents).unwrap();
    (dir, path)
}

/// The demo user's signal (`generate --demo`: replay has events to
/// print), in a new scratch folder.
fn demo_signal() -> (Scratch, PathBuf) {
    let dir = Scratch::new();
    let signal = dir.join("s.csv");
    let generated = sipnpuff(&["generate", "--out", signal.to_str().unwrap(), "--demo"]);
    assert!(generated.status.success());
    (dir, signal)
}

#[test]
fn enumerated_options_list_their_choices() {
    let e = refused(&["run", "--interface", "scan"]);
    assert!(e.contains("[possible values: asp, bsp]"), "{e}");
    let e = refused(&["study", "--sweep", "speed"]);
    assert!(
        e.contains("[possible values: bsp-dwell, asp-timeout, error-rate, library, motion-onset]"),
        "{e}"
    );
    let e = refused(&["run", "--sensor", "hid:/dev/hidraw0"]);
    assert!(
        e.contains("choose `synthetic`, `csv:PATH`, `evdev:/dev/input/eventN`, `evdev:name=SUBSTRING`, `serial:PATH[,baud=N]` or `iio:"),
        "{e}"
    );
    let e = refused(&["run", "--arm", "jaco"]);
    assert!(
        e.contains(
            "unknown arm `jaco`: use `sim`, `ros2:TOPIC`, `ros1:NAMESPACE` or `kinova-sdk:usb|eth`"
        ),
        "{e}"
    );
}

#[test]
fn numbers_out_of_range_are_refused_before_the_run() {
    let e = refused(&["run", "--priority", "120"]);
    assert!(e.contains("120 is not in 0..=99"), "{e}");
    let e = refused(&["bench", "latency", "--spin-margin-us", "1500"]);
    assert!(e.contains("1500 is not in 1..1000"), "{e}");
    let e = refused(&["run", "--seconds", "0"]);
    assert!(e.contains("must be a positive number of seconds"), "{e}");
    let e = refused(&["run", "--cpu", "4096"]);
    assert!(e.contains("--cpu 4096: no such CPU"), "{e}");
    let e = refused(&["study", "--users", "1"]);
    assert!(e.contains("1 is not in 2.."), "{e}");
    let e = refused(&["generate", "--out", "/dev/null", "--noise-volts=-1"]);
    assert!(e.contains("must be finite and 0 or more"), "{e}");
}

#[test]
fn an_unwritable_histogram_dir_is_refused_before_the_run() {
    let (_dir, file) = scratch_file("a-file", "");
    let inside_a_file = file.join("histograms");
    let e = refused(&["run", "--histogram-dir", inside_a_file.to_str().unwrap()]);
    assert!(e.contains("--histogram-dir"), "{e}");
    assert!(e.contains("cannot create it"), "{e}");
}

#[test]
fn a_bad_config_names_the_file_line_and_column() {
    let (_dir, path) = scratch_file(
        "bad.toml",
        "[detector]\nmin_burst_ms = 40\nmin_burst_ms = 50\n",
    );
    let e = refused(&["config", "--config", path.to_str().unwrap()]);
    let expected = format!(
        "{}: 1 problem in the configuration:\n  - line 3, column 1: not valid TOML: duplicate key",
        path.display()
    );
    assert!(e.contains(&expected), "{e}");
    std::fs::write(
        &path,
        "[matcher]\nsequence_timeout_ms = 0\n[command]\ntypo = 1\n",
    )
    .unwrap();
    let e = refused(&["run", "--config", path.to_str().unwrap()]);
    assert!(e.contains("2 problems"), "{e}");
    assert!(
        e.contains("line 2, column 1: matcher.sequence_timeout_ms: must be greater than 0 ms"),
        "{e}"
    );
    assert!(
        e.contains("line 4, column 1: command.typo: unknown key"),
        "{e}"
    );
}

#[test]
fn study_refuses_a_library_without_the_tasks_modes_at_start() {
    // Only two of the six modes the tasks use: the simulated users would
    // wait for the others until the time cap.
    let (_dir, path) = scratch_file(
        "two-modes.toml",
        "[[sequence]]\nactions = [-1, -1]\nmode = \"translate_x\"\n\
         [[sequence]]\nactions = [1, 1]\nmode = \"translate_z\"\n",
    );
    for extra in [&[][..], &["--fit-paper"][..]] {
        let mut args = vec!["study", "--config", path.to_str().unwrap()];
        args.extend_from_slice(extra);
        let out = sipnpuff(&args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_exit(out.status, &stderr, 2, "a library without the modes");
        assert!(out.stdout.is_empty(), "{args:?} printed a study");
        assert!(
            stderr.contains(
                "sequence: no sequence in the library for translate_y, rotate_x, rotate_y, fingers: \
                 the study's tasks need translate_x, translate_y, translate_z, rotate_x, rotate_y, fingers"
            ),
            "{stderr}"
        );
        assert!(!stderr.contains("runs"), "it ran before refusing: {stderr}");
    }
}

#[test]
fn study_fit_paper_refuses_the_other_modes() {
    for other in [
        &["--sweep", "bsp-dwell"][..],
        &["--atypical"][..],
        &["--plot", "x.svg"][..],
    ] {
        let mut args = vec!["study", "--fit-paper"];
        args.extend_from_slice(other);
        let e = refused(&args);
        assert!(e.contains("cannot be used with"), "{e}");
    }
}

#[test]
fn config_prints_every_key_and_reads_back() {
    let out = sipnpuff(&[
        "config",
        "--config",
        fixture("paper-example.toml").to_str().unwrap(),
    ]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    for section in [
        "[detector]",
        "stale_ms = 50",
        "[matcher]",
        "[command]",
        "[motion]",
        "[workspace]",
        "[arm]",
        "[interface]",
        "[scanning]",
        "[[sequence]]  # short sip, long sip, short puff: forward (puff) / backward (sip)",
    ] {
        assert!(text.contains(section), "no {section:?} in\n{text}");
    }
    let printed = Config::from_toml_str(&text).unwrap();
    let paper = Config::from_file(&fixture("paper-example.toml")).unwrap();
    assert_eq!(printed, paper);
}

/// `config --diff`: the keys a profile changes, each with its default and
/// the comment above it, as a table; a bad profile is refused as
/// `--config` refuses it.
#[test]
fn config_diff_prints_each_changed_key_with_its_reason() {
    let (_dir, path) = scratch_file(
        "ana.toml",
        "# sipnpuff profile: label \"ana\"\n\n[detector]\n\
         # midway between the rest noise and your weakest short puff\n\
         puff_threshold_volts = 2.81\n\
         min_burst_ms = 40\n\
         # where your short and long puffs are equally far in spreads\n\
         long_burst_ms = 470\n\n[interface]\nkind = \"bsp\"\n",
    );
    let out = sipnpuff(&["config", "--diff", path.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_exit(out.status, &stderr, 0, "config --diff");
    assert_eq!(
        String::from_utf8(out.stdout).unwrap(),
        format!(
            "\
{}: changes from default
key                            default  this file  reason
-----------------------------  -------  ---------  -------------------------------------------------
detector.puff_threshold_volts  3.0 V    2.81 V     midway between the rest noise and your weakest
                                                   short puff
detector.long_burst_ms         500 ms   470 ms     where your short and long puffs are equally far
                                                   in spreads
interface.kind                 \"asp\"    \"bsp\"
",
            path.display()
        )
    );
    std::fs::write(&path, "[matcher]\n# no wait\nsequence_timeout_ms = 0\n").unwrap();
    let out = sipnpuff(&["config", "--diff", path.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_exit(out.status, &stderr, 2, "config --diff on a bad file");
    assert!(out.stdout.is_empty());
    assert!(
        stderr.contains(&format!(
            "{}: 1 problem in the configuration:\n  - line 3, column 1: matcher.sequence_timeout_ms: must be greater than 0 ms\n",
            path.display()
        )),
        "{stderr}"
    );
}

#[test]
fn a_missing_recording_says_what_to_check() {
    let e = refused(&["run", "--sensor", "csv:/no/such/recording.csv"]);
    assert!(
        e.contains("/no/such/recording.csv: no such file or device"),
        "{e}"
    );
}

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

#[test]
fn bench_accuracy_json_has_every_field_of_the_tally() {
    let out = sipnpuff(&[
        "bench",
        "accuracy",
        "--seconds",
        "20",
        "--noise-volts",
        "0",
        "--hum-volts",
        "0",
        "--json",
    ]);
    assert!(out.status.success());
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["options"]["seconds"], 20);
    let cell = report["cells"][0].as_object().unwrap();
    let fields = [
        "noise_volts",
        "hum_volts",
        "ticks",
        "scripted",
        "too_short",
        "too_long",
        "correct",
        "missed",
        "split_or_merged",
        "wrong_breath",
        "wrong_class",
        "mistimed",
        "invented",
        "max_timing_error_ms",
        "selections",
        "selections_matched",
        "selections_extra",
        "resets",
        "faults",
        "stuck_faults",
        "recoveries",
        "rezeroes",
        "core_allocations",
    ];
    let keys: Vec<&str> = cell.keys().map(String::as_str).collect();
    assert_eq!(keys, fields);
    assert_eq!(cell["correct"], cell["scripted"]);
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

/// Runs `args` with stdout (or stderr) a pipe whose reader has already
/// gone.
fn with_closed(args: &[&str], close_stderr: bool) -> Output {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let mut command = crate::common::sipnpuff();
    command.args(args);
    if close_stderr {
        command
            .stderr(writer)
            .stdout(Stdio::piped())
            .stdin(Stdio::null());
    } else {
        command
            .stdout(writer)
            .stderr(Stdio::piped())
            .stdin(Stdio::null());
    }
    crate::watchdog::wait_with_output(crate::watchdog::spawn(&mut command))
}

#[test]
fn config_into_a_closed_pipe_exits_141_without_panicking() {
    let out = with_closed(&["config"], false);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(141), "{}\n{stderr}", out.status);
    assert!(stderr.is_empty(), "{stderr}");
}

#[test]
fn reports_into_a_closed_pipe_exit_141_without_panicking() {
    let (_dir, signal) = demo_signal();
    for args in [
        vec!["replay", signal.to_str().unwrap()],
        vec!["bench", "tick", "--seconds", "1"],
        vec!["bench", "tick", "--seconds", "1", "--json"],
        vec![
            "bench",
            "accuracy",
            "--seconds",
            "2",
            "--noise-volts",
            "0",
            "--hum-volts",
            "0",
        ],
    ] {
        let out = with_closed(&args, false);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_exit(out.status, &stderr, 141, &format!("{args:?}"));
    }
}

/// A closed stderr (progress and summaries go there) is no reason to fail.
#[test]
fn a_closed_stderr_does_not_fail_a_command() {
    let dir = Scratch::new();
    let signal = dir.join("s.csv");
    let out = with_closed(
        &[
            "generate",
            "--out",
            signal.to_str().unwrap(),
            "--seconds",
            "2",
        ],
        true,
    );
    assert_eq!(out.status.code(), Some(0), "{}", out.status);
    assert!(signal.exists());
}

/// A full disk under `replay --events`/`--trace`: an error naming it, exit
/// 1, no panic.
#[test]
fn replay_onto_a_full_disk_fails_cleanly() {
    let (_dir, signal) = demo_signal();
    for output in ["--events", "--trace"] {
        let out = sipnpuff(&["replay", signal.to_str().unwrap(), output, "/dev/full"]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_exit(out.status, &stderr, 1, output);
        assert!(stderr.contains("No space left on device"), "{stderr}");
    }
}

/// Exit status 2: the command line or the configuration is invalid,
/// nothing was started (clap's own refusals are 2 as well).
#[test]
fn an_invalid_command_line_or_config_exits_2() {
    let (_dir, bad) = scratch_file("bad.toml", "[detector]\nmin_burst_ms = -4\n");
    for args in [
        vec!["run", "--interface", "scan"],
        vec!["config", "--config", bad.to_str().unwrap()],
        vec!["run", "--config", bad.to_str().unwrap()],
        vec!["config", "--config", "/no/such/config.toml"],
        vec!["run", "--cpu", "4096"],
    ] {
        let out = sipnpuff(&args);
        assert_eq!(
            out.status.code(),
            Some(2),
            "{args:?}: {}\n{}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        );
    }
    // A recording that cannot be opened is a failed start, not a usage error.
    let out = sipnpuff(&["run", "--sensor", "csv:/no/such/recording.csv"]);
    assert_eq!(out.status.code(), Some(1), "{}", out.status);
}
