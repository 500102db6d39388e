//! Session recordings (`run --record DIR`, `replay DIR`): real runs of
//! the binary recorded and replayed to the same events and arm commands,
//! bit for bit (skipped ticks, a stall and the safe stop included); a
//! damaged recording named by file and offset; the size cap, a full disk
//! and a stalled disk marked incomplete while the run goes on; the binary
//! format round-tripped for any input.

use std::path::{Path, PathBuf};
use std::process::Output;
use std::time::Duration;

use proptest::prelude::*;
use serde_json::Value;
use sipnpuff::arm::sim::SimArm;
use sipnpuff::config::Config;
use sipnpuff::control::motion::stream::ArmCommand;
use sipnpuff::control::sample::Sample;
use sipnpuff::control::tick::TickInput;
use sipnpuff::rt::threads::{LoopSettings, RunOptions, run};
use sipnpuff::sim::synthetic_sensor::SyntheticSensor;
use sipnpuff::tools::recording::format::commands::{CommandDecoder, CommandEncoder, CommandItem};
use sipnpuff::tools::recording::format::samples::{SampleDecoder, SampleEncoder, SampleItem};
use sipnpuff::tools::recording::format::{Stream, StreamFile};
use sipnpuff::tools::recording::recorder::Recorder;
use sipnpuff::tools::recording::writer::RecordOptions;

use crate::common::TickByTick;
use crate::common::{Running, fixture};
use crate::scratch::Scratch;

fn sipnpuff(args: &[&str]) -> Output {
    let mut command = crate::common::sipnpuff();
    command.args(args);
    let output = crate::watchdog::output(&mut command);
    crate::common::witness(&text(&output.stdout));
    output
}

