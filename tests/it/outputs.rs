//! The outputs beyond the arm, up to their seam: what the core asks of
//! the computer and the home for a library that types, clicks, drags,
//! moves the pointer and sends home events (`fixtures/computer-and-home.toml`),
//! and how the runtime hands it to each output — only what it serves, in
//! order, dropped and counted when an output is too slow, and let go of at
//! every way out. The backends themselves are proven against their real
//! other sides: uinput through the kernel in the VM harness, MQTT against
//! mosquitto (`output_mqtt.rs`).

use std::sync::{Arc, Mutex};
use std::time::Duration;

use sipnpuff::config::Config;
use sipnpuff::control::Tick;
use sipnpuff::control::action::ActionSeq;
use sipnpuff::control::output_command::{OutputCommand, PointerMove};
use sipnpuff::control::pipeline::Pipeline;
use sipnpuff::control::sample::Sample;
use sipnpuff::control::target::{Chord, Click, HomeEvent};
use sipnpuff::control::tick::TickInput;
use sipnpuff::output::{Output, OutputReport};
use sipnpuff::rt::output_thread::{OUTPUT_RING, Serves};
use sipnpuff::rt::simulated::{SIMULATED_OUTPUT_RING, run_simulated_with_outputs};
use sipnpuff::sensor::Sensor;
use sipnpuff::sim::script::outputs_session;
use sipnpuff::sim::sensor_model::{SignalGenerator, SignalParams};
use sipnpuff::sim::synthetic_sensor::SyntheticSensor;

use crate::common::{TickByTick, fixture};

/// The library of the arm, the computer and the home.
fn library() -> Config {
    Config::from_file(&fixture("computer-and-home.toml")).unwrap()
}

/// Every entry of the library used in turn, as volts.
fn session(config: &Config) -> Vec<f64> {
    let params = SignalParams::clean(config.core().detector(), 7);
    SignalGenerator::new(params, &outputs_session(config)).collect()
}

/// The core's output commands over `samples`, with their ticks.
fn commands(config: &Config, samples: &[f64]) -> Vec<(Tick, OutputCommand)> {
    let mut core = Pipeline::new(config.core());
    let mut all = Vec::new();
    for (t, &v) in samples.iter().enumerate() {
        let out = core.tick(t as Tick, v);
        all.extend(out.outputs.iter().map(|c| (t as Tick, *c)));
    }
    all
}

fn seq(codes: &[i8]) -> ActionSeq {
    let actions: Vec<_> = codes
        .iter()
        .map(|&c| sipnpuff::control::action::Action::from_code(c.into()).unwrap())
        .collect();
    ActionSeq::from_slice(&actions).unwrap()
}

#[test]
fn each_entry_asks_the_outputs_for_what_it_does() {
    let config = library();
    let all = commands(&config, &session(&config));
    let actions: Vec<OutputCommand> = all
        .iter()
        .map(|&(_, c)| c)
        .filter(|c| !matches!(c, OutputCommand::Pointer(_)))
        .map(|c| match c {
            // The tick is checked below.
            OutputCommand::Home {
                event, sequence, ..
            } => OutputCommand::Home {
                event,
                tick: 0,
                sequence,
            },
            other => other,
        })
        .collect();
    let home = |name: &str, codes: &[i8]| OutputCommand::Home {
        event: HomeEvent::new(name).unwrap(),
        tick: 0,
        sequence: seq(codes).into(),
    };
    assert_eq!(
        actions,
        [
            // The drag begins; the click's selection lets it go first.
            OutputCommand::Button { down: true },
            OutputCommand::Button { down: false },
            OutputCommand::Click(Click::Left),
            OutputCommand::Key(Chord::parse("ctrl+alt+t").unwrap()),
            home("lights_toggle", &[-2, -2]),
            home("call_for_help", &[2, 2]),
            // A drag around a pointer move: the button stays down through
            // the pointer mode and goes up with the second drag.
            OutputCommand::Button { down: true },
            OutputCommand::Button { down: false },
        ]
    );
    // A home event carries the tick of its match.
    let mut core = Pipeline::new(config.core());
    let samples = session(&config);
    let mut matched = Vec::new();
    for (t, &v) in samples.iter().enumerate() {
        for e in core.tick(t as Tick, v).events.iter() {
            if let sipnpuff::control::event::Event::Match { target, .. } = e
                && matches!(target, sipnpuff::control::target::Target::Home(_))
            {
                matched.push(t as Tick);
            }
        }
    }
    let fired: Vec<Tick> = all
        .iter()
        .filter_map(|(t, c)| match c {
            OutputCommand::Home { tick, .. } => {
                assert_eq!(tick, t);
                Some(*tick)
            }
            _ => None,
        })
        .collect();
    assert_eq!(fired, matched);
}

