//! RealtimeSanitizer on the control thread.
//!
//! The control loop marks each tick, from its wake-up to the next deadline
//! sleep, as a real-time region. Under `cargo test` the markers are no-ops
//! and these tests check the loop with the counting allocator. `.ci/run`
//! builds them again with `RTSAN_ENABLE=1` and Debian's RTSan runtime
//! (`RTSAN_LIB_PATH`): then any `malloc`, `free`, lock or blocking call
//! inside a tick aborts the process with a report, so
//! `control_loop_ticks_are_realtime_safe` passing there means no tick of
//! the session did any of them; and `rtsan_catches_an_allocating_tick`
//! shows that a tick that does is caught.

use std::process::Command;

use sipnpuff::config::Config;
use sipnpuff::control::pipeline::Pipeline;
use sipnpuff::control::tick::{TickInput, TickOutput};
use sipnpuff::rt::alloc_counter::CountingAllocator;
use sipnpuff::rt::control_loop::StopReason;
use sipnpuff::rt::simulated::{run_simulated, run_simulated_measured};
use sipnpuff::sensor::Sensor;
use sipnpuff::sim::script::{every_path_session, outputs_session};
use sipnpuff::sim::sensor_model::SignalParams;
use sipnpuff::sim::synthetic_sensor::SyntheticSensor;

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

/// Built with the sanitizer's runtime linked in (`.ci/run`).
const RTSAN_BUILD: bool = option_env!("RTSAN_ENABLE").is_some();

/// The loop itself (the functions `sipnpuff run` starts) on a simulated
/// clock: more than 100 000 ticks of a noisy session with every mode,
/// save and go to point, the finger end and reach limit, faults,
/// recoveries and resets, then the safe stop.
#[test]
fn control_loop_ticks_are_realtime_safe() {
    let config = Config::default();
    let (params, script) = every_path_session(&config);
    let sensor = SyntheticSensor::new(params, script).start().unwrap();
    let run = run_simulated(config.core(), sensor.samples);
    assert!(run.ticks >= 100_000, "{run:?}");
    assert_eq!(run.allocations, 0, "{run:?}");
    assert_eq!(run.stop_reason, StopReason::SensorEnded, "{run:?}");
    assert!(run.last_arm_command.is_zero(), "{run:?}");
    // One command per 10 ticks run.
    assert_eq!(run.arm_commands, run.ticks / 10, "{run:?}");
    // With the session recorder's copy of each (`run --record`).
    assert_eq!(run.recorded_commands, run.arm_commands, "{run:?}");
    assert!(run.events > 100, "{run:?}");
}

/// The same session with an arm that reports its pose every 10 ms: the
/// measured-pose ring, the path matching, the corrections — no tick
/// allocates, locks or blocks, and the arm is trusted to the end (the
/// run ends with the sensor, not with an arm fault).
#[test]
fn control_loop_ticks_with_a_measuring_arm_are_realtime_safe() {
    let config = Config::default();
    let (params, script) = every_path_session(&config);
    let sensor = SyntheticSensor::new(params, script).start().unwrap();
    let run = run_simulated_measured(config.core(), sensor.samples);
    assert!(run.ticks >= 100_000, "{run:?}");
    // A measurement taken in with every command.
    assert!(run.measured_poses + 2 >= run.arm_commands, "{run:?}");
    assert_eq!(run.allocations, 0, "{run:?}");
    assert_eq!(run.stop_reason, StopReason::SensorEnded, "{run:?}");
    assert!(run.last_arm_command.is_zero(), "{run:?}");
    assert_eq!(run.arm_commands, run.ticks / 10, "{run:?}");
}

