//! Real runs of the binary recorded and replayed to the same events and
//! arm commands, bit for bit (skipped ticks, a stall, an unplugged device,
//! a measuring arm and the safe stop included); the size cap, a full disk,
//! a stalled disk and a full queue marked incomplete while the run goes on.

use crate::common::TickByTick;
use crate::common::{Running, fixture};
use crate::recordings::{
    assert_replay_fails, copy_recording, json, replay, shared_machine, sipnpuff, text,
};
use crate::scratch::Scratch;
use serde_json::Value;
use sipnpuff::arm::sim::SimArm;
use sipnpuff::config::Config;
use sipnpuff::control::motion::stream::ArmCommand;
use sipnpuff::control::sample::Sample;
use sipnpuff::control::tick::TickInput;
use sipnpuff::rt::threads::{LoopSettings, RunOptions, run};
use sipnpuff::sim::synthetic_sensor::SyntheticSensor;
use sipnpuff::tools::recording::format::samples::{SampleDecoder, SampleItem};
use sipnpuff::tools::recording::recorder::Recorder;
use sipnpuff::tools::recording::writer::RecordOptions;
use std::path::Path;
use std::time::Duration;

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
        // The stall is a fault: it stopped the arm, and the run fails.
        assert_eq!(status.code(), Some(1), "{status}\n{stderr}");
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
