//! The command line as a user meets it: bad options are refused at once
//! with the choices or the range, a bad file names its line, a sensor
//! that fails mid-run stops the arm and says where, and the `--json`
//! outputs carry every field of their structs.

use std::path::PathBuf;
use std::process::{Output, Stdio};

use sipnpuff::config::Config;

use crate::common::{assert_exit, fixture, refused};
use crate::scratch::{Scratch, scratch_file};

use crate::common::sipnpuff_output as sipnpuff;

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
        e.contains("choose `synthetic[:BREATHER]`, `csv:PATH`, `evdev:/dev/input/eventN`, `evdev:name=SUBSTRING`, `serial:PATH[,baud=N]` or `iio:"),
        "{e}"
    );
    for command in ["run", "fit"] {
        let e = refused(&[command, "--sensor", "synthetic:nobody", "--no-display"]);
        assert!(
            e.contains(
                "`synthetic:nobody`: no built-in breather has that name; one of typical, weak,"
            ),
            "{e}"
        );
    }
    let e = refused(&["run", "--arm", "jaco"]);
    assert!(
        e.contains(
            "unknown arm `jaco`: use `sim`, `ros2:TOPIC`, `ros1:NAMESPACE` or `kinova-sdk:usb|eth`"
        ),
        "{e}"
    );
}

/// A live `fit` or a recorded `run` refused before it starts (a sensor
/// that is not there) leaves no folder behind: not its default
/// `fit-LABEL-DATE`, nor a `--record` folder it would have made.
#[test]
fn a_session_refused_before_it_starts_leaves_no_folder_behind() {
    let dir = Scratch::new();
    for args in [
        &["fit", "--sensor", "synthetic:nobody", "--no-display"][..],
        &[
            "fit",
            "--sensor",
            "csv:missing.csv",
            "--no-display",
            "--record",
            "new/session",
        ],
        &[
            "run",
            "--sensor",
            "csv:missing.csv",
            "--no-display",
            "--record",
            "new/session",
        ],
    ] {
        let mut command = crate::common::sipnpuff();
        command.args(args).current_dir(&*dir);
        let out = crate::watchdog::output(&mut command);
        assert!(!out.status.success(), "{args:?}");
        let left: Vec<_> = std::fs::read_dir(&*dir)
            .unwrap()
            .flatten()
            .map(|e| e.file_name())
            .collect();
        assert!(left.is_empty(), "{args:?} left {left:?}");
    }
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

/// A sensor that is not there, or named in a form that does not exist:
/// refused before anything starts, saying what was looked for.
#[test]
fn missing_devices_and_wrong_forms_are_clear_errors() {
    for (sensor, says) in [
        (
            "serial:/dev/ttyNONE7",
            "/dev/ttyNONE7: no such file or device",
        ),
        (
            "evdev:/dev/input/event999",
            "/dev/input/event999: no such file or device",
        ),
        (
            "evdev:name=no such device",
            "no input device's name contains \"no such device\"",
        ),
        (
            "iio:/sys/bus/iio/devices/iio:device99/in_voltage0_raw",
            "no such file or device",
        ),
    ] {
        let out =
            crate::watchdog::output(crate::common::sipnpuff().args(["run", "--sensor", sensor]));
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{sensor}: {stderr}");
        assert!(stderr.contains(says), "{sensor}: {stderr}");
    }
    let out = crate::watchdog::output(crate::common::sipnpuff().args(["run", "--sensor", "usb:0"]));
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("evdev:name=SUBSTRING"));
}

