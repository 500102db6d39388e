//! A person who moves rather than breathes, through the whole core: their
//! own gesture set (recorded by the protocol), a library naming their
//! gestures, the IMU's samples replayed tick by tick. Gestures select
//! modes (alone, in sequences, mixed with breaths), the head's tilt moves
//! the arm in proportion, and a silent or lost IMU is a fault that stops
//! it, as the breath sensor's is.

use sipnpuff::config::Config;
use sipnpuff::control::Tick;
use sipnpuff::control::core_config::CoreConfig;
use sipnpuff::control::detector::FaultReason;
use sipnpuff::control::event::Event;
use sipnpuff::control::gesture::GestureConfig;
use sipnpuff::control::imu::{ImuInput, ImuSample};
use sipnpuff::control::mode::{Mode, ModeState};
use sipnpuff::control::modes::DetectionReason;
use sipnpuff::control::motion::limits::caps;
use sipnpuff::control::pipeline::Pipeline;
use sipnpuff::control::sample::Sample;
use sipnpuff::control::tick::{TickInput, TickOutput};
use sipnpuff::gestures::record::record;
use sipnpuff::gestures::set::GestureSet;
use sipnpuff::gestures::setup::setup;
use sipnpuff::rt::alloc_counter::thread_allocations;
use sipnpuff::sim::head_gesture::GestureName;
use sipnpuff::sim::imu_session::{
    Drive, ImuSession, drive_session, practice_session, protocol_session,
};
use sipnpuff::sim::imu_user::ImuUser;
use sipnpuff::sim::sensor_model::{SignalGenerator, SignalParams, Step};

const GESTURES: [GestureName; 6] = GestureName::DEFAULT;

/// The library of these tests: each gesture alone, a pair, and a
/// gesture followed by a short puff.
const LIBRARY: &str = r#"
[gestures]
set = "my-gestures.toml"

[[sequence]]
actions = ["nod"]
mode = "translate_x"

[[sequence]]
actions = ["double_nod"]
mode = "translate_z"

[[sequence]]
actions = ["shake"]
mode = "translate_y"

[[sequence]]
actions = ["tilt_left"]
mode = "fingers"

[[sequence]]
actions = ["tilt_right", "nod"]
mode = "rotate_z"

[[sequence]]
actions = ["wobble"]
event = "lights_toggle"
"#;

fn user(name: &str) -> ImuUser {
    ImuUser::builtin(name).unwrap()
}

/// `user`'s own set, recorded by the protocol.
fn own_set(user: &ImuUser) -> GestureSet {
    let protocol = protocol_session(user, &GESTURES, 1);
    let names: Vec<String> = GESTURES.iter().map(|g| g.name().to_string()).collect();
    record(
        &protocol.samples,
        protocol.channels,
        &names,
        GestureConfig::default(),
        None,
    )
    .unwrap()
    .set
}

/// The core for `library` with `set` loaded, `breath` said whether a
/// breath sensor feeds it too.
fn core(library: &str, set: &GestureSet, breath: bool) -> CoreConfig {
    let config = Config::from_toml_str(library).unwrap();
    let core = config.core().clone();
    let core = if breath {
        core
    } else {
        core.without_breath_sensor()
    };
    let ready = setup(&core, set).unwrap();
    core.with_gestures(ready)
}

/// Every tick from the first sample to the last (and `tail` ticks more,
/// still sampled, the last sample repeated with its noise frozen out),
/// the IMU's samples on their ticks.
fn inputs(samples: &[(Tick, ImuSample)]) -> Vec<TickInput> {
    let (first, last) = (samples[0].0, samples[samples.len() - 1].0);
    let mut at = samples.iter().peekable();
    (first..=last)
        .map(|tick| {
            let mut imu = ImuInput::Missing;
            while let Some((_, s)) = at.next_if(|(t, _)| *t <= tick) {
                imu = ImuInput::Sample(*s);
            }
            TickInput::imu(tick, imu)
        })
        .collect()
}