/// A library that drives the computer and the home
/// (`fixtures/computer-and-home.toml`), every entry used: pointer moves
/// at 100 Hz, a drag, a click, a chord and home events offered to both
/// outputs' rings — no tick allocates, locks or blocks.
#[test]
fn control_loop_ticks_driving_the_computer_and_the_home_are_realtime_safe() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fixtures/computer-and-home.toml"
    );
    let config = Config::from_file(std::path::Path::new(path)).unwrap();
    let script = outputs_session(&config);
    let params = SignalParams::clean(config.core().detector(), 1).with_noise(0.01);
    let sensor = SyntheticSensor::new(params, script).start().unwrap();
    let run = run_simulated(config.core(), sensor.samples);
    assert_eq!(run.allocations, 0, "{run:?}");
    assert_eq!(run.output_drops, 0, "{run:?}");
    // Pointer moves at 100 Hz while a pointer mode is held, and the
    // actions: hundreds of commands.
    assert!(run.output_commands > 200, "{run:?}");
    assert_eq!(run.stop_reason, StopReason::SensorEnded, "{run:?}");
}

/// The gesture front end (10 gestures × 5 templates) over 40 s of head
/// gestures, looking around and too-long holds, each `step` marked as a
/// real-time region: under RTSan any allocation, free or lock in a tick
/// aborts; here the counting allocator sees none.
#[test]
fn gesture_ticks_are_realtime_safe() {
    use sipnpuff::control::gesture::{GestureConfig, GestureEvent, Recognizer};
    use sipnpuff::rt::alloc_counter::thread_allocations;
    use sipnpuff::sim::head::{Head, HeadScript, Move, Noise, example_templates, ten_gestures};

    let config = GestureConfig::default();
    let gestures = ten_gestures();
    let templates = example_templates(&config, &gestures, 5, 0.6, 500);
    let mut recognizer = Recognizer::new(config, templates).unwrap();
    let mut script = HeadScript::new().rest(1000);
    for round in 0..2 {
        for m in gestures {
            let speed = 0.9 + 0.2 * round as f64;
            script = script
                .then(m.varied(m.speed * speed, m.amplitude))
                .rest(600);
        }
        script = script
            .then(Move::new(Head::LookAround))
            .rest(500)
            .then(Move::new(Head::LookDown).held(3000))
            .rest(800);
    }
    let samples = script.samples(10, Noise::TYPICAL, 78);
    let mut next = samples.iter().peekable();
    let (mut recognised, mut rejected) = (0, 0);
    let before = thread_allocations();
    for tick in 0..=script.length_ms() {
        let sample = next.next_if(|s| s.0 == tick).map(|s| &s.1);
        let event = {
            let _realtime = rtsan_standalone::ScopedSanitizeRealtime::default();
            recognizer.step(tick, sample)
        };
        match event {
            Some(GestureEvent::Recognised { .. }) => recognised += 1,
            Some(GestureEvent::Rejected { .. }) => rejected += 1,
            None => {}
        }
    }
    assert_eq!(thread_allocations() - before, 0);
    assert!(recognised >= 10 && rejected >= 2, "{recognised} {rejected}");
}