#[test]
fn generate_writes_an_imu_users_protocol_and_its_truth() {
    use sipnpuff::control::imu::Channels;
    use sipnpuff::tools::imu_csv::read_imu_csv;

    let dir = Scratch::new();
    let (csv, truth) = (dir.join("imu.csv"), dir.join("truth.json"));
    let out = sipnpuff(&[
        "generate",
        "--imu-user",
        "tremor",
        "--gestures",
        "nod,tilt_left",
        "--rate-hz",
        "50",
        "--seed",
        "4",
        "--out",
        csv.to_str().unwrap(),
        "--truth",
        truth.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let recording = read_imu_csv(&csv).unwrap();
    assert_eq!(recording.channels, Channels::ALL);
    assert!(recording.samples.windows(2).all(|w| w[1].0 - w[0].0 == 20));
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&truth).unwrap()).unwrap();
    assert_eq!(truth["user"]["name"], "tremor");
    assert_eq!(truth["user"]["rate_hz"], 50);
    assert_eq!(truth["session"], "protocol");
    assert_eq!(truth["asked"], serde_json::json!(["nod", "tilt_left"]));
    assert_eq!(truth["samples"], recording.samples.len());
    let gestures = truth["gestures"].as_array().unwrap();
    assert_eq!(gestures.len(), 10);
    assert_eq!(gestures[5]["name"], "tilt_left");
    assert_eq!(gestures[5]["example"], 1);
    let ordinary = &truth["ordinary"][0];
    let length = ordinary["end"].as_u64().unwrap() - ordinary["start"].as_u64().unwrap();
    assert!(length >= 60_000, "{ordinary}");
    // Only the two files: nothing partial left beside them.
    assert_eq!(std::fs::read_dir(&*dir).unwrap().count(), 2);

    let e = refused(&["generate", "--imu-user", "nobody", "--out", "/dev/null"]);
    assert!(
        e.contains("no IMU user \"nobody\": one of typical, slow_small, fast_large, tremor, wheelchair, drifting"),
        "{e}"
    );
    let e = refused(&[
        "generate",
        "--imu-user",
        "typical",
        "--gestures",
        "nod,wave",
        "--out",
        "/dev/null",
    ]);
    assert!(
        e.contains("no gesture \"wave\": one of nod, double_nod,"),
        "{e}"
    );
    let e = refused(&[
        "generate",
        "--imu-user",
        "typical",
        "--breather",
        "typical",
        "--out",
        "/dev/null",
    ]);
    assert!(e.contains("cannot be used with"), "{e}");
    let long = [
        "generate",
        "--imu-user",
        "typical",
        "--session",
        "use",
        "--minutes",
        "1000",
    ];
    let out = sipnpuff(&[&long[..], &["--rate-hz", "1000", "--out", "/dev/null"]].concat());
    let e = String::from_utf8_lossy(&out.stderr);
    assert_exit(out.status, &e, 2, "a session too long to hold");
    assert!(e.contains("is 60000000 samples: at most 8640000"), "{e}");
}

#[test]
fn generate_writes_an_imu_users_practice() {
    let dir = Scratch::new();
    let (csv, truth) = (dir.join("imu.csv"), dir.join("truth.json"));
    let out = sipnpuff(&[
        "generate",
        "--imu-user",
        "typical",
        "--session",
        "practice",
        "--per-gesture",
        "2",
        "--gestures",
        "wobble,nod",
        "--rate-hz",
        "10",
        "--out",
        csv.to_str().unwrap(),
        "--truth",
        truth.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_exit(out.status, &stderr, 0, "practice");
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&truth).unwrap()).unwrap();
    assert_eq!(
        truth["session"],
        serde_json::json!({"practice": {"per_gesture": 2}})
    );
    let gestures = truth["gestures"].as_array().unwrap();
    assert_eq!(gestures.len(), 4);
    let wobbles = gestures.iter().filter(|g| g["name"] == "wobble").count();
    assert_eq!(wobbles, 2, "{gestures:?}");
    assert!(stderr.contains("wrote the truth of 4 gestures"), "{stderr}");
}

/// An option that does not apply to the session asked for: refused in
/// one line, before anything is written.
#[test]
fn generate_refuses_imu_options_the_session_does_not_use() {
    let dir = Scratch::new();
    let csv = dir.join("imu.csv");
    let csv = csv.to_str().unwrap();
    for (options, says) in [
        (
            &["--minutes", "5"][..],
            "--minutes is for --session use or ordinary: a protocol session's length is set by \
             its gestures",
        ),
        (
            &["--session", "protocol", "--minutes", "5"],
            "--minutes is for --session use or ordinary: a protocol",
        ),
        (
            &["--session", "practice", "--minutes", "5"],
            "--minutes is for --session use or ordinary: a practice",
        ),
        (
            &["--session", "ordinary", "--gestures", "nod"],
            "--gestures is not for --session ordinary: ordinary movement makes no gesture",
        ),
        (
            &["--session", "use", "--per-gesture", "3"],
            "--per-gesture is for --session practice, not use",
        ),
        (
            &[
                "--session",
                "practice",
                "--per-gesture",
                "1000",
                "--rate-hz",
                "1000",
            ],
            "--per-gesture 1000 of 6 gestures at --rate-hz 1000 is up to 180000000 samples: \
             at most 8640000",
        ),
    ] {
        let args = [
            &["generate", "--imu-user", "typical", "--out", csv],
            options,
        ]
        .concat();
        let out = sipnpuff(&args);
        let e = String::from_utf8_lossy(&out.stderr);
        assert_exit(out.status, &e, 2, &args.join(" "));
        assert!(e.contains(says), "{options:?}: {e}");
        assert_eq!(e.lines().count(), 1, "{options:?}: {e}");
        assert!(out.stdout.is_empty());
    }
    assert_eq!(std::fs::read_dir(&*dir).unwrap().count(), 0);
}
