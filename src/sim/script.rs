//! Scripts for the synthetic sensor: what a scripted user breathes. The
//! demo user, the built-in user of `sipnpuff run`, a random user, the
//! paper's sequences, and a session that takes every path of the core.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::config::Config;
use crate::control::action::{Action, ActionSeq, Breath};
use crate::control::detector::DetectorConfig;
use crate::control::mode::Mode;
use crate::control::selection::SequenceEntry;
use crate::control::sequence::Sequence;
use crate::control::target::Target;
use crate::fit::protocol::{Ask, Protocol};
use crate::sim::sensor_model::{DEFAULT_RAMP_MS, SignalParams, Step};

/// How long a scripted user's breaths and pauses are, in ms.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Timing {
    /// A short burst.
    pub short_ms: u32,
    /// A long burst.
    pub long_ms: u32,
    /// Rest between the bursts of a sequence.
    pub gap_ms: u32,
}

impl Timing {
    /// Comfortable timings for the default detector (40 ms minimum, 500 ms
    /// long): 150 ms short, 800 ms long, 300 ms gaps.
    pub const DEFAULT: Timing = Timing {
        short_ms: 150,
        long_ms: 800,
        gap_ms: 300,
    };
}

/// The steps that enter `actions`, each burst followed by a gap.
pub fn sequence_steps(actions: &[Action], timing: Timing) -> Vec<Step> {
    actions
        .iter()
        .flat_map(|a| {
            [
                Step::Breath {
                    breath: a.breath(),
                    ms: if a.is_long() {
                        timing.long_ms
                    } else {
                        timing.short_ms
                    },
                },
                Step::Rest { ms: timing.gap_ms },
            ]
        })
        .collect()
}

/// Parses sequences written as codes, groups separated by spaces:
/// `"1,2,-1 1,2 2,1"`.
pub fn parse_sequences(text: &str) -> Result<Vec<Vec<Action>>, String> {
    text.split_whitespace()
        .map(|group| {
            group
                .split(',')
                .map(|code| {
                    code.trim()
                        .parse::<i64>()
                        .ok()
                        .and_then(Action::from_code)
                        .ok_or_else(|| {
                            format!("{code:?} in {group:?} is not an action code (1, 2, -1, -2)")
                        })
                })
                .collect()
        })
        .collect()
}

/// A script entering each sequence in turn (default timings), with enough
/// rest after each to be matched (or reset) and to return to detection mode
/// before the next.
pub fn sequences_script(config: &Config, sequences: &[Vec<Action>]) -> Vec<Step> {
    let rest = config.core().matcher().sequence_timeout_ms
        + config.core().command().inactivity_timeout_ms
        + 500;
    let mut script = vec![Step::Rest { ms: 1000 }];
    for actions in sequences {
        script.extend(sequence_steps(actions, Timing::DEFAULT));
        script.push(Step::Rest { ms: rest });
    }
    script
}

/// The demo user: selects modes from the configured library and uses
/// each: forward 1.5 s, save the point, down 1.5 s, rotate 1 s about the
/// tool's z axis, close the fingers to their end and open them a little,
/// forward until the reach limit stops the arm, then hold a puff in
/// `goto_point` until the saved pose is reached. Modes missing from the
/// library are skipped. Returns the script and the modes selected.
pub fn demo_script(config: &Config) -> (Vec<Step>, Vec<Mode>) {
    use Breath::{Puff, Sip};
    scripted_user(
        config,
        &[
            (Mode::TranslateX, &[(Puff, 1500)]),
            (Mode::SavePoint, &[(Puff, 300)]),
            (Mode::TranslateZ, &[(Sip, 1500)]),
            (Mode::RotateZ, &[(Puff, 1000)]),
            (Mode::Fingers, &[(Sip, 2700), (Puff, 600)]),
            (Mode::TranslateX, &[(Puff, 3000)]),
            (Mode::GotoPoint, &[(Puff, 5000)]),
            (Mode::TranslateY, &[(Sip, 800)]),
        ],
    )
}