/// The whole core fed by a head-worn IMU alone: a person's own gesture
/// set, gestures that select modes, the head's tilt that moves the arm
/// and returns to rest, each `Pipeline::step` marked as a real-time
/// region.
#[test]
fn pipeline_ticks_with_gestures_are_realtime_safe() {
    use sipnpuff::control::event::Event;
    use sipnpuff::control::gesture::GestureConfig;
    use sipnpuff::control::imu::ImuInput;
    use sipnpuff::gestures::record::record;
    use sipnpuff::gestures::setup::setup;
    use sipnpuff::rt::alloc_counter::thread_allocations;
    use sipnpuff::sim::head_gesture::GestureName;
    use sipnpuff::sim::imu_session::{Drive, drive_session, protocol_session};
    use sipnpuff::sim::imu_user::ImuUser;

    let user = ImuUser::builtin("typical").unwrap();
    let gestures = [GestureName::Nod, GestureName::DoubleNod];
    let protocol = protocol_session(&user, &gestures, 1);
    let names = ["nod".to_string(), "double_nod".to_string()];
    let set = record(
        &protocol.samples,
        protocol.channels,
        &names,
        GestureConfig::default(),
        None,
    )
    .unwrap()
    .set;
    let config = Config::from_toml_str(
        "[gestures]\nset = \"g.toml\"\n[[sequence]]\nactions = [\"nod\"]\nmode = \"translate_x\"\n[[sequence]]\nactions = [\"double_nod\"]\nmode = \"translate_z\"\n",
    )
    .unwrap();
    let core = config.core().clone().without_breath_sensor();
    let ready = setup(&core, &set).unwrap();
    let core = core.with_gestures(ready);
    let drive = |gesture, pitch_deg| Drive {
        gesture,
        pitch_deg,
        hold_ms: 1500,
    };
    let (session, _) = drive_session(
        &user,
        &[
            drive(GestureName::Nod, 20.0),
            drive(GestureName::DoubleNod, -25.0),
        ],
        2,
    );
    let mut pipeline = Pipeline::new(&core);
    let mut out = TickOutput::default();
    let mut next = session.samples.iter().peekable();
    let last = session.samples.last().unwrap().0;
    let (mut matched, mut moving) = (0, 0);
    let before = thread_allocations();
    for tick in 0..=last {
        let imu = next
            .next_if(|s| s.0 == tick)
            .map_or(ImuInput::Missing, |s| ImuInput::Sample(s.1));
        {
            let _realtime = rtsan_standalone::ScopedSanitizeRealtime::default();
            pipeline.step(&TickInput::imu(tick, imu), &mut out);
        }
        matched += out
            .events
            .iter()
            .filter(|e| matches!(e, Event::Match { .. }))
            .count();
        moving += usize::from(out.motion.linear != [0.0; 3]);
    }
    assert_eq!(thread_allocations() - before, 0);
    assert_eq!(matched, 2);
    assert!(moving > 2000, "{moving} ticks moving");
}

/// A tick that does the core's work and then formats a log line, the kind
/// of slip a code review can miss. Run only as a child of
/// `rtsan_catches_an_allocating_tick`.
#[test]
#[ignore = "run in a child process by rtsan_catches_an_allocating_tick"]
fn allocating_tick() {
    let config = Config::default();
    let mut core = Pipeline::new(config.core());
    let mut out = TickOutput::default();
    let _realtime = rtsan_standalone::ScopedSanitizeRealtime::default();
    core.step(
        &TickInput::volts(0, config.core().detector().neutral_volts),
        &mut out,
    );
    let line = format!("tick {} state {:?}", out.tick, out.command.state);
    std::hint::black_box(line);
}

/// `.ci/run` sets `SIPNPUFF_EXPECT_RTSAN` for its RTSan pass: a build
/// that silently lost the sanitizer would otherwise pass as a plain one.
#[test]
fn the_sanitizer_is_built_in_when_expected() {
    let expected = std::env::var_os("SIPNPUFF_EXPECT_RTSAN").is_some();
    assert_eq!(RTSAN_BUILD, expected, "RTSAN_ENABLE at build time");
}

#[test]
fn rtsan_catches_an_allocating_tick() {
    if !RTSAN_BUILD {
        eprintln!("not built with RealtimeSanitizer (RTSAN_ENABLE): nothing to catch here");
        return;
    }
    let output = Command::new(std::env::current_exe().expect("test binary"))
        .args(["allocating_tick", "--exact", "--ignored", "--nocapture"])
        .output()
        .expect("run the allocating tick");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        !output.status.success(),
        "the allocating tick passed:\n{stderr}"
    );
    assert!(
        stderr.contains("ERROR: RealtimeSanitizer: unsafe-library-call")
            && stderr.contains("`malloc`"),
        "no RealtimeSanitizer report of malloc:\n{stderr}"
    );
}