#[test]
fn the_pointer_moves_only_in_its_modes_at_100_hz_and_each_way() {
    let config = library();
    let all = commands(&config, &session(&config));
    let moves: Vec<(Tick, PointerMove)> = all
        .iter()
        .filter_map(|&(t, c)| match c {
            OutputCommand::Pointer(m) => Some((t, m)),
            _ => None,
        })
        .collect();
    assert!(moves.len() > 100, "{}", moves.len());
    assert!(moves.iter().all(|(t, m)| t % 10 == 0 && !m.is_zero()));
    // Each move is one axis at a time: the modes are held one by one.
    assert!(
        moves
            .iter()
            .all(|(_, m)| [m.dx, m.dy, m.wheel].iter().filter(|&&d| d != 0).count() == 1)
    );
    let sum = |f: fn(&PointerMove) -> i32, positive: bool| -> i32 {
        moves
            .iter()
            .map(|(_, m)| f(m))
            .filter(|&d| (d > 0) == positive && d != 0)
            .sum()
    };
    // Right with the puff and left with the sip (pointer_x, then the drag's
    // move); up (negative y) with the puff and down with the sip; the
    // wheel up and down.
    for (axis, f) in [
        ("x", (|m: &PointerMove| m.dx) as fn(&PointerMove) -> i32),
        ("y", |m: &PointerMove| m.dy),
        ("wheel", |m: &PointerMove| m.wheel),
    ] {
        assert!(sum(f, true) > 0 && sum(f, false) < 0, "{axis}");
    }
    // A 1.2 s puff outruns a 0.6 s sip, in counts.
    assert!(sum(|m| m.dx, true) > 2 * -sum(|m| m.dx, false));
}

#[test]
fn a_fault_or_a_stop_lets_go_of_a_held_drag_once() {
    let config = library();
    let samples = session(&config);
    let all = commands(&config, &samples);
    let drag_at = all
        .iter()
        .find(|(_, c)| *c == OutputCommand::Button { down: true })
        .unwrap()
        .0;
    // A sensor lost 100 ms after the drag began.
    let mut core = Pipeline::new(config.core());
    let mut released = Vec::new();
    for (t, &v) in samples.iter().enumerate().take(drag_at as usize + 3000) {
        let t = t as Tick;
        let sample = if (drag_at + 100..drag_at + 600).contains(&t) {
            Sample::Lost
        } else {
            Sample::Volts(v)
        };
        let out = core.tick_with(t, sample);
        released.extend(
            out.outputs
                .iter()
                .filter(|c| **c == OutputCommand::ReleaseAll)
                .map(|_| t),
        );
    }
    assert_eq!(released.len(), 1, "{released:?}");
    assert!(released[0] >= drag_at + 100 && released[0] < drag_at + 200);

    // A stop mid-drag.
    let mut core = Pipeline::new(config.core());
    let mut released = 0;
    for (t, &v) in samples.iter().enumerate().take(drag_at as usize + 500) {
        let out = core.tick_input(&TickInput {
            stop: t as Tick == drag_at + 200,
            ..TickInput::volts(t as Tick, v)
        });
        released += out
            .outputs
            .iter()
            .filter(|c| **c == OutputCommand::ReleaseAll)
            .count();
    }
    assert_eq!(released, 1);
}