/// The computer-and-home user: every entry of the library in turn, used
/// as a person would: a mode's sequence, then a held puff (1.2 s) and a
/// held sip (0.6 s); an action's sequence alone; a drag begun, a pointer
/// mode held and the drag let go again. Each use ends with rest enough to
/// return to selection. For a library such as
/// `fixtures/computer-and-home.toml` (the outputs' tests and their proofs
/// against the kernel and a broker).
pub fn outputs_session(config: &Config) -> Vec<Step> {
    use Breath::{Puff, Sip};
    let core = config.core();
    let rest = core.matcher().sequence_timeout_ms + core.command().inactivity_timeout_ms + 500;
    let library = core.sequences();
    let mut script = vec![Step::Rest { ms: 1000 }];
    let select = |script: &mut Vec<Step>, target: Target, holds: &[(Breath, u32)]| {
        if let Some(actions) = library
            .iter()
            .find(|e| e.target == target)
            .and_then(SequenceEntry::breaths)
        {
            script.extend(sequence_steps(actions.as_slice(), Timing::DEFAULT));
            for &(breath, ms) in holds {
                script.push(Step::Breath { breath, ms });
                script.push(Step::Rest { ms: 300 });
            }
            script.push(Step::Rest { ms: rest });
        }
    };
    let holds: [(Breath, u32); 2] = [(Puff, 1200), (Sip, 600)];
    for entry in library {
        let uses: &[(Breath, u32)] = match entry.target {
            Target::Mode(_) => &holds,
            _ => &[],
        };
        select(&mut script, entry.target, uses);
    }
    if let Some(pointer) = library
        .iter()
        .find(|e| matches!(e.target, Target::Mode(m) if m.is_pointer()))
    {
        select(&mut script, Target::Drag, &[]);
        select(&mut script, pointer.target, &[(Puff, 1000)]);
        select(&mut script, Target::Drag, &[]);
    }
    script
}

/// The built-in user of `sipnpuff run` (about 22 s): saves the home pose,
/// moves forward 1.5 s, closes the fingers 1.5 s and opens them 1 s, then
/// holds a puff in `goto_point` until the saved pose is reached.
pub fn run_script(config: &Config) -> (Vec<Step>, Vec<Mode>) {
    use Breath::{Puff, Sip};
    let (mut script, modes) = scripted_user(
        config,
        &[
            (Mode::SavePoint, &[(Puff, 300)]),
            (Mode::TranslateX, &[(Puff, 1500)]),
            (Mode::Fingers, &[(Sip, 1200), (Puff, 800)]),
            (Mode::GotoPoint, &[(Puff, 2200)]),
        ],
    );
    // The run ends with a safe stop: no need to wait for detection mode.
    script.pop();
    (script, modes)
}

/// A user who selects each mode in turn (its first sequence in the
/// library), makes the given breaths in it, and waits to return to
/// detection mode. Modes missing from the library are skipped.
fn scripted_user(config: &Config, plan: &[(Mode, &[(Breath, u32)])]) -> (Vec<Step>, Vec<Mode>) {
    let library = config.core().sequences();
    // A sequence that starts another is matched only at the timeout.
    let wait = |actions: &Sequence| {
        let prefix = library.iter().any(|e| {
            e.actions.len() > actions.len() && e.actions.as_slice().starts_with(actions.as_slice())
        });
        if prefix {
            config.core().matcher().sequence_timeout_ms + 200
        } else {
            300
        }
    };
    let leave = config.core().command().inactivity_timeout_ms + 300;
    let mut script = vec![Step::Rest { ms: 1000 }];
    let mut modes = Vec::new();
    for &(mode, breaths) in plan {
        let Some((entry, actions)) = config
            .core()
            .sequences()
            .iter()
            .filter(|e| e.target.mode() == Some(mode))
            .find_map(|e| Some((e, e.breaths()?)))
        else {
            continue;
        };
        script.extend(sequence_steps(actions.as_slice(), Timing::DEFAULT));
        script.push(Step::Rest {
            ms: wait(&entry.actions),
        });
        for &(breath, ms) in breaths {
            script.push(Step::Breath { breath, ms });
            script.push(Step::Rest { ms: 400 });
        }
        script.push(Step::Rest { ms: leave });
        modes.push(mode);
    }
    (script, modes)
}