/// Each tick's output.
fn run(core: &CoreConfig, inputs: &[TickInput]) -> Vec<TickOutput> {
    let mut pipeline = Pipeline::new(core);
    let mut out = TickOutput::default();
    inputs
        .iter()
        .map(|input| {
            pipeline.step(input, &mut out);
            out
        })
        .collect()
}

fn events(outputs: &[TickOutput]) -> Vec<(Tick, Event)> {
    outputs
        .iter()
        .flat_map(|o| o.events.iter().map(move |e| (o.tick, *e)))
        .collect()
}

fn matches(outputs: &[TickOutput]) -> Vec<(Tick, String)> {
    events(outputs)
        .into_iter()
        .filter_map(|(t, e)| match e {
            Event::Match { target, .. } => Some((t, target.label())),
            _ => None,
        })
        .collect()
}

/// What the library's one-gesture entries select, by gesture.
fn selects(gesture: GestureName) -> Option<&'static str> {
    match gesture {
        GestureName::Nod => Some("translate_x"),
        GestureName::DoubleNod => Some("translate_z"),
        GestureName::Shake => Some("translate_y"),
        GestureName::TiltLeft => Some("fingers"),
        GestureName::Wobble => Some("Home: lights_toggle"),
        _ => None,
    }
}

#[test]
fn gestures_select_modes_and_fire_events_and_nothing_else_does() {
    for name in ["typical", "slow_small", "wheelchair"] {
        let person = user(name);
        let core = core(LIBRARY, &own_set(&person), false);
        let session: ImuSession = practice_session(&person, &GESTURES, 5, 7);
        let outputs = run(&core, &inputs(&session.samples));
        let found = matches(&outputs);
        let mut right = 0;
        let mut made = 0;
        for (i, truth) in session.truth.iter().enumerate() {
            let next = session.truth.get(i + 1).map_or(Tick::MAX, |t| t.start);
            let here: Vec<&(Tick, String)> = found
                .iter()
                .filter(|(t, _)| *t >= truth.end && *t < next)
                .collect();
            match selects(truth.name) {
                Some(label) => {
                    made += 1;
                    // Never a wrong selection; a miss is a rejection.
                    assert!(
                        here.iter().all(|(_, l)| l == label),
                        "{name}: {:?} at {} selected {here:?}",
                        truth.name,
                        truth.start
                    );
                    right += usize::from(!here.is_empty());
                }
                // tilt_right alone is the start of a pair: it selects nothing.
                None => assert!(here.is_empty(), "{name}: {here:?}"),
            }
        }
        for &(from, to) in &session.ordinary {
            assert!(
                found.iter().all(|(t, _)| *t < from || *t > to + 1500),
                "{name}: ordinary movement selected something: {found:?}"
            );
        }
        assert!(
            right * 10 >= made * 8,
            "{name}: {right} of {made} gestures selected"
        );
        let arm_moved = outputs.iter().any(|o| o.motion.linear != [0.0; 3]);
        assert!(!arm_moved, "{name}: the head never tilted, nothing moves");
    }
}

/// The tilt `degrees` past a 12° dead zone, on a 30° full scale: the
/// fraction of full speed above the 25 % floor.
fn expected_speed(degrees: f64) -> f64 {
    let fraction = ((degrees.abs() - 12.0) / (30.0 - 12.0)).clamp(0.0, 1.0);
    caps::LINEAR_SPEED_MPS * (0.25 + 0.75 * fraction)
}

