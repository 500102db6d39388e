//! Stress tests with synthetic burst signals: scripted users on the seeded
//! generator at the edges of what the detector must handle: bursts at the
//! length boundaries, fast trains, ten-second holds (longer than
//! `max_hold_ms`: each one stuck fault, never a burst), noise σ = 0.1 V,
//! 50 Hz hum of 0.2 V, a rail spike every 100 ms (inside bursts too),
//! neutral drift of 0.5 V a minute, breaths saturating at 0 and 5 V, and
//! NaN dropouts. More than 10 million ticks in all (the lower bounds the
//! tests assert add up to 10.3 million), each through the whole core
//! (detector, matcher, modes, motion). Every scripted burst must be
//! detected exactly once as the right action, every scripted selection
//! matched (or reset, where the script says so), no burst invented, and
//! `Pipeline::step` must not allocate.

use std::f64::consts::PI;

use sipnpuff::config::Config;
use sipnpuff::control::action::Breath;
use sipnpuff::rt::alloc_counter::thread_allocations;
use sipnpuff::tools::accuracy::{SessionTally, observe, score};

use crate::common::paper_config;
use sipnpuff::control::mode::Mode;
use sipnpuff::sim::script::{Timing, UserStyle, random_session, random_session_with};
use sipnpuff::sim::sensor_model::{SignalParams, Step};

/// What a script should make of the core besides its bursts and selections.
#[derive(Debug, Clone, Copy, Default)]
struct Expect {
    resets: u64,
    /// Every fault (each recovered).
    faults: u64,
    /// Of those, breaths held longer than `max_hold_ms`.
    stuck: u64,
}

/// Plays the script through a fresh core and demands a perfect score for
/// the actions; `tolerance_ms` bounds the timing error. Returns the tally.
fn assert_perfect(
    what: &str,
    config: &Config,
    params: SignalParams,
    script: &[Step],
    modes: &[Mode],
    tolerance_ms: u64,
    expect: Expect,
) -> SessionTally {
    let seen = observe(config, params, script);
    let t = score(config, &seen, modes, tolerance_ms);
    let context = format!("{what} (seed {}): {t:?}", params.seed);
    assert!(t.scripted > 0, "{context}");
    assert_eq!(
        t.correct, t.scripted,
        "every burst, the right action: {context}"
    );
    assert_eq!(t.mistimed, 0, "timing within {tolerance_ms} ms: {context}");
    assert_eq!(t.invented, 0, "no burst invented: {context}");
    assert_eq!(t.selections_matched, t.selections, "selections: {context}");
    assert_eq!(t.selections_extra, 0, "no selection invented: {context}");
    assert_eq!(t.resets, expect.resets, "resets: {context}");
    assert_eq!(t.faults, expect.faults, "faults: {context}");
    assert_eq!(t.recoveries, expect.faults, "recoveries: {context}");
    assert_eq!(t.stuck_faults, expect.stuck, "stuck faults: {context}");
    assert_eq!(t.rezeroes, 0, "a wandering breath re-zeroed: {context}");
    assert_eq!(t.core_allocations, 0, "Pipeline::step allocated: {context}");
    t
}

/// [`assert_perfect`] with the timing bound the signal allows.
fn assert_noisy_session(
    what: &str,
    config: &Config,
    params: SignalParams,
    script: &[Step],
    modes: &[Mode],
    expect: Expect,
) -> SessionTally {
    let bound = timing_bound_ms(config, &params);
    assert_perfect(what, config, params, script, modes, bound, expect)
}

/// The worst signal the detector is asked to handle.
fn harsh(config: &Config, seed: u64) -> SignalParams {
    SignalParams {
        // 0.5 V amplitude, at most 0.5 V a minute: the sine's steepest
        // slope 2π·A/T equals 0.5 V per 60 000 ms.
        drift_period_ms: 2.0 * PI * 60_000.0,
        ..SignalParams::clean(config.core().detector(), seed)
            .with_noise(0.1)
            .with_hum(0.2)
            .with_spikes_every(100)
            .with_drift(0.5)
    }
}