/// A scripted user session: random library sequences, each followed by a
/// few moves (holds of 0.2–3 s, with pauses short enough to stay in the
/// mode) and a wait until the interface returns to detection mode, then
/// rest. Deterministic for a seed. Played with the default ramps, every
/// breath ends within the first `seconds × 1000` samples and the script
/// lasts at least that long, so cutting it there only shortens the final
/// rest. Returns the script and the modes selected, in order.
pub fn random_session(config: &Config, seconds: u64, seed: u64) -> (Vec<Step>, Vec<Mode>) {
    random_session_with(
        config,
        seconds,
        seed,
        UserStyle::for_detector(config.core().detector()),
    )
}

/// How a scripted user breathes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UserStyle {
    /// Bursts and gaps while entering a sequence.
    pub timing: Timing,
    /// Range of the holds that move the arm, ms.
    pub hold_ms: (u32, u32),
}

impl UserStyle {
    /// The random user's style: short bursts halfway between the class
    /// boundaries, long ones 300 ms past `long_burst_ms`, 300 ms gaps,
    /// holds of 0.2–3 s.
    pub fn for_detector(d: &DetectorConfig) -> UserStyle {
        UserStyle {
            timing: Timing {
                short_ms: (d.min_burst_ms + d.long_burst_ms) / 2,
                long_ms: d.long_burst_ms + 300,
                gap_ms: 300,
            },
            hold_ms: (200, 3000),
        }
    }
}

/// [`random_session`] for a user who breathes in the given style.
pub fn random_session_with(
    config: &Config,
    seconds: u64,
    seed: u64,
    style: UserStyle,
) -> (Vec<Step>, Vec<Mode>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed_5e55_1011);
    let timing = style.timing;
    let inactivity = config.core().command().inactivity_timeout_ms;
    // Ramps add up to ~100 ms around a pause; stay well inside the timeout.
    let longest_pause = inactivity.saturating_sub(400).max(201);
    // A breather breathes the entries made of breaths only.
    let library: Vec<(ActionSeq, Target)> = config
        .core()
        .sequences()
        .iter()
        .filter_map(|e| Some((e.breaths()?, e.target)))
        .collect();
    let total_ms = seconds * 1000;
    // Samples a step plays: at least its `ms`, and for a breath at most its
    // `ms` plus both ramps whole.
    let bounds = |steps: &[Step]| {
        steps.iter().fold((0, 0), |(low, high), s| match *s {
            Step::Breath { ms, .. } => (
                low + u64::from(ms),
                high + u64::from(ms) + 2 * DEFAULT_RAMP_MS.1 as u64 + 2,
            ),
            Step::Rest { ms } | Step::Dropout { ms } => (low + u64::from(ms), high + u64::from(ms)),
        })
    };
    let mut script = vec![Step::Rest { ms: 1000 }];
    let mut modes = Vec::new();
    let (mut low, mut high) = (1000, 1000);
    while !library.is_empty() {
        let (actions, target) = library[rng.random_range(0..library.len())];
        let mut steps = sequence_steps(actions.as_slice(), timing);
        // Wait out the sequence timeout in case the entry is a prefix.
        steps.push(Step::Rest {
            ms: config.core().matcher().sequence_timeout_ms,
        });
        for _ in 0..rng.random_range(1..=3) {
            let breath = if rng.random_bool(0.5) {
                Breath::Puff
            } else {
                Breath::Sip
            };
            steps.push(Step::Breath {
                breath,
                ms: rng.random_range(style.hold_ms.0..=style.hold_ms.1),
            });
            steps.push(Step::Rest {
                ms: rng.random_range(200..longest_pause),
            });
        }
        steps.push(Step::Rest {
            ms: inactivity + 500,
        });
        let (step_low, step_high) = bounds(&steps);
        if high + step_high > total_ms {
            break;
        }
        low += step_low;
        high += step_high;
        script.extend(steps);
        if let Some(mode) = target.mode() {
            modes.push(mode);
        }
    }
    let fill = total_ms.saturating_sub(low);
    script.push(Step::Rest {
        ms: u32::try_from(fill).unwrap_or(u32::MAX),
    });
    (script, modes)
}