#[test]
fn the_heads_tilt_moves_the_arm_along_the_selected_mode_in_proportion() {
    let person = user("typical");
    let drives = [
        Drive {
            gesture: GestureName::Nod,
            pitch_deg: 21.0,
            hold_ms: 2000,
        },
        Drive {
            gesture: GestureName::DoubleNod,
            pitch_deg: -27.0,
            hold_ms: 1500,
        },
        // Within the dead zone: selected, and nothing moves.
        Drive {
            gesture: GestureName::Nod,
            pitch_deg: 8.0,
            hold_ms: 1500,
        },
    ];
    let (session, holds) = drive_session(&person, &drives, 3);
    let core = core(LIBRARY, &own_set(&person), false);
    let outputs = run(&core, &inputs(&session.samples));
    let first = outputs[0].tick;
    let at = |t: Tick| &outputs[(t - first) as usize];
    let axis = [0, 2, 0];
    for ((drive, &(from, to)), axis) in drives.iter().zip(&holds).zip(axis) {
        // Half a second into the hold: the arm has reached its speed.
        let mid = at(from + 500);
        let mode = if drive.gesture == GestureName::Nod {
            Mode::TranslateX
        } else {
            Mode::TranslateZ
        };
        assert_eq!(mid.command.state, ModeState::Command(mode), "{drive:?}");
        let speed = at(to - 100).motion.linear;
        if drive.pitch_deg.abs() < 12.0 {
            assert_eq!(speed, [0.0; 3], "{drive:?}");
            continue;
        }
        let want = expected_speed(drive.pitch_deg) * drive.pitch_deg.signum();
        let got = speed[axis];
        assert!(
            (got - want).abs() < 0.05 * want.abs(),
            "{drive:?}: {got} m/s, {want} m/s expected"
        );
        for (k, v) in speed.iter().enumerate() {
            if k != axis {
                assert!(v.abs() < 1e-9, "{drive:?}: off-axis {speed:?}");
            }
        }
        // Back at rest: the arm stops, and inactivity returns to
        // selection.
        assert_eq!(at(to + 1500).motion.linear, [0.0; 3], "{drive:?}");
    }
    let back: Vec<DetectionReason> = events(&outputs)
        .into_iter()
        .filter_map(|(_, e)| match e {
            Event::Detection { reason } => Some(reason),
            _ => None,
        })
        .collect();
    assert_eq!(back, [DetectionReason::Inactivity; 3]);
}

#[test]
fn a_gesture_and_a_breath_make_one_sequence() {
    let person = user("typical");
    let library = r#"
[gestures]
set = "my-gestures.toml"

[[sequence]]
actions = ["nod"]
mode = "translate_x"

[[sequence]]
actions = ["nod", -1]
mode = "translate_y"

[[sequence]]
actions = [-1, -1]
mode = "fingers"
"#;
    let set = own_set(&person);
    let session = practice_session(&person, &[GestureName::Nod], 2, 4);
    let imu = inputs(&session.samples);
    // Where each nod is read, with the breath sensor at rest.
    let core = core(library, &set, true);
    let rest = core.detector().neutral_volts;
    let at_rest: Vec<TickInput> = imu
        .iter()
        .map(|i| TickInput {
            sample: Sample::Volts(rest),
            ..*i
        })
        .collect();
    let read: Vec<Tick> = events(&run(&core, &at_rest))
        .into_iter()
        .filter_map(|(t, e)| matches!(e, Event::Gesture { .. }).then_some(t))
        .collect();
    assert_eq!(read.len(), 2, "both nods read");
    // A short puff 300 ms after the first nod is read; none after the
    // second.
    let first = imu[0].tick;
    let puff_at = (read[0] + 300 - first) as u32;
    let script = [
        Step::Rest { ms: puff_at },
        Step::Breath {
            breath: sipnpuff::control::action::Breath::Puff,
            ms: 150,
        },
        Step::Rest {
            ms: imu.len() as u32,
        },
    ];
    let volts = SignalGenerator::new(SignalParams::clean(core.detector(), 9), &script);
    let both: Vec<TickInput> = imu
        .iter()
        .zip(volts)
        .map(|(i, v)| TickInput {
            sample: Sample::Volts(v),
            ..*i
        })
        .collect();
    let found = matches(&run(&core, &both));
    assert_eq!(found.len(), 2, "{found:?}");
    assert_eq!(found[0].1, "translate_y", "nod then a short puff");
    assert!(found[0].0 > read[0] + 300, "after the puff");
    assert_eq!(found[1].1, "translate_x", "a nod alone, at the timeout");
    assert_eq!(
        found[1].0,
        read[1] + 1000,
        "the sequence timeout after the nod"
    );
}