/// An output that keeps what it is given, as the runtime hands it over;
/// optionally stalled on its first command (a device or broker that
/// hangs).
#[derive(Clone, Default)]
struct Kept {
    commands: Arc<Mutex<Vec<OutputCommand>>>,
    closed: Arc<Mutex<u32>>,
    stall: Option<Duration>,
}

impl Output for Kept {
    fn describe(&self) -> String {
        "kept".into()
    }

    fn apply(&mut self, command: &OutputCommand) {
        let mut commands = self.commands.lock().unwrap();
        commands.push(*command);
        if commands.len() == 1
            && let Some(stall) = self.stall
        {
            std::thread::sleep(stall);
        }
    }

    fn close(&mut self) -> OutputReport {
        *self.closed.lock().unwrap() += 1;
        OutputReport {
            output: "kept".into(),
            applied: self.commands.lock().unwrap().len() as u64,
            ..OutputReport::default()
        }
    }
}

/// Runs the session through the production loop (on a simulated clock)
/// with these outputs, on rings of `ring` commands.
fn run_with(
    config: &Config,
    outputs: Vec<(Serves, Box<dyn Output>)>,
    ring: usize,
) -> Vec<OutputReport> {
    let params = SignalParams::clean(config.core().detector(), 7);
    let sensor = SyntheticSensor::new(params, outputs_session(config))
        .start()
        .unwrap();
    let (run, reports) = run_simulated_with_outputs(config.core(), sensor.samples, outputs, ring);
    assert_eq!(run.allocations, 0, "{run:?}");
    reports
}

#[test]
fn each_output_gets_what_it_serves_in_order_and_is_closed_once() {
    let config = library();
    let expected = commands(&config, &session(&config));
    let (computer, home) = (Kept::default(), Kept::default());
    let reports = run_with(
        &config,
        vec![
            (Serves::Computer, Box::new(computer.clone())),
            (Serves::Home, Box::new(home.clone())),
        ],
        SIMULATED_OUTPUT_RING,
    );
    let want = |serves: Serves| -> Vec<OutputCommand> {
        let mut want: Vec<OutputCommand> = expected
            .iter()
            .map(|&(_, c)| c)
            .filter(|c| serves.wants(c))
            .collect();
        // The run's safe stop at the end lets go of everything.
        if serves == Serves::Computer {
            want.push(OutputCommand::ReleaseAll);
        }
        want
    };
    assert_eq!(*computer.commands.lock().unwrap(), want(Serves::Computer));
    assert_eq!(*home.commands.lock().unwrap(), want(Serves::Home));
    assert_eq!(home.commands.lock().unwrap().len(), 2);
    assert_eq!(
        (
            *computer.closed.lock().unwrap(),
            *home.closed.lock().unwrap()
        ),
        (1, 1)
    );
    assert!(reports.iter().all(|r| r.dropped == 0), "{reports:?}");
}

#[test]
fn a_slow_output_loses_commands_counted_never_the_loop_its_pace() {
    let config = library();
    let slow = Kept {
        stall: Some(Duration::from_secs(2)),
        ..Kept::default()
    };
    let reports = run_with(
        &config,
        vec![(Serves::Computer, Box::new(slow.clone()))],
        OUTPUT_RING,
    );
    let kept = slow.commands.lock().unwrap().len() as u64;
    let report = &reports[0];
    // The loop runs on while the output hangs (its 80 s of ticks on a
    // simulated clock take well under 2 s): the ring fills, the rest is
    // dropped and counted, and nothing else is lost.
    assert!(report.dropped > 0, "{report:?}");
    assert_eq!(report.applied, kept);
    let offered = commands(&config, &session(&config))
        .iter()
        .filter(|(_, c)| Serves::Computer.wants(c))
        .count() as u64
        + 1;
    assert_eq!(report.applied + report.dropped, offered, "{report:?}");
}
