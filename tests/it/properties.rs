//! Seeded property tests of the core's invariants (proptest; failures are
//! shrunk and persisted by seed).

use crate::common::TickByTick;
use proptest::prelude::*;
use sipnpuff::config::Config;
use sipnpuff::control::action::{Action, Breath};
use sipnpuff::control::event::Event;
use sipnpuff::control::mode::{Direction, Mode, ModeState};
use sipnpuff::control::motion::limits::{caps, hold_to_run_min_jerk};
use sipnpuff::control::pipeline::Pipeline;
use sipnpuff::control::sample::Sample;
use sipnpuff::control::selection::Interface;
use sipnpuff::control::sequence::Sequence;
use sipnpuff::control::token::Token;
use sipnpuff::sim::script::{Timing, sequence_steps};
use sipnpuff::sim::sensor_model::{SignalGenerator, SignalParams, Step};
use sipnpuff::tools::safety::SafetyMonitor;

fn action() -> impl Strategy<Value = Action> {
    prop::sample::select(Action::ALL.to_vec())
}

fn mode() -> impl Strategy<Value = Mode> {
    prop::sample::select(Mode::ALL.to_vec())
}

/// A library of 1–12 distinct sequences of 1–6 actions (prefixes allowed),
/// as `[[sequence]]` TOML.
fn library_toml() -> impl Strategy<Value = String> {
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
            toml
        },
    )
}

/// A random library on the default settings, as a validated config.
fn library() -> impl Strategy<Value = Config> {
    library_toml()
        .prop_map(|toml| Config::from_toml_str(&toml).expect("generated library is valid"))
}

/// `[detector]`, `[matcher]`, `[command]`: any values the validator's
/// rules allow (thresholds on their sides of the neutral, the hysteresis
/// inside the band, timers ordered).
fn timing_toml() -> impl Strategy<Value = String> {
    (
        (1.0f64..4.0, 0.05f64..0.95, 0.05f64..0.95, 0.0f64..0.9),
        (2u32..200, 1u32..3000, 0.0f64..1.0, 1u32..20_000),
        (0.01f64..5.0, 1u32..3000, 1u32..3000, 1u32..5000, 1u32..10_000),
        prop_oneof![Just(0u32), 1u32..1500],
        prop_oneof![Just(None), (0.0f64..0.9).prop_map(Some)],
    )
        .prop_map(
            |(
                (neutral, puff, sip, hysteresis),
                (min_burst, long_extra, glitch, tracking),
                (margin, recovery, stale, timeout, inactivity),
                onset,
                sip_hysteresis,
            )| {
                let puff_offset = puff * (5.0 - neutral);
                let sip_offset = sip * neutral;
                // One hysteresis inside the narrower band, or one each.
                let (hysteresis, sip_hysteresis) = match sip_hysteresis {
                    None => (hysteresis * puff_offset.min(sip_offset), String::new()),
                    Some(h) => (
                        hysteresis * puff_offset,
                        format!("sip_hysteresis_volts = {}\n", h * sip_offset),
                    ),
                };
                format!(
                    "[detector]\nneutral_volts = {neutral}\npuff_threshold_volts = {}\nsip_threshold_volts = {}\nhysteresis_volts = {hysteresis}\n{sip_hysteresis}min_burst_ms = {min_burst}\nlong_burst_ms = {}\nglitch_ms = {}\nneutral_tracking_ms = {tracking}\nfault_margin_volts = {margin}\nfault_recovery_ms = {recovery}\nstale_ms = {stale}\n[matcher]\nsequence_timeout_ms = {timeout}\n[command]\ninactivity_timeout_ms = {inactivity}\nmotion_onset_ms = {onset}\n",
                    neutral + puff_offset,
                    neutral - sip_offset,
                    min_burst + long_extra,
                    (glitch * f64::from(min_burst)) as u32,
                )
            },
        )
}