#[test]
fn a_silent_or_lost_imu_stops_the_arm_and_returns_to_selection() {
    let person = user("typical");
    let drive = Drive {
        gesture: GestureName::Nod,
        pitch_deg: 24.0,
        hold_ms: 3000,
    };
    let (session, holds) = drive_session(&person, &[drive], 5);
    let core = core(LIBRARY, &own_set(&person), false);
    let clean = inputs(&session.samples);
    let (from, _) = holds[0];
    for (lost, reason) in [
        (false, FaultReason::ImuStale { ms: 100 }),
        (true, FaultReason::ImuDisconnected),
    ] {
        // One second into the hold the IMU falls silent (or is
        // unplugged) for 200 ms.
        let cut = from + 1000;
        let faulty: Vec<TickInput> = clean
            .iter()
            .map(|i| {
                if (cut..cut + 200).contains(&i.tick) {
                    let imu = if lost {
                        ImuInput::Lost
                    } else {
                        ImuInput::Missing
                    };
                    TickInput { imu, ..*i }
                } else {
                    *i
                }
            })
            .collect();
        let outputs = run(&core, &faulty);
        let first = outputs[0].tick;
        let at = |t: Tick| &outputs[(t - first) as usize];
        assert!(at(cut - 1).motion.linear[0] > 0.1, "moving before");
        let said: Vec<(Tick, Event)> = events(&outputs)
            .into_iter()
            .filter(|(t, _)| *t >= cut && *t < cut + 1000)
            .filter(|(_, e)| !matches!(e, Event::Motion(_)))
            .collect();
        // Silent: the last sample came up to 10 ms before the cut.
        let fault_at = said[0].0;
        assert!(
            fault_at <= cut + 100,
            "{reason:?}: the fault at {fault_at}, cut at {cut}"
        );
        assert!(
            matches!(said[0].1, Event::Fault { reason: r } if std::mem::discriminant(&r) == std::mem::discriminant(&reason)),
            "{said:?}"
        );
        assert_eq!(
            said[1].1,
            Event::Detection {
                reason: DetectionReason::Fault
            }
        );
        assert!(at(fault_at).faulted);
        assert_eq!(at(fault_at).command.state, ModeState::Detection);
        // Braked through the usual limits, to rest within 0.2 s.
        // Braked through the usual limits: never faster, at rest within
        // 0.4 s.
        let speeds: Vec<f64> = (fault_at..fault_at + 400)
            .map(|t| at(t).motion.linear[0])
            .collect();
        assert!(speeds.windows(2).all(|w| w[1] <= w[0]), "{speeds:?}");
        assert_eq!(speeds[speeds.len() - 1], 0.0);
        // The samples come back: healthy again 300 ms after the first,
        // still in selection though the head is still tilted.
        let back = clean
            .iter()
            .find(|i| i.tick >= cut + 200 && matches!(i.imu, ImuInput::Sample(_)))
            .unwrap()
            .tick;
        assert_eq!(said[2].0, back + 300, "{said:?}");
        assert_eq!(said[2].1, Event::Recovered);
        assert!(at(cut + 900).motion.linear == [0.0; 3]);
    }
}

#[test]
fn the_core_with_gestures_allocates_nothing() {
    let person = user("typical");
    let (session, _) = drive_session(
        &person,
        &[Drive {
            gesture: GestureName::Nod,
            pitch_deg: 20.0,
            hold_ms: 1000,
        }],
        6,
    );
    let core = core(LIBRARY, &own_set(&person), false);
    let inputs = inputs(&session.samples);
    let mut pipeline = Pipeline::new(&core);
    let mut out = TickOutput::default();
    let (mut said, mut moved) = (0, 0);
    let before = thread_allocations();
    for input in &inputs {
        pipeline.step(input, &mut out);
        said += out.events.len();
        moved += usize::from(out.motion.linear != [0.0; 3]);
    }
    assert_eq!(thread_allocations() - before, 0, "{} ticks", inputs.len());
    assert_eq!(said, 3, "a gesture, its match, back to selection");
    assert!(moved > 1000, "the head moved the arm for {moved} ticks");
}

