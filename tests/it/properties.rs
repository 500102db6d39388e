//! Seeded property tests of the core's invariants (proptest; failures are
//! shrunk and persisted by seed).

use proptest::prelude::*;
use sipnpuff::config::Config;
use sipnpuff::control::action::{Action, ActionSeq, Breath};
use sipnpuff::control::event::Event;
use sipnpuff::control::mode::{Direction, Mode, ModeState};
use sipnpuff::control::pipeline::Pipeline;
use sipnpuff::control::selection::index::{ScanIndex, TrieIndex};
use sipnpuff::sim::script::{Timing, sequence_steps};
use sipnpuff::sim::sensor_model::{SignalGenerator, SignalParams, Step};

fn action() -> impl Strategy<Value = Action> {
    prop::sample::select(Action::ALL.to_vec())
}

fn mode() -> impl Strategy<Value = Mode> {
    prop::sample::select(Mode::ALL.to_vec())
}

/// A library of 1–12 distinct sequences of 1–6 actions (prefixes allowed),
/// as a validated config built from TOML.
fn library() -> impl Strategy<Value = Config> {
    prop::collection::vec((prop::collection::vec(action(), 1..=6), mode()), 1..=12).prop_map(
        |entries| {
            let mut seen = std::collections::HashSet::new();
            let mut toml = String::new();
            for (actions, mode) in entries {
                if seen.insert(actions.clone()) {
                    let codes: Vec<String> = actions.iter().map(|a| a.code().to_string()).collect();
                    toml += &format!(
                        "[[sequence]]\nactions = [{}]\nmode = \"{}\"\n",
                        codes.join(", "),
                        mode.name()
                    );
                }
            }
            Config::from_toml_str(&toml).expect("generated library is valid")
        },
    )
}

/// Runs of one value: any f64 (NaN, ±inf, huge), the rails, or a level in
/// 0–5 V, each held 1–600 samples.
fn samples() -> impl Strategy<Value = Vec<f64>> {
    let level = prop_oneof![
        1 => any::<f64>(),
        1 => Just(f64::NAN),
        1 => prop::sample::select(vec![0.0, 5.0, f64::INFINITY, f64::NEG_INFINITY, -0.6, 5.6]),
        8 => 0.0f64..=5.0,
    ];
    prop::collection::vec((level, 1usize..600), 0..60).prop_map(|runs| {
        runs.into_iter()
            .flat_map(|(v, n)| std::iter::repeat_n(v, n))
            .collect()
    })
}

/// A random user: breaths of 10–1500 ms and rests of 10–3000 ms.
fn random_script() -> impl Strategy<Value = Vec<Step>> {
    let breath = prop::sample::select(vec![Breath::Sip, Breath::Puff]);
    prop::collection::vec((breath, 10u32..1500, 10u32..3000), 1..40).prop_map(|steps| {
        steps
            .into_iter()
            .flat_map(|(breath, ms, rest)| [Step::Breath { breath, ms }, Step::Rest { ms: rest }])
            .collect()
    })
}

fn in_library(config: &Config, sequence: &ActionSeq, mode: Mode) -> bool {
    config
        .core()
        .sequences()
        .iter()
        .any(|e| e.actions == *sequence && e.mode == mode)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Whatever the samples, nothing panics, matches come only from the
    /// library, nothing moves outside command mode or during a fault, and no
    /// event is ever dropped.
    #[test]
    fn any_samples_are_safe(config in library(), samples in samples()) {
        let mut core: Pipeline = Pipeline::new(config.core());
        for (t, &v) in samples.iter().enumerate() {
            let out = core.step(t as u64, v);
            prop_assert_eq!(out.dropped_events, 0);
            prop_assert!(out.command.strength_volts.is_finite() && out.command.strength_volts >= 0.0);
            if out.command.state == ModeState::Detection || out.faulted {
                prop_assert_eq!(out.command.direction, Direction::Still);
            }
            for event in out.events.iter() {
                if let Event::Match { sequence, mode } = event {
                    prop_assert!(in_library(&config, sequence, *mode), "{:?} {:?}", sequence, mode);
                }
            }
        }
    }

    /// Entering any UDS with clean bursts (realistic ramps and tremor, any
    /// seed) yields exactly that match: the right bursts, no reset.
    #[test]
    fn clean_bursts_of_a_uds_match_it(config in library(), pick in any::<prop::sample::Index>(), seed in any::<u64>()) {
        let entry = config.core().sequences()[pick.index(config.core().sequences().len())];
        let mut script = vec![Step::Rest { ms: 500 }];
        script.extend(sequence_steps(entry.actions.as_slice(), Timing::DEFAULT));
        script.push(Step::Rest { ms: 3000 });
        let mut core: Pipeline = Pipeline::new(config.core());
        let mut bursts = Vec::new();
        let mut decisions = Vec::new();
        for (t, v) in SignalGenerator::new(SignalParams::clean(config.core().detector(), seed), &script).enumerate() {
            for event in core.step(t as u64, v).events.iter() {
                match event {
                    Event::Burst(b) => bursts.push(b.action),
                    Event::Match { .. } | Event::Reset { .. } => decisions.push(*event),
                    _ => {}
                }
            }
        }
        prop_assert_eq!(bursts.as_slice(), entry.actions.as_slice());
        prop_assert_eq!(decisions, vec![Event::Match { sequence: entry.actions, mode: entry.mode }]);
    }

    /// The trie and the reference linear scan make the same decisions on the
    /// same noisy signal, tick for tick.
    #[test]
    fn trie_and_scan_agree(config in library(), script in random_script(), seed in any::<u64>()) {
        let mut params = SignalParams::clean(config.core().detector(), seed);
        params.noise_volts = 0.05;
        let mut trie: Pipeline<TrieIndex> = Pipeline::new(config.core());
        let mut scan: Pipeline<ScanIndex> = Pipeline::new(config.core());
        for (t, v) in SignalGenerator::new(params, &script).enumerate() {
            prop_assert_eq!(trie.step(t as u64, v), scan.step(t as u64, v));
        }
    }
}