/// A noisy session of about 150 s that takes every path of the core
/// (bursts, matches, resets on timeout and at once, mode changes, faults
/// and recoveries, a stuck breath and two re-zeroes) and of the motion
/// layer (every mode, save and go to point, the finger end and the reach
/// limit, braking after a fault): a random user, the demo user twice, then
/// faults and broken sequences. The allocation and RealtimeSanitizer
/// checks run it.
pub fn every_path_session(config: &Config) -> (SignalParams, Vec<Step>) {
    let params = SignalParams::clean(config.core().detector(), 11)
        .with_noise(0.08)
        .with_hum(0.15)
        .with_drift(0.3)
        .with_spikes_every(100);
    let (mut script, _) = random_session(config, 150, 11);
    // The demo user, twice: every mode, save, go to, the finger end and the
    // reach limit.
    for _ in 0..2 {
        script.extend(demo_script(config).0);
    }
    // Faults, a sequence cut short (reset on timeout) and a wrong sequence
    // (reset at once), between the random user's selections.
    script.extend([
        Step::Dropout { ms: 20 },
        Step::Rest { ms: 1000 },
        Step::Breath {
            breath: Breath::Puff,
            ms: 150,
        },
        Step::Rest { ms: 2000 },
        Step::Breath {
            breath: Breath::Puff,
            ms: 150,
        },
        Step::Dropout { ms: 3 },
        Step::Rest { ms: 1000 },
        // A puff held 9 s without wandering: a stuck fault at 6 s, and its
        // level becomes the neutral 2 s later; the rest that follows is then
        // a sip held too long, stuck and re-zeroed back in turn.
        Step::Breath {
            breath: Breath::Puff,
            ms: 9000,
        },
        Step::Rest { ms: 10_000 },
    ]);
    (params, script)
}

/// A user breathing `protocol` in time with a live calibration's prompts
/// (`sipnpuff fit` on the synthetic sensor; the guide is
/// `fit::prompter`): 6 s at rest, then each breath 1.5–2 s after the one
/// before and 3.5 s after a block's last, so that every breath starts
/// after its prompt (the guide prompts after 1 s of rest, 3 s between
/// blocks, 5 s at the start); short breaths 150 ms and long ones 800 ms
/// (± 30 %), holds 3.5 s (± 10 %); then 10 s at rest, past the session's
/// end. Light noise (0.01 V); shaped for `detector`, its neutral the rest
/// level. Seeded.
pub fn protocol_script(
    detector: &DetectorConfig,
    protocol: &Protocol,
    seed: u64,
) -> (SignalParams, Vec<Step>) {
    let script = prompted_script(protocol, seed, |ask, rng| {
        let (mean, spread) = match ask {
            Ask::Breath(action) if action.is_long() => (800.0, 0.3),
            Ask::Breath(_) => (150.0, 0.3),
            Ask::Hold(_) => (3500.0, 0.1),
        };
        (mean * rng.random_range(1.0 - spread..=1.0 + spread)) as u32
    });
    let params = SignalParams::clean(detector, seed).with_noise(0.01);
    (params, script)
}

/// The timing of [`protocol_script`] with each breath's length from
/// `length`: 6 s at rest, 1.5–2 s after each breath and 3.5 s after a
/// block's last, 10 s at rest at the end.
pub fn prompted_script(
    protocol: &Protocol,
    seed: u64,
    mut length: impl FnMut(Ask, &mut ChaCha8Rng) -> u32,
) -> Vec<Step> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut script = vec![Step::Rest { ms: 6000 }];
    for block in &protocol.blocks {
        for n in 1..=block.count {
            let ms = length(block.ask, &mut rng);
            script.push(Step::Breath {
                breath: block.ask.breath(),
                ms,
            });
            let rest = if n == block.count {
                3500
            } else {
                rng.random_range(1500..=2000)
            };
            script.push(Step::Rest { ms: rest });
        }
    }
    script.push(Step::Rest { ms: 10_000 });
    script
}