/// How far noise and hum can move a threshold crossing: their worst
/// excursion (hum + 3σ) over the slowest crossing slope of a breath (the
/// lowest plateau over the longest ramp), plus the glitch filter's window.
/// The harsh signal gives 30 ms.
fn timing_bound_ms(config: &Config, p: &SignalParams) -> u64 {
    let lowest = p.breath_volts * (1.0 - p.breath_jitter);
    let slowest_slope = lowest * PI / (2.0 * p.ramp_ms.1); // V per ms
    let excursion = p.hum_volts + 3.0 * p.noise_volts;
    (excursion / slowest_slope).ceil() as u64 + u64::from(config.core().detector().glitch_ms)
}

/// Breaths that reach the rails: the plateau is clamped at 0 V (sip) or
/// 5 V (puff).
fn saturating(mut p: SignalParams) -> SignalParams {
    p.breath_volts = 3.2;
    p.breath_jitter = 0.05;
    p
}

/// The harsh signal; on even seeds with saturating breaths too.
fn harsh_and_every_other_saturating(config: &Config, seed: u64) -> SignalParams {
    if seed.is_multiple_of(2) {
        saturating(harsh(config, seed))
    } else {
        harsh(config, seed)
    }
}

#[test]
fn the_harsh_timing_bound_is_30_ms() {
    let _cpu = crate::common::cpu_heavy();
    let config = Config::default();
    assert_eq!(timing_bound_ms(&config, &harsh(&config, 0)), 30);
}

#[test]
fn the_counter_sees_allocations() {
    let _cpu = crate::common::cpu_heavy();
    let before = thread_allocations();
    drop(std::hint::black_box(vec![0u8; 16]));
    assert_eq!(thread_allocations() - before, 1);
}

/// Lengths around `min_burst_ms` and `long_burst_ms` on a clean signal,
/// where the generator places every threshold crossing exactly: a breath
/// below the minimum makes no burst, one at it makes a short one, and the
/// long class starts exactly at `long_burst_ms`. Each stands alone and is
/// reset at the sequence timeout (no single-burst entry in the library).
#[test]
fn boundary_lengths_are_classified_to_the_millisecond() {
    let _cpu = crate::common::cpu_heavy();
    let config = Config::default();
    let d = config.core().detector();
    let mut lengths = Vec::new();
    for k in 1..=5 {
        lengths.extend([d.min_burst_ms - k, d.min_burst_ms + k]);
        lengths.extend([d.long_burst_ms - k, d.long_burst_ms + k]);
    }
    lengths.extend([d.min_burst_ms, d.long_burst_ms]);
    let rest = config.core().matcher().sequence_timeout_ms + 300;
    let mut ticks = 0;
    for seed in 0..12 {
        let mut script = vec![Step::Rest { ms: 500 }];
        for breath in [Breath::Puff, Breath::Sip] {
            for &ms in &lengths {
                script.push(Step::Breath { breath, ms });
                script.push(Step::Rest { ms: rest });
            }
        }
        let bursts = 2 * lengths.iter().filter(|&&ms| ms >= d.min_burst_ms).count() as u64;
        let t = assert_perfect(
            "boundary lengths",
            &config,
            SignalParams::clean(d, seed),
            &script,
            &[],
            0,
            Expect {
                resets: bursts,
                ..Expect::default()
            },
        );
        assert_eq!(t.too_short, 10, "{t:?}");
        ticks += t.ticks;
    }
    assert!(ticks >= 700_000, "{ticks} ticks");
}

/// One random session of `seconds` in `style` per seed, on the signal
/// `signal` makes for the seed, each held to [`assert_noisy_session`];
/// returns the ticks played.
fn random_sessions(
    what: &str,
    config: &Config,
    seeds: std::ops::Range<u64>,
    seconds: u64,
    style: UserStyle,
    signal: fn(&Config, u64) -> SignalParams,
) -> u64 {
    seeds
        .map(|seed| {
            let (script, modes) = random_session_with(config, seconds, seed, style);
            let params = signal(config, seed);
            assert_noisy_session(what, config, params, &script, &modes, Expect::default()).ticks
        })
        .sum()
}