#[test]
fn a_library_naming_gestures_is_checked_against_the_set_and_the_config() {
    let person = user("typical");
    let set = own_set(&person);
    // Not in the set: named by its entry.
    let config = Config::from_toml_str(
        "[gestures]\nset = \"g.toml\"\n[[sequence]]\nactions = [\"nod\"]\nmode = \"fingers\"\n[[sequence]]\nactions = [\"blink\", -1]\nmode = \"rotate_x\"\n",
    )
    .unwrap();
    assert_eq!(
        setup(config.core(), &set).unwrap_err(),
        [
            "sequence #2.actions: `blink` not in the gesture set (it has nod, double_nod, shake, tilt_left, tilt_right, wobble)"
        ]
    );
    // Gestures without a set, a name that cannot be one, a bad dead zone
    // and gestures with the scanning interface: all said at once, by key
    // and line.
    let errors = Config::from_toml_str(
        "[[sequence]]\nactions = [\"nod\"]\nmode = \"fingers\"\n[[sequence]]\nactions = [\"Nod\", 1]\nmode = \"rotate_x\"\n[gestures]\ndead_zone_deg = 60\n",
    )
    .unwrap_err()
    .to_string();
    for said in [
        "line 2, column 1: sequence #1.actions: [\"nod\"] names gestures, but no gesture set is given",
        "line 5, column 1: sequence #2.actions: \"Nod\" not a gesture name",
        "line 8, column 1: gestures.dead_zone_deg: 60 is not 2–45 degrees",
    ] {
        assert!(errors.contains(said), "{said}\nin\n{errors}");
    }
    assert!(errors.starts_with("3 problems"), "{errors}");
    let errors =
        Config::from_toml_str("[interface]\nkind = \"bsp\"\n[gestures]\nset = \"g.toml\"\n")
            .unwrap_err()
            .to_string();
    assert!(
        errors.contains(
            "gestures.set: gestures are read as sequences: they need `[interface] kind = \"asp\"`"
        ),
        "{errors}"
    );
}

/// The fixture `fixtures/gesture-user/`: the simulated `typical` IMU
/// user's set and a practice session of each gesture once (made as
/// docs/gestures.md says), replayed as a newcomer would.
const FIXTURE: [&str; 5] = [
    "replay",
    "fixtures/gesture-user/practice.csv",
    "--config",
    "fixtures/gesture-user/config.toml",
    "--events",
];

#[test]
fn the_gesture_users_replay_is_its_golden_file_and_says_what_was_made() {
    let dir = crate::scratch::Scratch::new();
    let events = dir.join("events.jsonl");
    let mut args = FIXTURE.to_vec();
    args.push(events.to_str().unwrap());
    let out = crate::common::sipnpuff_output(&args);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    crate::common::assert_exit(out.status, &stderr, 0, "replay");
    let written = std::fs::read_to_string(&events).unwrap();
    let golden = std::fs::read_to_string("fixtures/gesture-user/practice.events.jsonl").unwrap();
    assert_eq!(written, golden, "the replay changed its events");
    // And what the golden says: each gesture made once, each read as
    // itself and selecting its entry; tilt_right alone, the start of a
    // pair, waits for the timeout and resets.
    let lines: Vec<serde_json::Value> = golden
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let read: Vec<&str> = lines
        .iter()
        .filter(|e| e["event"] == "gesture")
        .map(|e| e["name"].as_str().unwrap())
        .collect();
    let mut sorted = read.clone();
    sorted.sort_unstable();
    assert_eq!(
        sorted,
        [
            "double_nod",
            "nod",
            "shake",
            "tilt_left",
            "tilt_right",
            "wobble"
        ]
    );
    for pair in lines.windows(2) {
        if pair[0]["event"] == "gesture" {
            let name = pair[0]["name"].as_str().unwrap();
            let then = &pair[1];
            let (read_at, then_at) = (pair[0]["tick"].as_u64(), then["tick"].as_u64());
            if name == "tilt_right" {
                // The sequence timeout (1000 ms) after it was read.
                assert_eq!(then_at, read_at.map(|t| t + 1000), "{then}");
                assert_eq!(then["event"], "reset", "{then}");
                assert_eq!(then["reason"], "timeout", "{then}");
            } else {
                assert_eq!(then_at, read_at, "{then}");
                assert_eq!(then["event"], "match", "{then}");
                assert_eq!(then["sequence"], serde_json::json!([name]), "{then}");
            }
        }
    }
    assert!(stderr.contains("replayed 35191 samples"), "{stderr}");
}