fn shared_machine() -> String {
    fixture("shared-machine.toml").to_str().unwrap().to_string()
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn text(out: &[u8]) -> String {
    String::from_utf8_lossy(out).into_owned()
}

/// `replay DIR`: (exit code, events on stdout, stderr).
fn replay(dir: &Path) -> (i32, String, String) {
    let out = sipnpuff(&["replay", dir.to_str().unwrap()]);
    (
        out.status.code().unwrap_or(-1),
        text(&out.stdout),
        text(&out.stderr),
    )
}

/// `replay DIR` fails (exit 1) saying each of `parts`.
fn assert_replay_fails(dir: &Path, parts: &[&str]) {
    let (code, _, stderr) = replay(dir);
    assert_eq!(code, 1, "{stderr}");
    for part in parts {
        assert!(stderr.contains(part), "{part}: {stderr}");
    }
}

/// What every complete recording of a run must show: its report and
/// metadata agree, `replay` says it is identical, and the replayed events
/// are the lines `run` printed.
fn assert_replays_bit_for_bit(dir: &Path, run_stdout: &[String]) -> Value {
    let (events, report) = run_stdout.split_at(run_stdout.len() - 1);
    let report: Value = serde_json::from_str(&report[0]).unwrap();
    let recording = &report["recording"];
    assert_eq!(recording["complete"], true, "{report}");
    assert_eq!(report["control_thread_allocations"], 0);
    // report.json is the report printed.
    assert_eq!(json(&dir.join("report.json")), report);
    let meta = json(&dir.join("meta.json"));
    assert_eq!(meta["status"], "finished");
    assert_eq!(meta["complete"], true);
    assert_eq!(meta["ticks"], report["stats"]["ticks_run"], "{meta}");
    // The core's commands: those the arm got and those its ring dropped.
    let produced = report["arm_commands"].as_u64().unwrap()
        + report["drops"]["arm_commands"].as_u64().unwrap();
    assert_eq!(meta["arm_commands"], produced, "{meta}");
    assert_eq!(meta["events"], events.len(), "{meta}");
    assert_eq!(meta["sensor"], report["sensor"]);
    // The configuration reloads to itself.
    let printed = std::fs::read_to_string(dir.join("config.toml")).unwrap();
    let config = Config::from_toml_str(&printed).unwrap();
    assert_eq!(config.to_toml().unwrap(), printed);

    let (code, replayed, stderr) = replay(dir);
    assert_eq!(code, 0, "{stderr}\n{meta}");
    assert!(
        stderr.contains(&format!(
            "identical to the recording, bit for bit: {} events and {} arm commands (safe stop begun at tick {})",
            events.len(),
            meta["arm_commands"],
            meta["stop_tick"]
        )),
        "{stderr}"
    );
    let replayed: Vec<&str> = replayed.lines().collect();
    assert_eq!(replayed, events, "replay's events are the run's");
    // The safe stop began on the recorded tick: if the core was in
    // command mode, it left it for good on that tick.
    let stop_tick = meta["stop_tick"].as_u64().expect("a recorded stop");
    if let Some(stop) = events
        .iter()
        .map(|l| serde_json::from_str::<Value>(l).unwrap())
        .find(|e| e["event"] == "detection" && e["reason"] == "stop")
    {
        assert_eq!(stop["tick"], stop_tick, "{meta}");
    }
    meta
}

/// 8 s of the built-in user (save the pose, then forward; the time is up
/// mid-move and the arm brakes), recorded and replayed: the same events
/// and arm commands, the braking included, bit for bit. Then a recording whose configuration was
/// changed: the replay names the first arm command that differs.
#[test]
fn a_recorded_run_of_the_built_in_user_replays_bit_for_bit() {
    crate::common::real_time(|| {
        let scratch = Scratch::new();
        let dir = scratch.join("rec");
        let run = Running::spawn(&[
            "run",
            "--json",
            "--seconds",
            "8",
            "--config",
            &shared_machine(),
            "--record",
            dir.to_str().unwrap(),
        ]);
        // However this loaded machine paced it (a stall halts the motion,
        // which restarts from rest), the recording must replay to it exactly.
        let (status, stdout, stderr) = run.finish();
        assert!(status.success(), "{status}\n{stderr}");
        // The stop came in command mode, mid-move: the core braked the arm
        // from the tick whose input began the stop, and the replay must too.
        assert!(
            stdout.iter().any(|l| l.contains("\"reason\":\"stop\"")),
            "not stopped in command mode: {stdout:?}"
        );
        let meta = assert_replays_bit_for_bit(&dir, &stdout);
        assert!(meta["ticks"].as_u64().unwrap() > 6_000, "{meta}");

        // 0.2 → 0.19 m/s: the first move's commands differ from the 767th on.
        let changed = scratch.join("changed");
        copy_recording(&dir, &changed);
        let config = std::fs::read_to_string(changed.join("config.toml")).unwrap();
        assert!(config.contains("\nlinear_speed_mps = 0.2\n"));
        let config = config.replace("\nlinear_speed_mps = 0.2\n", "\nlinear_speed_mps = 0.19\n");
        std::fs::write(changed.join("config.toml"), config).unwrap();
        assert_replay_fails(
            &changed,
            &[
                "DIFFERENT from the recording: first difference: arm command ",
                "linear x: recorded ",
            ],
        );
    });
}

/// A CSV recording played in real time and stopped for 1.2 s (SIGSTOP, as
/// a paused VM would): the gap, the fault it is and the discarded backlog
/// are what the core saw, and the replay reproduces them, bit for bit.
#[test]
fn a_recorded_csv_run_with_a_stall_replays_bit_for_bit() {
    crate::common::real_time(|| {
        let scratch = Scratch::new();
        let dir = scratch.join("rec");
        let sensor = format!("csv:{}", fixture("demo.csv").display());
        let mut run = Running::spawn(&[
            "run",
            "--json",
            "--seconds",
            "4",
            "--sensor",
            &sensor,
            "--config",
            &shared_machine(),
            "--record",
            dir.to_str().unwrap(),
        ]);
        run.wait_for("\"event\":\"match\"");
        run.pause(Duration::from_millis(1200));
        let (status, stdout, stderr) = run.finish();
        assert!(status.success(), "{status}\n{stderr}");
        assert!(
            stdout.iter().any(|l| l.contains("stalled for")),
            "no stall fault:\n{}",
            stdout.join("\n")
        );
        let meta = assert_replays_bit_for_bit(&dir, &stdout);
        assert!(meta["sensor"].as_str().unwrap().starts_with("csv:"));
        // The gap is in the recording: more ticks spanned than stepped.
        let span = meta["last_tick"].as_u64().unwrap() - meta["first_tick"].as_u64().unwrap() + 1;
        assert!(span >= meta["ticks"].as_u64().unwrap() + 1100, "{meta}");
    });
}

/// A serial device (a real kernel tty) resting at 2.6 V, re-zeroed at
/// start, then unplugged: the recording holds the configuration the core
/// ran with (the measured neutral, not the configured 2.5 V) and the
/// ticks with the device gone (`Sample::Lost`), and replays bit for
/// bit.
#[test]
fn a_recorded_serial_device_that_is_unplugged_replays_bit_for_bit() {
    crate::common::real_time(|| {
        use crate::sensors::{Pty, stream};
        const BREATHS: [(f64, u64); 5] =
            [(2.6, 3000), (4.0, 800), (2.6, 400), (1.5, 150), (2.6, 500)];
        let scratch = Scratch::new();
        let dir = scratch.join("rec");
        let pty = Pty::open();
        let sensor = format!("serial:{}", pty.path);
        let feeder = stream(pty, &BREATHS, 1, |v| format!("{v:.3}\n"));
        let run = Running::spawn(&[
            "run",
            "--json",
            "--sensor",
            &sensor,
            "--config",
            &shared_machine(),
            "--record",
            dir.to_str().unwrap(),
        ]);
        let (status, stdout, stderr) = run.finish();
        feeder.join().unwrap();
        // Unplugged: a fault, the run stopped safely, exit 1.
        assert_eq!(status.code(), Some(1), "{stderr}");
        assert!(
            stderr.contains("neutral 2.6000 V measured at rest"),
            "{stderr}"
        );
        let meta = assert_replays_bit_for_bit(&dir, &stdout);
        let config = std::fs::read_to_string(dir.join("config.toml")).unwrap();
        let neutral = Config::from_toml_str(&config)
            .unwrap()
            .core()
            .detector()
            .neutral_volts;
        assert!((neutral - 2.6).abs() < 1e-9, "{neutral}\n{meta}");
        let file = std::io::BufReader::new(std::fs::File::open(dir.join("samples.bin")).unwrap());
        let mut samples = SampleDecoder::new(file).unwrap();
        let mut gone = 0;
        while let Some(item) = samples.next_item().unwrap() {
            if let SampleItem::Input(TickInput {
                sample: Sample::Lost,
                ..
            }) = item
            {
                gone += 1;
            }
        }
        assert!(gone > 0, "no tick with the device gone: {meta}");
    });
}

/// Past `--record-max-mb` recording stops, the run goes on to its end,
/// the report and metadata say what was not written, and replay compares
/// what there is but does not claim equality.
#[test]
fn a_recording_past_its_size_cap_is_incomplete_and_replay_says_so() {
    crate::common::real_time(|| {
        let scratch = Scratch::new();
        let dir = scratch.join("rec");
        let out = sipnpuff(&[
            "run",
            "--seconds",
            "1.5",
            "--config",
            &shared_machine(),
            "--record",
            dir.to_str().unwrap(),
            "--record-max-mb",
            "0.005",
        ]);
        let stdout = text(&out.stdout);
        assert!(out.status.success(), "{stdout}{}", text(&out.stderr));
        assert!(stdout.contains("stopped by: time"), "{stdout}");
        assert!(
            stdout.contains("INCOMPLETE (the size cap of 0.005 MB was reached at tick "),
            "{stdout}"
        );
        let meta = json(&dir.join("meta.json"));
        assert_eq!(
            (&meta["status"], &meta["complete"]),
            (&"finished".into(), &false.into())
        );
        assert!(meta["bytes"].as_u64().unwrap() <= 5000, "{meta}");
        assert!(meta["lost"]["ticks"].as_u64().unwrap() > 0, "{meta}");
        assert!(meta["problems"][0].as_str().unwrap().contains("size cap"));
        assert_replay_fails(
            &dir,
            &[
                "NOT VERIFIED: the recording is incomplete (the size cap",
                "identical so far",
            ],
        );
    });
}

/// A disk that refuses every write (`/dev/full`): the run goes on to its
/// end and brakes as usual; the recording failed, the report says why and
/// the exit status is 1.
#[test]
fn a_full_disk_fails_the_recording_not_the_run() {
    crate::common::real_time(|| {
        let scratch = Scratch::new();
        let dir = scratch.join("rec");
        std::fs::create_dir_all(&dir).unwrap();
        std::os::unix::fs::symlink("/dev/full", dir.join("commands.bin")).unwrap();
        let out = sipnpuff(&[
            "run",
            "--seconds",
            "1",
            "--config",
            &shared_machine(),
            "--record",
            dir.to_str().unwrap(),
        ]);
        let stdout = text(&out.stdout);
        assert_eq!(out.status.code(), Some(1), "{stdout}");
        assert!(stdout.contains("stopped by: time"), "{stdout}");
        assert!(
            stdout.contains("last arm command zero: true")
                && stdout.contains("control thread heap allocations after start: 0"),
            "{stdout}"
        );
        assert!(
            stdout.contains("INCOMPLETE (cannot write ")
                && stdout.contains("commands.bin: No space left on device"),
            "{stdout}"
        );
    });
}

/// A writer that cannot drain its queue (its first file is a FIFO nobody
/// reads: `open` blocks, as on a hung disk): the loop runs its ticks with
/// no allocation, every item that does not fit is dropped and counted,
/// and `finish` gives up after the stall timeout instead of waiting.
#[test]
fn a_stalled_writer_drops_and_counts_and_never_holds_up_the_loop() {
    let scratch = Scratch::new();
    let dir = scratch.join("rec");
    std::fs::create_dir_all(&dir).unwrap();
    let fifo = std::ffi::CString::new(dir.join("samples.bin").to_str().unwrap()).unwrap();
    // SAFETY: a valid NUL-terminated path; mkfifo has no memory effects.
    assert_eq!(unsafe { libc::mkfifo(fifo.as_ptr(), 0o600) }, 0);
    let config = Config::from_file(&fixture("shared-machine.toml")).unwrap();
    let options = RecordOptions {
        queue: 64,
        stall_timeout: Duration::from_millis(300),
        ..RecordOptions::default()
    };
    let mut recorder = Recorder::create(&dir, &config, options).unwrap();
    let settings = LoopSettings::plain(1.5);
    let sensor = SyntheticSensor::built_in_user(&config);
    let arm = Box::new(SimArm::new(config.core()));
    let options = RunOptions::new(sensor, arm, settings).recorder(&mut recorder);
    let mut report = run(config.core(), options).unwrap();
    let recording = recorder.finish(&mut report);
    let ticks = report.stats.ticks_run;
    assert!(ticks >= 1000, "{:?}", report.stats);
    assert_eq!(report.control_thread_allocations, 0);
    assert_eq!(report.drops.records, 0);
    assert!(report.last_arm_command.is_zero());
    assert!(!recording.summary.complete);
    assert!(
        recording
            .error
            .as_deref()
            .unwrap()
            .contains("made no progress"),
        "{recording:?}"
    );
    // Everything beyond the queue's 64 items was dropped and counted; the
    // rest is lost in the unfinished files.
    assert!(recording.summary.problems[0].contains("the recorder's queue was full"));
    assert_eq!(recording.summary.lost.ticks, ticks, "{recording:?}");
    assert_eq!(report.recording.as_ref(), Some(&recording));
    assert!(report.to_text().contains("INCOMPLETE ("));
    // A FIFO is not read (it would block): the file is named.
    let (code, _, stderr) = replay(&dir);
    assert_eq!(code, 1);
    assert!(
        stderr.contains("meta.json: missing") || stderr.contains("not a regular file"),
        "{stderr}"
    );
    // Let the writer out of its `open` (it then fails on the closed pipe
    // and ends).
    // SAFETY: a valid NUL-terminated path; the descriptor is closed at once.
    unsafe {
        let fd = libc::open(fifo.as_ptr(), libc::O_RDONLY | libc::O_NONBLOCK);
        if fd >= 0 {
            libc::close(fd);
        }
    }
}

/// A queue of 16 items fed a whole session in a tight loop (faster than
/// any writer): items are dropped and counted, the streams mark where
/// ticks and commands were lost, and replay compares only up to the
/// first loss and never claims equality.
#[test]
fn dropped_items_are_marked_in_the_streams_and_replay_does_not_claim_equality() {
    crate::common::real_time(|| {
        use sipnpuff::control::event::TimedEvent;
        use sipnpuff::control::pipeline::Pipeline;
        use sipnpuff::rt::recorder::SessionRecorder;
        use sipnpuff::sim::script::run_script;
        use sipnpuff::sim::sensor_model::{SignalGenerator, SignalParams};
        use sipnpuff::tools::recording::read::Recording;

        let scratch = Scratch::new();
        let dir = scratch.join("rec");
        let config = Config::default();
        let options = RecordOptions {
            queue: 16,
            ..RecordOptions::default()
        };
        let mut recorder = Recorder::create(&dir, &config, options).unwrap();
        recorder.start("test", "test");
        let (script, _) = run_script(&config);
        let samples =
            SignalGenerator::new(SignalParams::clean(config.core().detector(), 3), &script);
        let mut core: Pipeline = Pipeline::new(config.core());
        let mut ticks = 0;
        for (tick, volts) in samples.enumerate() {
            let tick = tick as u64;
            let out = core.tick(tick, volts);
            recorder.input(&TickInput {
                tick,
                sample: Sample::Volts(volts),
                stop: false,
                ..TickInput::default()
            });
            for &event in out.events.iter() {
                recorder.event(&TimedEvent { tick, event });
            }
            if let Some(command) = &out.motion.arm_command {
                recorder.command(command);
            }
            ticks += 1;
        }
        let settings = LoopSettings::plain(0.01);
        let sensor = SyntheticSensor::built_in_user(&config);
        let arm = Box::new(SimArm::new(config.core()));
        let mut report = run(config.core(), RunOptions::new(sensor, arm, settings)).unwrap();
        let finished = recorder.finish(&mut report);
        assert!(finished.error.is_none(), "{finished:?}");
        let summary = finished.summary;
        assert!(!summary.complete);
        assert!(summary.lost.ticks > 0, "{summary:?}");
        assert_eq!(summary.ticks + summary.lost.ticks, ticks, "{summary:?}");
        assert!(summary.problems[0].contains("the recorder's queue was full"));

        let recording = Recording::open(&dir).unwrap();
        let contents = recording.check().unwrap();
        assert_eq!(contents.ticks, summary.ticks);
        assert!(contents.losses > 0, "{contents:?}");
        let verdict = sipnpuff::tools::recording::recording_replay::replay(
            &recording,
            &recording.config,
            true,
            &mut Vec::new(),
            None,
        )
        .unwrap();
        assert!(!verdict.complete && !verdict.identical(), "{verdict:?}");
        assert!(
            verdict.compared_through < verdict.last_tick,
            "compared only up to the first loss: {verdict:?}"
        );
        assert_replay_fails(
            &dir,
            &["NOT VERIFIED: the recording is incomplete (the recorder's queue was full"],
        );
    });
}

/// A short recording of the built-in user to damage (made once): 3 s,
/// its first bursts and match.
fn short_recording() -> &'static Path {
    static DIR: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let dir = Scratch::new().until_exit().join("rec");
        let out = sipnpuff(&[
            "run",
            "--seconds",
            "3",
            "--config",
            &shared_machine(),
            "--record",
            dir.to_str().unwrap(),
        ]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        dir
    })
}