/// `[motion]`, `[workspace]`, `[arm]`: limits within the JACO2's caps, a
/// workspace within its reach, the power-up pose inside it (drawn in
/// spherical coordinates between the spheres, above the table).
fn motion_toml() -> impl Strategy<Value = String> {
    (
        (0.04f64..=0.2, 0.2f64..=1.07, 0.01f64..=1.0, 0.01f64..=1.0, 0.0f64..=1.0, 0.0f64..=1.0),
        (1.0f64..=6800.0, 0.001f64..=1.0, 0.0f64..=1.0, any::<bool>(), 0.05f64..=5.0, 0.0f64..=1.0),
        (0.3f64..=0.9, 0.0f64..=0.5, -0.5f64..=0.3, 0.001f64..=0.02, 100.0f64..=10_000.0, 0.05f64..=2.9, 0.05f64..=2.9),
        (0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0, -3.0f64..3.0, 0.0f64..=1.0),
    )
        .prop_map(|(speeds, fingers, workspace, home)| {
            let (v, w, a_share, aw_share, j_share, jw_share) = speeds;
            let (fv, fa_share, fj_share, proportional, full_scale, min_fraction) = fingers;
            let (reach, min_share, table_share, margin, closed, tilt, twist) = workspace;
            let (radius_share, elevation_share, azimuth_share, angle, finger_share) = home;
            // Any acceleration under its cap whose hold-to-run jerk (A²/2J
            // ≤ 10 % of v, A/J ≤ 60 ms) fits under the jerk cap, then any
            // jerk from that least one to the cap.
            let limits = |speed: f64, a_cap: f64, j_cap: f64, a_share: f64, j_share: f64| {
                let a_max = a_cap.min((0.2 * speed * j_cap).sqrt()).min(0.06 * j_cap);
                let a = a_max * a_share;
                let least = hold_to_run_min_jerk(speed, a);
                (a, least + (j_cap - least) * j_share)
            };
            let (a, j) = limits(v, caps::LINEAR_ACCELERATION_MPS2, caps::LINEAR_JERK_MPS3, a_share, j_share);
            let (aw, jw) = limits(w, caps::ANGULAR_ACCELERATION_RADPS2, caps::ANGULAR_JERK_RADPS3, aw_share, jw_share);
            let (fa, fj) = limits(fv, caps::FINGER_ACCELERATION, caps::FINGER_JERK, fa_share, fj_share);
            let min_radius = reach * min_share;
            let table = reach * table_share;
            // A radius between the spheres; an elevation that keeps the
            // point above the table (the reach sphere always has room: the
            // table is at most 0.3 of the reach).
            let (inner, outer) = ((min_radius + margin).max(table + 2.0 * margin), reach - margin);
            let r = inner + (outer - inner) * (0.05 + 0.9 * radius_share);
            let lowest = ((table + margin) / r).clamp(-1.0, 1.0).asin();
            let highest = std::f64::consts::FRAC_PI_2;
            let elevation = lowest + (highest - lowest) * (0.05 + 0.9 * elevation_share);
            let azimuth = 2.0 * std::f64::consts::PI * azimuth_share;
            let home = [
                r * elevation.cos() * azimuth.cos(),
                r * elevation.cos() * azimuth.sin(),
                r * elevation.sin(),
            ];
            format!(
                "[motion]\nlinear_speed_mps = {v}\nangular_speed_radps = {w}\nlinear_acceleration_mps2 = {a}\nangular_acceleration_radps2 = {aw}\nlinear_jerk_mps3 = {j}\nangular_jerk_radps3 = {jw}\nfinger_speed = {fv}\nfinger_acceleration = {fa}\nfinger_jerk = {fj}\nproportional_speed = {proportional}\nproportional_full_scale_volts = {full_scale}\nproportional_min_fraction = {min_fraction}\n[workspace]\nreach_m = {reach}\nmin_radius_m = {min_radius}\ntable_z_m = {table}\nstop_margin_m = {margin}\nfinger_closed = {closed}\nmax_tilt_rad = {tilt}\nmax_twist_rad = {twist}\n[arm]\nhome_position_m = [{}, {}, {}]\nhome_rotation_vector_rad = [0.0, {angle}, 0.0]\nhome_fingers = {}\n",
                home[0], home[1], home[2], closed * finger_share
            )
        })
}