/// Five short bursts a second (100 ms breaths, 100 ms gaps) and long ones
/// of 600 ms, through both libraries, on the harsh signal.
#[test]
fn fast_trains_on_a_harsh_signal() {
    let _cpu = crate::common::cpu_heavy();
    let style = UserStyle {
        timing: Timing {
            short_ms: 100,
            long_ms: 600,
            gap_ms: 100,
        },
        hold_ms: (200, 1500),
    };
    let ticks = random_sessions("fast trains", &Config::default(), 0..6, 400, style, harsh)
        + random_sessions("fast trains", &paper_config(), 6..10, 400, style, harsh);
    assert!(ticks >= 4_000_000, "{ticks} ticks");
}

/// Ten-second holds in command mode, half of the sessions with breaths
/// saturating at the rails. A hold longer than `max_hold_ms` (6 s) is a
/// stuck sensor: each is exactly one stuck fault and never a burst, and
/// (the breath wanders, as a person's does) never re-zeroed; releasing
/// recovers. The user rests long enough after each hold to recover before
/// the next, so every hold begins while detecting.
#[test]
fn ten_second_holds_and_saturation() {
    let _cpu = crate::common::cpu_heavy();
    let config = Config::default();
    let d = config.core().detector();
    let style = UserStyle {
        hold_ms: (10_000, 10_000),
        ..UserStyle::for_detector(d)
    };
    let mut ticks = 0;
    for seed in 20..26 {
        let (session, modes) = random_session_with(&config, 500, seed, style);
        let mut script = Vec::new();
        let mut long_holds = 0;
        let mut after_long = false;
        for step in session {
            script.push(match step {
                Step::Rest { ms } if after_long => Step::Rest {
                    ms: ms.max(d.fault_recovery_ms + 300),
                },
                other => other,
            });
            after_long = matches!(step, Step::Breath { ms, .. } if ms > d.max_hold_ms);
            long_holds += u64::from(after_long);
        }
        // Held breaths wander by ±0.1 V, as a person's do.
        let params = harsh_and_every_other_saturating(&config, seed).with_wander(0.1);
        let t = assert_noisy_session(
            "ten-second holds",
            &config,
            params,
            &script,
            &modes,
            Expect {
                faults: long_holds,
                stuck: long_holds,
                ..Expect::default()
            },
        );
        assert_eq!(t.too_long, long_holds, "{t:?}");
        assert!(long_holds >= 20, "{long_holds} long holds");
        ticks += t.ticks;
    }
    assert!(ticks >= 3_000_000, "{ticks} ticks");
}

/// Runs of NaN between selections: each is one fault and one recovery,
/// and the user goes on as before.
#[test]
fn nan_dropouts_fault_and_recover() {
    let _cpu = crate::common::cpu_heavy();
    let config = Config::default();
    let recovery = config.core().detector().fault_recovery_ms;
    let dropouts = [1, 2, 5, 20, 100, 1000, 5000];
    let mut ticks = 0;
    for seed in 30..38 {
        let (session, modes) = random_session(&config, 300, seed);
        // After each wait for detection mode (the longest rests), a dropout
        // and a rest long enough to recover.
        let longest = session
            .iter()
            .filter_map(|s| match s {
                Step::Rest { ms } => Some(*ms),
                _ => None,
            })
            .filter(|&ms| ms >= config.core().command().inactivity_timeout_ms)
            .min()
            .expect("waits for detection mode");
        let mut script = Vec::new();
        let mut inserted = 0;
        for step in session {
            script.push(step);
            if matches!(step, Step::Rest { ms } if ms >= longest) {
                script.push(Step::Dropout {
                    ms: dropouts[inserted % dropouts.len()],
                });
                script.push(Step::Rest { ms: recovery + 500 });
                inserted += 1;
            }
        }
        let params = harsh_and_every_other_saturating(&config, seed);
        let t = assert_noisy_session(
            "NaN dropouts",
            &config,
            params,
            &script,
            &modes,
            Expect {
                faults: inserted as u64,
                ..Expect::default()
            },
        );
        assert!(inserted >= dropouts.len(), "{inserted} dropouts");
        ticks += t.ticks;
    }
    assert!(ticks >= 2_600_000, "{ticks} ticks");
}
