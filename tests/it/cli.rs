//! The command line as a user meets it: bad options are refused at once
//! with the choices or the range, a bad file names its line, a sensor
//! that fails mid-run stops the arm and says where, and the `--json`
//! outputs carry every field of their structs.

use std::process::{Command, Output};

use sipnpuff::config::Config;

use crate::common::fixture;

fn sipnpuff(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sipnpuff"))
        .args(args)
        .output()
        .expect("the sipnpuff binary runs")
}

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

/// A scratch directory for one test.
fn scratch(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("sipnpuff-cli-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn enumerated_options_list_their_choices() {
    let e = refused(&["run", "--interface", "scan"]);
    assert!(e.contains("[possible values: asp, bsp]"), "{e}");
    let e = refused(&["study", "--sweep", "speed"]);
    assert!(
        e.contains("[possible values: bsp-dwell, asp-timeout, error-rate, library]"),
        "{e}"
    );
    let e = refused(&["run", "--sensor", "evdev:/dev/input/event3"]);
    assert!(e.contains("choose `synthetic` or `csv:PATH`"), "{e}");
    let e = refused(&["run", "--arm", "jaco"]);
    assert!(e.contains("[possible values: sim]"), "{e}");
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
    let dir = scratch("hgrm");
    let file = dir.join("a-file");
    std::fs::write(&file, "").unwrap();
    let inside_a_file = file.join("histograms");
    let e = refused(&["run", "--histogram-dir", inside_a_file.to_str().unwrap()]);
    assert!(e.contains("--histogram-dir"), "{e}");
    assert!(e.contains("cannot create it"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_bad_config_names_the_file_line_and_column() {
    let dir = scratch("config");
    let path = dir.join("bad.toml");
    std::fs::write(&path, "[detector]\nmin_burst_ms = 40\nmin_burst_ms = 50\n").unwrap();
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
    std::fs::remove_dir_all(&dir).unwrap();
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
    let dir = scratch("badrow");
    let path = dir.join("cut.csv");
    let mut text = String::from("tick,volts\n");
    for t in 0..500 {
        text += &format!("{t},2.5\n");
    }
    text += "500,two point five\n";
    std::fs::write(&path, text).unwrap();
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
    assert!(
        stdout.contains("stream ended with a zero command and the arm stopped: true"),
        "{stdout}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
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