/// `[interface]` and `[scanning]`: either interface, any dwell times, any
/// non-empty order of distinct modes.
fn selection_toml() -> impl Strategy<Value = String> {
    (
        any::<bool>(),
        1u32..5000,
        1u32..10_000,
        Just(Mode::ALL.to_vec()).prop_shuffle(),
        1usize..=9,
    )
        .prop_map(|(bsp, dwell, first, order, count)| {
            let names: Vec<String> = order[..count].iter().map(|m| format!("\"{}\"", m.name())).collect();
            format!(
                "[interface]\nkind = \"{}\"\n[scanning]\ndwell_ms = {dwell}\nfirst_dwell_ms = {first}\norder = [{}]\n",
                if bsp { "bsp" } else { "asp" },
                names.join(", ")
            )
        })
}

/// Any configuration the validator accepts: every section drawn at random
/// within its rules, and a random library.
fn valid_config() -> impl Strategy<Value = Config> {
    (
        timing_toml(),
        motion_toml(),
        selection_toml(),
        library_toml(),
    )
        .prop_map(|(timing, motion, selection, library)| {
            let text = format!("{timing}{motion}{selection}{library}");
            match Config::from_toml_str(&text) {
                Ok(config) => config,
                Err(e) => panic!("a generated config is invalid: {e}\n{text}"),
            }
        })
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

fn in_library(config: &Config, sequence: &Sequence, mode: Mode) -> bool {
    config
        .core()
        .sequences()
        .iter()
        .any(|e| e.actions == *sequence && e.target.mode() == Some(mode))
}

/// Whether a match could come from the interface: a library entry (ASP),
/// or one puff on a mode of the scan (BSP).
fn selectable(config: &Config, sequence: &Sequence, mode: Mode) -> bool {
    match config.core().interface() {
        Interface::Asp => in_library(config, sequence, mode),
        Interface::Bsp => {
            let one_puff =
                matches!(sequence.as_slice(), [Token::Breath(a)] if a.breath() == Breath::Puff);
            one_puff && config.core().scanning().modes().contains(&mode)
        }
    }
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
            let out = core.tick(t as u64, v);
            prop_assert_eq!(out.dropped_events, 0);
            prop_assert!(out.command.strength_volts.is_finite() && out.command.strength_volts >= 0.0);
            if out.command.state == ModeState::Detection || out.faulted {
                prop_assert_eq!(out.command.direction, Direction::Still);
            }
            for event in out.events.iter() {
                if let Event::Match { sequence, target } = event {
                    let mode = target.mode().expect("the library selects modes");
                    prop_assert!(in_library(&config, sequence, mode), "{:?} {:?}", sequence, mode);
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
        let actions = entry.breaths().unwrap();
        script.extend(sequence_steps(actions.as_slice(), Timing::DEFAULT));
        script.push(Step::Rest { ms: 3000 });
        let mut core: Pipeline = Pipeline::new(config.core());
        let mut bursts = Vec::new();
        let mut decisions = Vec::new();
        for (t, v) in SignalGenerator::new(SignalParams::clean(config.core().detector(), seed), &script).enumerate() {
            for event in core.tick(t as u64, v).events.iter() {
                match event {
                    Event::Burst(b) => bursts.push(b.action),
                    Event::Match { .. } | Event::Reset { .. } => decisions.push(*event),
                    _ => {}
                }
            }
        }
        prop_assert_eq!(bursts.as_slice(), actions.as_slice());
        prop_assert_eq!(decisions, vec![Event::Match { sequence: entry.actions, target: entry.target }]);
    }

    /// Any valid configuration, any samples, and ticks that jump ahead,
    /// repeat or go back: no panic, only finite motion within the speed
    /// limits, matches only from the library, no motion outside command
    /// mode or during a fault, every event kept.
    #[test]
    fn any_valid_config_any_samples_any_ticks(
        config in valid_config(),
        samples in samples(),
        jumps in prop::collection::vec((0usize..20_000, prop_oneof![Just(0u64), 1u64..5, 1000u64..100_000]), 0..4),
    ) {
        let mut core: Pipeline = Pipeline::new(config.core());
        let m = *config.core().motion();
        let norm = |v: [f64; 3]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        let mut tick: u64 = 1_000_000;
        for (i, &v) in samples.iter().enumerate() {
            // Mostly one tick on; at the chosen samples, back or ahead.
            tick = match jumps.iter().find(|(at, _)| *at == i) {
                Some((_, 0)) => tick,
                Some((at, by)) if at % 2 == 0 => tick.saturating_sub(*by),
                Some((_, by)) => tick + by,
                None => tick + 1,
            };
            let out = if v.is_nan() && i % 7 == 0 { core.tick_with(tick, Sample::Missing) } else { core.tick(tick, v) };
            prop_assert_eq!(out.dropped_events, 0);
            let motion = out.motion.velocity();
            prop_assert!(motion.iter().all(|x| x.is_finite()), "{:?}", motion);
            prop_assert!(norm(out.motion.linear) <= m.linear_speed_mps * (1.0 + 1e-9));
            prop_assert!(norm(out.motion.angular) <= m.angular_speed_radps * (1.0 + 1e-9));
            prop_assert!(out.motion.fingers_velocity.abs() <= m.finger_speed * (1.0 + 1e-9));
            if out.command.state == ModeState::Detection || out.faulted {
                prop_assert_eq!(out.command.direction, Direction::Still);
            }
            for event in out.events.iter() {
                if let Event::Match { sequence, target } = event {
                    let mode = target.mode().expect("the library selects modes");
                    prop_assert!(selectable(&config, sequence, mode), "{:?} {:?}", sequence, mode);
                }
            }
        }
    }

    /// `sipnpuff config` prints any valid configuration as TOML that reads
    /// back to the same configuration, and prints that the same again.
    #[test]
    fn printed_configs_read_back_the_same(config in valid_config()) {
        let text = config.to_toml().unwrap();
        let again = Config::from_toml_str(&text);
        prop_assert_eq!(again.as_ref(), Ok(&config), "{}", text);
        prop_assert_eq!(again.unwrap().to_toml().unwrap(), text);
    }
}

/// One stretch of an adversarial user's session.
#[derive(Debug, Clone)]
enum Segment {
    /// Enters a library sequence (quickly or comfortably), then holds a
    /// breath and rests: the way modes are used, and fast re-selections.
    Select {
        entry: prop::sample::Index,
        quick: bool,
        hold: (Breath, u32),
        rest: u32,
    },
    /// The sensor stuck at a level (a rail, or a level past a threshold).
    Stuck { volts: f64, ms: u32 },
    /// The sensor's offset shifts by `volts` for a while, then back.
    Shift { volts: f64, ms: u32 },
    /// NaN samples.
    Dropout { ms: u32 },
    /// The process stalls: the next tick comes this much later.
    Stall { ticks: u64 },
}

fn segment() -> impl Strategy<Value = Segment> {
    let breath = prop::sample::select(vec![Breath::Sip, Breath::Puff]);
    prop_oneof![
        8 => (any::<prop::sample::Index>(), any::<bool>(), (breath, 20u32..4000), 0u32..2500)
            .prop_map(|(entry, quick, hold, rest)| Segment::Select { entry, quick, hold, rest }),
        1 => (prop::sample::select(vec![0.0, 5.0, 4.0, 1.0, 3.4, 1.6]), 500u32..9000)
            .prop_map(|(volts, ms)| Segment::Stuck { volts, ms }),
        1 => (prop::sample::select(vec![-0.7, 0.7, -1.2, 1.2]), 500u32..9000)
            .prop_map(|(volts, ms)| Segment::Shift { volts, ms }),
        1 => (1u32..400).prop_map(|ms| Segment::Dropout { ms }),
        1 => (2u64..3000).prop_map(|ticks| Segment::Stall { ticks }),
    ]
}

/// The samples of a session, each with how many ticks it comes after the
/// previous one (1, or more after a stall).
fn session_samples(config: &Config, segments: &[Segment], seed: u64) -> Vec<(u64, f64)> {
    let d = *config.core().detector();
    let params = SignalParams::clean(&d, seed)
        .with_noise(0.02)
        .with_hum(0.03);
    let comfortable = Timing {
        short_ms: (d.min_burst_ms + d.long_burst_ms) / 2,
        long_ms: d.long_burst_ms + 300,
        gap_ms: 300,
    };
    let quick = Timing {
        short_ms: d.min_burst_ms + d.glitch_ms + 5,
        gap_ms: d.glitch_ms + 40,
        ..comfortable
    };
    let mut out = Vec::new();
    let mut next_gap = 1;
    let push = |out: &mut Vec<(u64, f64)>, v: f64, gap: &mut u64| {
        out.push((*gap, v));
        *gap = 1;
    };
    for s in segments {
        match s {
            Segment::Select {
                entry,
                quick: fast,
                hold,
                rest,
            } => {
                let sequences = config.core().sequences();
                let actions = sequences[entry.index(sequences.len())].breaths().unwrap();
                let mut steps =
                    sequence_steps(actions.as_slice(), if *fast { quick } else { comfortable });
                steps.push(Step::Breath {
                    breath: hold.0,
                    ms: hold.1,
                });
                steps.push(Step::Rest { ms: *rest });
                for v in SignalGenerator::new(params, &steps) {
                    push(&mut out, v, &mut next_gap);
                }
            }
            Segment::Stuck { volts, ms } => {
                for _ in 0..*ms {
                    push(&mut out, *volts, &mut next_gap);
                }
            }
            Segment::Shift { volts, ms } => {
                let level = (d.neutral_volts + volts).clamp(0.0, 5.0);
                for _ in 0..*ms {
                    push(&mut out, level, &mut next_gap);
                }
            }
            Segment::Dropout { ms } => {
                for _ in 0..*ms {
                    push(&mut out, f64::NAN, &mut next_gap);
                }
            }
            Segment::Stall { ticks } => next_gap = *ticks,
        }
    }
    let short = MIN_SESSION_TICKS.saturating_sub(out.len());
    let rest = [Step::Rest {
        ms: u32::try_from(short).unwrap_or(u32::MAX),
    }];
    for v in SignalGenerator::new(params, &rest).take(short) {
        push(&mut out, v, &mut next_gap);
    }
    out
}

proptest! {
    // 24 sessions of 45–90 s: over a million ticks in all.
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// The safety promise: any configuration the validator accepts, any
    /// adversarial user (fast re-selections, long and stuck holds, offset
    /// shifts, dropouts, process stalls): at every tick the tool is inside
    /// the workspace by the margin as a normal distance and inside its
    /// orientation limits, speed, acceleration and jerk vectors within the
    /// limits, nothing non-finite, and still within the stopping time after
    /// every release and fault.
    #[test]
    fn the_safety_monitor_holds_for_any_config_and_any_user(
        config in valid_config(),
        segments in prop::collection::vec(segment(), 8..24),
        seed in any::<u64>(),
    ) {
        let mut core: Pipeline = Pipeline::new(config.core());
        let mut monitor = SafetyMonitor::new(config.core());
        let mut tick = 0u64;
        let samples = session_samples(&config, &segments, seed);
        prop_assert!(samples.len() >= MIN_SESSION_TICKS);
        for (gap, v) in samples {
            tick += gap;
            let out = core.tick(tick, v);
            if let Err(violation) = monitor.check(&out) {
                prop_assert!(false, "{}", violation);
            }
        }
    }
}

/// Each session is padded with rest to at least this many ticks: 24
/// sessions check over a million ticks.
const MIN_SESSION_TICKS: usize = 45_000;
