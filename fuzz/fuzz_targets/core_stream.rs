//! Arbitrary sample streams (levels anywhere in and out of 0–5 V, NaN,
//! infinities, missing samples, a device gone) through the whole core and
//! motion layer, with the built-in library, the paper's (with prefixes) or
//! one for the computer and the home (keys, clicks, pointer modes, a drag,
//! home events), process stalls (ticks that jump ahead), the arm's link
//! lost and the safe stop begun at any tick: never a panic; matches only
//! from the library; a drag's button never left down after a fault's
//! release; detection mode for good once the stop began; nothing but
//! finite numbers reaching the arm; and the
//! safety monitor's promises at every tick (`sipnpuff::tools::safety`: the
//! workspace by the margin as a normal distance, the orientation limits,
//! speed, acceleration and jerk vectors within the limits, still within
//! the stopping time after every release and fault).

#![no_main]

use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use sipnpuff::config::Config;
use sipnpuff::control::event::Event;
use sipnpuff::control::mode::ModeState;
use sipnpuff::control::output_command::OutputCommand;
use sipnpuff::control::pipeline::Pipeline;
use sipnpuff::control::sample::Sample;
use sipnpuff::control::tick::{ArmInput, TickInput, TickOutput};
use sipnpuff::tools::safety::SafetyMonitor;

const PAPER_LIBRARY: &str = include_str!("../../fixtures/paper-example.toml");
const OUTPUTS_LIBRARY: &str = include_str!("../../fixtures/computer-and-home.toml");
/// Bound on one input's length, so each run stays short.
const MAX_TICKS: u64 = 30_000;

/// The built-in configuration, the paper's library and the computer and
/// home's, read once (not once an input: the same text every time).
fn configs() -> &'static [Config; 3] {
    static CONFIGS: OnceLock<[Config; 3]> = OnceLock::new();
    CONFIGS.get_or_init(|| {
        let paper = Config::from_toml_str(PAPER_LIBRARY).expect("the paper's example is valid");
        let outputs =
            Config::from_toml_str(OUTPUTS_LIBRARY).expect("the outputs' library is valid");
        [Config::default(), paper, outputs]
    })
}

fn norm(v: &[f64; 3]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// One tick's input from two bytes of a chunk: the sample, and how many
/// ticks the process stalled before it (the tick jumps ahead).
fn decode(kind: u8, level: u8) -> (Sample, u64) {
    let volts = f64::from(level);
    let sample = match kind % 10 {
        // Mostly inside 0–5 V, where breaths are.
        0..=5 => Sample::Volts(volts / 255.0 * 5.0),
        6 => Sample::Volts(volts / 255.0 * 9.0 - 2.0), // out of range too
        7 => Sample::Volts(f64::NAN),
        8 if level < 128 => Sample::Volts(f64::INFINITY),
        8 => Sample::Volts(f64::NEG_INFINITY),
        _ if level < 96 => Sample::Missing,
        _ if level < 128 => Sample::Lost,
        _ => return (Sample::Missing, (u64::from(level) - 127) * 20),
    };
    (sample, 0)
}

/// What a chunk's first tick carries besides its sample, for the rare
/// kinds: the arm's link lost (250–252) or the safe stop begun (253–255).
fn arm_and_stop(kind: u8) -> (ArmInput, bool) {
    let arm = ArmInput {
        link_lost: matches!(kind, 250..=252),
        ..ArmInput::default()
    };
    (arm, kind >= 253)
}

fn check(config: &Config, o: &TickOutput, monitor: &mut SafetyMonitor) {
    let m = config.core().motion();
    let tol = 1.0 + 1e-9;
    if let Err(violation) = monitor.check(o) {
        panic!("{violation}");
    }
    let motion = &o.motion;
    if let Some(c) = &motion.arm_command {
        let numbers = c.linear.iter().chain(&c.angular).chain([&c.fingers]);
        assert!(numbers.clone().all(|v| v.is_finite()), "{c:?}");
        assert!(norm(&c.linear) <= m.linear_speed_mps * tol, "{c:?}");
        assert!(norm(&c.angular) <= m.angular_speed_radps * tol, "{c:?}");
    }
    for event in o.events.iter() {
        if let Event::Match { sequence, target } = event {
            assert!(
                config
                    .core()
                    .sequences()
                    .iter()
                    .any(|e| e.actions == *sequence && e.target == *target),
                "{sequence:?} → {target:?} is not in the library"
            );
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&choice, chunks)) = data.split_first() else {
        return;
    };
    let config = &configs()[usize::from(choice % 3)];
    let mut core = Pipeline::new(config.core());
    let mut monitor = SafetyMonitor::new(config.core());
    let mut out = TickOutput::default();
    let mut tick = 0u64;
    // The drag's button as the outputs would hold it.
    let mut button_down = false;
    let mut stopped = false;
    for chunk in chunks.chunks_exact(3) {
        let (kind, level, len) = (chunk[0], chunk[1], chunk[2]);
        // Hold each level 4 ms to 1 s, so breaths, sequences and holds form.
        for at in 0..(u64::from(len) + 1) * 4 {
            let (sample, stalled) = decode(kind, level);
            tick += stalled;
            let (arm, stop) = if at == 0 {
                arm_and_stop(kind)
            } else {
                (ArmInput::default(), false)
            };
            stopped |= stop;
            let input = TickInput {
                arm,
                stop,
                ..TickInput::new(tick, sample)
            };
            core.step(&input, &mut out);
            check(config, &out, &mut monitor);
            assert!(
                !stopped || out.command.state == ModeState::Detection,
                "command mode after the stop began"
            );
            for command in out.outputs.iter() {
                match command {
                    OutputCommand::Button { down } => button_down = *down,
                    OutputCommand::ReleaseAll => button_down = false,
                    _ => {}
                }
            }
            assert!(
                !(out.faulted && button_down),
                "a fault left the drag's button down"
            );
            tick += 1;
            if tick >= MAX_TICKS {
                return;
            }
        }
    }
});