#[test]
fn replay_with_a_gesture_set_alone_prints_each_gesture_with_its_movement() {
    let out = crate::common::sipnpuff_output(&[
        "replay",
        "fixtures/gesture-user/practice.csv",
        "--gestures",
        "fixtures/gesture-user/gestures.toml",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    crate::common::assert_exit(out.status, &stderr, 0, "replay --gestures");
    // The same gestures, at the same ticks, as the golden file read with
    // the person's whole configuration.
    let golden = std::fs::read_to_string("fixtures/gesture-user/practice.events.jsonl").unwrap();
    let gestures = |text: &str| -> Vec<String> {
        text.lines()
            .filter(|l| l.contains(r#""event":"gesture""#))
            .map(str::to_string)
            .collect()
    };
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(gestures(&stdout), gestures(&golden));
    assert_eq!(gestures(&stdout).len(), 6);
    // A breath recording is not read with a gesture set.
    let stderr = crate::common::refused(&[
        "replay",
        "fixtures/demo.csv",
        "--gestures",
        "fixtures/gesture-user/gestures.toml",
    ]);
    assert!(
        stderr.contains("--gestures is for an IMU recording"),
        "{stderr}"
    );
}

#[test]
fn an_imu_recording_without_a_gesture_set_is_refused_with_what_to_give() {
    let stderr = crate::common::refused(&["replay", "fixtures/gesture-user/practice.csv"]);
    assert!(
        stderr.contains(
            "an IMU needs the person's gestures: give a --config with [gestures] set = \"FILE\""
        ),
        "{stderr}"
    );
}

#[test]
fn the_control_loop_plays_an_imu_recording_and_allocates_nothing() {
    use sipnpuff::rt::control_loop::StopReason;
    use sipnpuff::rt::simulated::run_simulated;
    use sipnpuff::sensor::Sensor;
    use sipnpuff::sensor::imu_playback::ImuPlayback;

    let person = user("typical");
    let (session, _) = drive_session(
        &person,
        &[Drive {
            gesture: GestureName::Nod,
            pitch_deg: 21.0,
            hold_ms: 2000,
        }],
        8,
    );
    let core = core(LIBRARY, &own_set(&person), false);
    let length = session.samples.len();
    let playback = ImuPlayback::prepared("drive".into(), session.samples)
        .start()
        .unwrap();
    let run = run_simulated(&core, playback.samples);
    assert_eq!(run.allocations, 0, "{run:?}");
    assert_eq!(run.stop_reason, StopReason::SensorEnded, "{run:?}");
    assert!(run.ticks >= (length as u64 - 1) * 10, "{run:?}");
    // A gesture, its match, back to selection; the arm moved and stopped.
    assert_eq!(run.events, 3, "{run:?}");
    assert_eq!(run.arm_commands, run.ticks / 10, "{run:?}");
    assert!(run.last_arm_command.is_zero(), "{run:?}");
    assert_eq!(run.drops.samples, 0, "{run:?}");
}

#[test]
fn a_run_with_gestures_needs_an_imu_and_an_imu_needs_gestures() {
    // Gestures configured, a breath sensor given.
    let stderr = crate::common::refused(&[
        "run",
        "--seconds",
        "1",
        "--config",
        "fixtures/gesture-user/config.toml",
    ]);
    assert!(
        stderr.contains("gestures need an IMU: give --sensor evdev:name=NAME (an input device with the accelerometer property"),
        "{stderr}"
    );
    assert!(
        stderr.contains(
            "to read breaths too, give the breath sensor with --sensor and the IMU with --imu"
        ),
        "{stderr}"
    );
    // An IMU recording without gestures.
    let stderr =
        crate::common::refused(&["run", "--sensor", "csv:fixtures/gesture-user/practice.csv"]);
    assert!(
        stderr.contains("an IMU needs the person's gestures"),
        "{stderr}"
    );
}

#[test]
fn an_imu_beside_a_breath_sensor_is_refused_when_either_is_not_what_it_should_be() {
    let practice = "csv:fixtures/gesture-user/practice.csv";
    let person = "fixtures/gesture-user/config.toml";
    for (args, says) in [
        (
            vec!["--imu", practice],
            "--imu csv:fixtures/gesture-user/practice.csv: an IMU needs the person's gestures",
        ),
        (
            vec!["--sensor", practice, "--imu", practice, "--config", person],
            "--sensor csv:fixtures/gesture-user/practice.csv: with --imu, --sensor is the breath sensor",
        ),
        (
            vec!["--imu", "csv:fixtures/demo.csv", "--config", person],
            "--imu csv:fixtures/demo.csv: not an IMU recording (its header must be `tick` and IMU channels, e.g. `tick,ax,ay,az,gx,gy,gz`)",
        ),
        (
            vec!["--imu", "synthetic", "--config", person],
            "--imu synthetic: not an IMU: give evdev:name=NAME",
        ),
    ] {
        let mut run = vec!["run", "--seconds", "1"];
        run.extend(args);
        let stderr = crate::common::refused(&run);
        assert!(stderr.contains(says), "{run:?}: {stderr}");
    }
}

#[test]
fn an_imu_without_a_channel_the_set_was_recorded_with_is_refused() {
    // The practice session with its accelerations alone: the set was
    // recorded with all six channels.
    let dir = crate::scratch::Scratch::new();
    let accel = dir.join("accel.csv");
    let text: String = std::fs::read_to_string("fixtures/gesture-user/practice.csv")
        .unwrap()
        .lines()
        .map(|line| line.split(',').take(4).collect::<Vec<_>>().join(",") + "\n")
        .collect();
    std::fs::write(&accel, text).unwrap();
    let path = accel.to_str().unwrap();
    let said = "gives ax,ay,az but the gesture set fixtures/gesture-user/gestures.toml was recorded with ax,ay,az,gx,gy,gz: a set from another sensor's channels";
    let stderr = crate::common::refused(&[
        "replay",
        path,
        "--config",
        "fixtures/gesture-user/config.toml",
    ]);
    assert!(stderr.contains(&format!("{path}: {said}")), "{stderr}");
    let sensor = format!("csv:{path}");
    let stderr = crate::common::refused(&[
        "run",
        "--sensor",
        &sensor,
        "--config",
        "fixtures/gesture-user/config.toml",
    ]);
    assert!(stderr.contains(&format!("{sensor}: {said}")), "{stderr}");
}

/// A head held at `pitch` and `roll` (degrees), turning at `rates`
/// (rad/s): what its IMU reads (x forward, y left, z up).
fn reading(pitch: f64, roll: f64, rates: [f64; 3]) -> ImuSample {
    let g = sipnpuff::control::gesture::features::GRAVITY;
    let (sp, cp) = pitch.to_radians().sin_cos();
    let (sr, cr) = roll.to_radians().sin_cos();
    ImuSample {
        values: [
            -g * sp,
            g * sr * cp,
            g * cp * cr,
            rates[0],
            rates[1],
            rates[2],
        ],
    }
}

/// The fixture person's recording up to a random point (mostly just after
/// a mode is selected), then runs of any head pose, rate, silence, loss
/// and non-finite value, sampled every 1–20 ms.
fn imu_inputs() -> impl proptest::strategy::Strategy<Value = Vec<ImuInput>> {
    use proptest::prelude::*;
    let pose = prop_oneof![
        6 => (-90.0f64..90.0, -90.0f64..90.0, prop::array::uniform3(-4.0f64..4.0))
            .prop_map(|(p, r, w)| ImuInput::Sample(reading(p, r, w))),
        1 => Just(ImuInput::Missing),
        1 => Just(ImuInput::Lost),
        1 => Just(ImuInput::Sample(ImuSample { values: [f64::NAN, 0.0, 9.8, 0.0, f64::INFINITY, 0.0] })),
    ];
    // Mostly just after a mode is selected (the fixture's matches at
    // 4.2, 15.2, 20.7 and 26.1 s), so the head then moves the arm.
    let cut = prop_oneof![
        1 => 0usize..35_000,
        3 => (prop::sample::select(vec![4200usize, 15_180, 20_700, 26_100]), 0usize..1500)
            .prop_map(|(selected, after)| selected + after),
    ];
    (
        cut,
        prop::collection::vec((pose, 1usize..2000, 1usize..20), 0..40),
    )
        .prop_map(|(cut, runs)| {
            let recorded = sipnpuff::tools::imu_csv::read_imu_csv(std::path::Path::new(
                "fixtures/gesture-user/practice.csv",
            ))
            .unwrap();
            let mut inputs: Vec<ImuInput> = inputs(&recorded.samples)
                .into_iter()
                .take(cut)
                .map(|i| i.imu)
                .collect();
            for (input, ticks, every) in runs {
                for k in 0..ticks {
                    let sampled = k % every == 0;
                    inputs.push(match input {
                        ImuInput::Sample(_) if !sampled => ImuInput::Missing,
                        other => other,
                    });
                }
            }
            inputs
        })
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

    /// Whatever the head and its IMU do, under any valid head settings:
    /// the motion keeps every limit at every tick (the safety monitor),
    /// nothing moves outside a command mode or during a fault, the speed
    /// fraction stays in 0–1, every match is a library entry, no event is
    /// dropped and nothing panics.
    #[test]
    fn any_head_movement_is_safe(
        imu in imu_inputs(),
        tilt in proptest::sample::select(vec!["pitch", "roll", "off"]),
        dead_zone in 2.0f64..45.0,
        span in 1.0f64..35.0,
    ) {
        use proptest::prelude::*;
        let set_line = "set = \"fixtures/gesture-user/gestures.toml\"";
        let text = std::fs::read_to_string("fixtures/gesture-user/config.toml")
            .unwrap()
            .replacen(
                set_line,
                &format!(
                    "{set_line}\ntilt = \"{tilt}\"\ndead_zone_deg = {dead_zone}\nfull_scale_deg = {}",
                    dead_zone + span
                ),
                1,
            );
        let config = Config::from_toml_str(&text).unwrap();
        let set = GestureSet::from_toml(
            &std::fs::read_to_string("fixtures/gesture-user/gestures.toml").unwrap(),
        )
        .unwrap();
        let core = config.core().clone().without_breath_sensor();
        let core = core.clone().with_gestures(setup(&core, &set).unwrap());
        let mut pipeline = Pipeline::new(&core);
        let mut monitor = sipnpuff::tools::safety::SafetyMonitor::new(&core);
        let mut out = TickOutput::default();
        for (t, imu) in imu.iter().enumerate() {
            pipeline.step(&TickInput::imu(t as Tick, *imu), &mut out);
            prop_assert_eq!(out.dropped_events, 0);
            if let Err(v) = monitor.check(&out) {
                return Err(TestCaseError::fail(format!("tick {t}: {v:?}")));
            }
            if let Some(f) = out.command.speed_fraction {
                prop_assert!((0.0..=1.0).contains(&f), "{}", f);
            }
            if out.command.state == ModeState::Detection || out.faulted {
                prop_assert_eq!(out.command.direction, sipnpuff::control::mode::Direction::Still);
            }
            for event in out.events.iter() {
                if let Event::Match { sequence, target } = event {
                    prop_assert!(
                        core.sequences().iter().any(|e| e.actions == *sequence && e.target == *target),
                        "{:?} {:?}", sequence, target
                    );
                }
            }
        }
    }
}