/// A copy of the short recording, in `rec` in a fresh scratch directory
/// (removed when the copy is dropped).
fn copy_of_short_recording() -> (Scratch, PathBuf) {
    let scratch = Scratch::new();
    let dir = scratch.join("rec");
    copy_recording(short_recording(), &dir);
    (scratch, dir)
}

/// A copy of the recording in `from`, in `to`.
fn copy_recording(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, to.join(path.file_name().unwrap())).unwrap();
    }
}

/// A copy of the short recording, `damage` done to it, replayed: the
/// error.
fn damaged(name: &str, damage: impl FnOnce(&Path)) -> String {
    let (_copy, dir) = copy_of_short_recording();
    damage(&dir);
    let (code, events, stderr) = replay(&dir);
    assert_eq!(code, 1, "{name}: {stderr}");
    assert!(events.is_empty(), "{name}: replayed before the check");
    stderr
}

fn edit_bytes(path: &Path, edit: impl FnOnce(&mut Vec<u8>)) {
    let mut bytes = std::fs::read(path).unwrap();
    edit(&mut bytes);
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn a_damaged_recording_is_an_error_naming_the_file_and_offset() {
    let (code, _, stderr) = replay(short_recording());
    assert_eq!(code, 0, "{stderr}");

    let e = damaged("truncated", |dir| {
        edit_bytes(&dir.join("samples.bin"), |b| b.truncate(b.len() / 2));
    });
    assert!(
        e.contains("rec/samples.bin: offset ") && e.contains(": truncated"),
        "{e}"
    );
    let e = damaged("flipped", |dir| {
        edit_bytes(&dir.join("samples.bin"), |b| {
            let i = b.len() / 2;
            b[i] ^= 0x04;
        });
    });
    assert!(e.contains("rec/samples.bin: offset "), "{e}");
    let e = damaged("commands", |dir| {
        edit_bytes(&dir.join("commands.bin"), |b| b.truncate(b.len() - 3));
    });
    assert!(
        e.contains("rec/commands.bin: offset ") && e.contains("truncated"),
        "{e}"
    );
    let e = damaged("swapped", |dir| {
        std::fs::copy(dir.join("commands.bin"), dir.join("samples.bin")).unwrap();
    });
    assert!(
        e.contains("rec/samples.bin: offset 0: holds the commands stream"),
        "{e}"
    );
    let e = damaged("event", |dir| {
        let text = std::fs::read_to_string(dir.join("events.jsonl")).unwrap();
        std::fs::write(dir.join("events.jsonl"), format!("{text}{{\"tick\":")).unwrap();
    });
    assert!(e.contains("rec/events.jsonl: line "), "{e}");
    let e = damaged("meta", |dir| {
        std::fs::remove_file(dir.join("meta.json")).unwrap()
    });
    assert!(e.contains("rec/meta.json: missing"), "{e}");
    let e = damaged("config", |dir| {
        std::fs::write(dir.join("config.toml"), "[detector]\nmin_burst = 40\n").unwrap();
    });
    assert!(
        e.contains("rec/config.toml: ") && e.contains("detector.min_burst"),
        "{e}"
    );
    let e = damaged("count", |dir| {
        let meta = std::fs::read_to_string(dir.join("meta.json")).unwrap();
        let meta = meta.replacen("\"ticks\": ", "\"ticks\": 1", 1);
        std::fs::write(dir.join("meta.json"), meta).unwrap();
    });
    assert!(e.contains("rec/meta.json: says 1"), "{e}");
}

/// `bench replay` times the whole replay against the core alone through
/// the same inputs, and the core alone did the replay's work: its steps,
/// events and arm commands are the recording's. A damaged recording is
/// refused as `replay` refuses it.
#[test]
fn bench_replay_times_the_replay_against_the_core_alone() {
    let dir = short_recording();
    let out = sipnpuff(&[
        "bench",
        "replay",
        dir.to_str().unwrap(),
        "--rounds",
        "3",
        "--json",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let report: Value = serde_json::from_str(&text(&out.stdout)).unwrap();
    let meta = json(&dir.join("meta.json"));
    assert_eq!(report["ticks"], meta["ticks"], "{report}");
    assert_eq!(report["events"], meta["events"], "{report}");
    assert_eq!(report["arm_commands"], meta["arm_commands"], "{report}");
    assert_eq!(report["identical"], true);
    assert_eq!(report["rounds"], 3);
    // Figures as JSON gives them back: serde_json's parser may be an ulp
    // off the printed value, so they agree to rounding.
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
    let ticks = meta["ticks"].as_f64().unwrap();
    let recorded_s = report["recorded_s"].as_f64().unwrap();
    assert!(close(recorded_s, ticks / 1000.0), "{report}");
    let figure = |part: &str, key: &str| report[part][key].as_f64().unwrap();
    for part in ["whole_replay", "core_alone"] {
        let (median, min) = (figure(part, "median_ms"), figure(part, "min_ms"));
        assert!(min > 0.0 && min <= median, "{report}");
        let rate = ticks / 1000.0 / (median / 1e3);
        assert!(close(figure(part, "real_time"), rate), "{report}");
    }
    let share = figure("core_alone", "median_ms") / figure("whole_replay", "median_ms");
    assert!(
        close(report["core_share"].as_f64().unwrap(), share),
        "{report}"
    );
    let out = sipnpuff(&["bench", "replay", dir.to_str().unwrap(), "--rounds", "1"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let table = text(&out.stdout);
    assert!(
        table.contains("identical to the recording; 1 rounds of each")
            && table.contains("the core alone, stepped through the same inputs (the floor)"),
        "{table}"
    );

    let (_copy, damaged) = copy_of_short_recording();
    edit_bytes(&damaged.join("samples.bin"), |b| b.truncate(b.len() / 2));
    let out = sipnpuff(&["bench", "replay", damaged.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let e = text(&out.stderr);
    assert!(
        e.contains("rec/samples.bin: offset ") && e.contains(": truncated"),
        "{e}"
    );
    assert!(out.stdout.is_empty());
}

/// `--events` and `--trace` work for a recording as for a CSV signal:
/// the events are the recorded lines, the trace has a row per tick.
#[test]
fn a_recording_replays_to_events_and_trace_files() {
    let scratch = Scratch::new();
    let (events, trace) = (scratch.join("events.jsonl"), scratch.join("trace.csv"));
    let dir = short_recording();
    let out = sipnpuff(&[
        "replay",
        dir.to_str().unwrap(),
        "--events",
        events.to_str().unwrap(),
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(out.stdout.is_empty());
    assert_eq!(
        std::fs::read_to_string(&events).unwrap(),
        std::fs::read_to_string(dir.join("events.jsonl")).unwrap()
    );
    let trace = std::fs::read_to_string(&trace).unwrap();
    let meta = json(&dir.join("meta.json"));
    assert_eq!(
        trace.lines().count() as u64,
        meta["ticks"].as_u64().unwrap() + 1
    );
    assert!(trace.starts_with("tick,mode,vx,"), "{trace}");
    // With another configuration it is replayed, not compared.
    let paper = fixture("paper-example.toml");
    let out = sipnpuff(&[
        "replay",
        dir.to_str().unwrap(),
        "--config",
        paper.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    assert!(
        text(&out.stderr).contains("not compared: replayed with --config "),
        "{}",
        text(&out.stderr)
    );
}

#[test]
fn a_recorded_event_that_differs_is_named_with_its_line() {
    let (_copy, dir) = copy_of_short_recording();
    let events = std::fs::read_to_string(dir.join("events.jsonl")).unwrap();
    let first = events
        .lines()
        .next()
        .expect("an event in 1.5 s")
        .to_string();
    let changed = first.replacen("{\"tick\":", "{\"tick\":1", 1);
    std::fs::write(
        dir.join("events.jsonl"),
        events.replacen(&first, &changed, 1),
    )
    .unwrap();
    let (code, _, stderr) = replay(&dir);
    assert_eq!(code, 1);
    assert!(
        stderr.contains(&format!(
            "DIFFERENT from the recording: first difference: event 1 (line 1 of events.jsonl): recorded {changed}, replayed {first}"
        )),
        "{stderr}"
    );
}

/// A core input: a sample (any bits: NaN payloads, -0.0, the rails, a few
/// levels a sample-and-hold sensor repeats), none, or the device gone,
/// after a gap of skipped ticks, perhaps where the stop began.
fn inputs() -> impl Strategy<Value = Vec<(u64, Sample, bool)>> {
    let value = prop_oneof![
        3 => prop::sample::select(vec![2.5, 2.5, 4.0, -0.0, 0.0, 5.0]),
        2 => any::<f64>(),
        1 => any::<u64>().prop_map(f64::from_bits),
    ];
    let sample = prop_oneof![
        8 => value.prop_map(Sample::Volts),
        2 => Just(Sample::Missing),
        1 => Just(Sample::Lost),
    ];
    let gap = prop_oneof![6 => Just(0u64), 2 => 1u64..100, 1 => 0u64..u64::MAX / 4];
    prop::collection::vec((gap, sample, prop::bool::weighted(0.02)), 0..400)
}

proptest! {
    /// Any sequence of values, missing samples, ticks with the device
    /// gone, gaps, stops and losses comes back tick for tick and bit for
    /// bit.
    #[test]
    fn samples_round_trip(first in 0u64..5, items in inputs(), losses in prop::collection::vec((0usize..400, 1u64..1000), 0..3)) {
        let mut tick = first;
        let inputs: Vec<TickInput> = items
            .iter()
            .map(|&(gap, sample, stop)| {
                tick = tick.wrapping_add(gap);
                let input = TickInput {
                    tick,
                    sample,
                    stop,
                    ..TickInput::default()
                };
                tick = tick.wrapping_add(1);
                input
            })
            .collect();
        let mut file = StreamFile::start(Vec::new(), Stream::Samples).unwrap();
        let (mut enc, mut ops) = (SampleEncoder::default(), Vec::new());
        let mut expected = Vec::new();
        for (i, input) in inputs.iter().enumerate() {
            for &(at, n) in &losses {
                if at == i {
                    enc.lost(&mut ops, n);
                    expected.push(SampleItem::Lost(n));
                }
            }
            enc.input(&mut ops, input);
            expected.push(SampleItem::Input(*input));
            // Commit in pieces, as the writer does.
            if i % 37 == 0 {
                file.write(&ops).unwrap();
                ops.clear();
            }
        }
        enc.flush(&mut ops);
        file.write(&ops).unwrap();
        let bytes = file.end().unwrap();
        let mut dec = SampleDecoder::new(bytes.as_slice()).unwrap();
        let mut back = Vec::new();
        while let Some(item) = dec.next_item().unwrap() {
            back.push(item);
        }
        prop_assert_eq!(back.len(), expected.len());
        for (a, b) in back.iter().zip(&expected) {
            let bits = |item: &SampleItem| match *item {
                SampleItem::Input(TickInput { tick, sample, stop, .. }) => match sample {
                    Sample::Volts(v) => (0, tick, v.to_bits(), stop),
                    Sample::Missing => (1, tick, 0, stop),
                    Sample::Lost => (4, tick, 0, stop),
                },
                SampleItem::Lost(n) => (3, n, 0, false),
            };
            prop_assert_eq!(bits(a), bits(b));
        }
        // At most 9 bytes a tick, plus what gaps, stops and losses cost.
        let extra = items.iter().filter(|i| i.0 > 0 || i.2).count() + losses.len();
        prop_assert!(bytes.len() <= 15 + 9 * inputs.len() + 11 * extra + 11);
    }

    /// Any arm commands (numbers, ticks, any bits) come back exactly.
    #[test]
    fn commands_round_trip(commands in prop::collection::vec((0u64..3, 1u64..30, prop::collection::vec(prop_oneof![Just(0.0f64), any::<f64>()], 7)), 0..200)) {
        let (mut seq, mut tick) = (0u64, 0u64);
        let commands: Vec<ArmCommand> = commands
            .iter()
            .map(|(skip, dt, v)| {
                seq += skip;
                tick += dt;
                let c = ArmCommand { seq, tick, linear: [v[0], v[1], v[2]], angular: [v[3], v[4], v[5]], fingers: v[6] };
                seq += 1;
                c
            })
            .collect();
        let mut file = StreamFile::start(Vec::new(), Stream::Commands).unwrap();
        let (mut enc, mut ops) = (CommandEncoder::default(), Vec::new());
        for c in &commands {
            enc.command(&mut ops, c);
        }
        file.write(&ops).unwrap();
        let bytes = file.end().unwrap();
        let mut dec = CommandDecoder::new(bytes.as_slice()).unwrap();
        let mut back = Vec::new();
        while let Some(item) = dec.next_item().unwrap() {
            match item {
                CommandItem::Command(c) => back.push(c),
                CommandItem::Lost(n) => prop_assert!(false, "lost {}", n),
            }
        }
        let bits = |c: &ArmCommand| (c.seq, c.tick, [c.linear, c.angular].concat().iter().map(|v| v.to_bits()).collect::<Vec<_>>(), c.fingers.to_bits());
        prop_assert_eq!(back.iter().map(bits).collect::<Vec<_>>(), commands.iter().map(bits).collect::<Vec<_>>());
    }
}

/// An arm that executes each command 3 % further than commanded and
/// reports its pose after each, until it falls silent after `silent_after`
/// commands: the core corrects its estimate from the measurements, then
/// faults on their silence.
struct FastMeasuringArm {
    jaco: sipnpuff::arm::sim::SimulatedJaco,
    sends: usize,
    silent_after: usize,
    fresh: bool,
}

impl sipnpuff::arm::Arm for FastMeasuringArm {
    fn describe(&self) -> String {
        "a measuring arm 3 % fast".into()
    }
    fn connect(&mut self) -> Result<(), sipnpuff::arm::ArmError> {
        Ok(())
    }
    fn send(&mut self, command: &ArmCommand) -> Result<(), sipnpuff::arm::ArmError> {
        let mut fast = *command;
        fast.linear = fast.linear.map(|v| v * 1.03);
        self.jaco.command(&fast);
        for _ in 0..10 {
            self.jaco.advance_ms();
        }
        self.sends += 1;
        self.fresh = true;
        Ok(())
    }
    fn feedback(&mut self) -> Option<sipnpuff::arm::ArmState> {
        let fresh = std::mem::take(&mut self.fresh) || self.sends == 0;
        (fresh && self.sends <= self.silent_after).then(|| self.jaco.state())
    }
    fn measures_pose(&self) -> bool {
        true
    }
    fn stop(&mut self) -> Result<(), sipnpuff::arm::ArmError> {
        self.jaco.halt();
        Ok(())
    }
}

/// The measured poses, the corrections they made and the fault their
/// silence caused are in the recording: replay reproduces the run bit for
/// bit.
#[test]
fn a_run_with_a_measuring_arm_replays_bit_for_bit() {
    crate::common::real_time(|| {
        let dir = Scratch::new();
        let config = Config::default();
        let mut recorder = Recorder::create(&dir, &config, RecordOptions::default()).unwrap();
        // The silence (after 12 s of commands) ends the run; the limit
        // outlasts a loaded machine's skipped ticks.
        let settings = LoopSettings::plain(60.0);
        let mut printed = Vec::new();
        let arm = FastMeasuringArm {
            jaco: sipnpuff::arm::sim::SimulatedJaco::new(config.core()),
            sends: 0,
            silent_after: 1200,
            fresh: true,
        };
        let mut print = |e: &sipnpuff::control::event::TimedEvent| {
            printed.push(serde_json::to_string(e).unwrap());
        };
        let sensor = SyntheticSensor::built_in_user(&config);
        let options = RunOptions::new(sensor, Box::new(arm), settings)
            .events(&mut print)
            .recorder(&mut recorder);
        let mut report = run(config.core(), options).unwrap();
        let recording = recorder.finish(&mut report);
        assert!(recording.summary.complete, "{recording:?}");
        assert!(report.arm_measured && report.measured_poses > 1000);
        // The arm's 3 % is corrected a little at every measurement (each far
        // below the 2 mm that is logged as an event).
        assert!(
            report.largest_correction_m > 1e-5,
            "the arm's 3 % showed as corrections: {}",
            report.largest_correction_m
        );
        let fault = printed
            .iter()
            .find(|e| e.contains("\"event\":\"arm_fault\""))
            .expect("the silence was a fault");
        assert!(fault.contains("no measured arm pose"), "{fault}");
        let (code, replayed, stderr) = replay(&dir);
        assert_eq!(code, 0, "{stderr}");
        assert!(
            stderr.contains("identical to the recording, bit for bit"),
            "{stderr}"
        );
        assert_eq!(replayed.lines().collect::<Vec<_>>(), printed);
    });
}
