//! The detector, tick by tick: bursts, glitches, drift, faults, re-zero.

use super::*;
use crate::control::sample::Sample::{Lost, Missing, Volts};

/// Everything a detector holds but the rest step's switch and count.
fn state(d: &BurstDetector) -> String {
    let mut d = d.clone();
    d.reference_path = false;
    d.rest_steps = SkipCount::default();
    format!("{d:?}")
}

/// A detector that takes the rest step and one that never does.
fn with_and_without_rest_step(config: &DetectorConfig) -> (BurstDetector, BurstDetector) {
    let mut whole = BurstDetector::new(config);
    whole.use_reference_path();
    (BurstDetector::new(config), whole)
}

proptest::proptest! {
    /// The rest step is the whole step: a detector that takes it and
    /// one that never does give the same output every tick and the
    /// same state (by `Debug`: the delay line and `-0.0` included),
    /// over runs of samples near the neutral, breaths, exact thresholds
    /// and range limits, NaN and infinities, on ticks that follow,
    /// repeat, skip and stall, with missing samples and a device gone.
    #[test]
    fn the_rest_step_is_the_whole_step(
        runs in proptest::collection::vec((
            proptest::prop_oneof![8 => proptest::strategy::Just(1u64), 1 => proptest::strategy::Just(0u64), 1 => 2u64..80],
            proptest::prop_oneof![
                6 => 2.2f64..2.8,
                2 => proptest::sample::select(vec![
                    3.0, 2.0, 2.9, 2.1, 3.8, 1.2, -0.5, 5.5, -0.6, 5.6, 0.0, -0.0, 5.0,
                    f64::NAN, f64::INFINITY, f64::NEG_INFINITY,
                ]),
                1 => -1.0f64..6.0,
            ],
            proptest::prop_oneof![3 => 1usize..4, 1 => 4usize..400],
            proptest::prop_oneof![
                10 => proptest::strategy::Just(None),
                1 => proptest::strategy::Just(Some(Missing)),
                1 => proptest::strategy::Just(Some(Lost)),
            ],
        ), 1..120),
        fast_tracking in proptest::bool::ANY,
    ) {
        let mut config = DetectorConfig::default();
        if fast_tracking {
            // The neutral follows closely: the thresholds move a lot.
            config.neutral_tracking_ms = 20;
            config.glitch_ms = 0;
        }
        let (mut fast, mut whole) = with_and_without_rest_step(&config);
        let mut tick = 0u64;
        for (delta, volts, repeat, no_sample) in runs {
            tick += delta;
            let sample = no_sample.unwrap_or(Volts(volts));
            for _ in 0..repeat {
                let (a, b) = (fast.step(tick, sample), whole.step(tick, sample));
                proptest::prop_assert_eq!(format!("{a:?}"), format!("{b:?}"), "tick {}", tick);
                tick += 1;
            }
            proptest::prop_assert_eq!(state(&fast), state(&whole));
        }
        proptest::prop_assert_eq!(whole.rest_steps(), 0);
    }
}

#[test]
fn a_day_at_rest_takes_the_rest_step() {
    let (mut fast, mut whole) = with_and_without_rest_step(&DetectorConfig::default());
    for t in 0..10_000 {
        // Noise about the neutral, inside the thresholds.
        let volts = 2.5 + 0.2 * ((t as f64) * 0.37).sin();
        assert_eq!(fast.step(t, Volts(volts)), whole.step(t, Volts(volts)));
    }
    assert_eq!(state(&fast), state(&whole));
    // All but the first sample (no tick before it).
    assert_eq!(fast.rest_steps(), 9_999);
}

/// Runs a detector over samples, returning (tick, event) pairs.
fn run(config: &DetectorConfig, samples: &[f64]) -> Vec<(Tick, DetectorEvent)> {
    let mut d = BurstDetector::new(config);
    samples
        .iter()
        .enumerate()
        .filter_map(|(t, &v)| d.step(t as Tick, Volts(v)).event.map(|e| (t as Tick, e)))
        .collect()
}

/// `rest` ms at 2.5 V, `len` ms at `level`, `after` ms at 2.5 V.
fn square(rest: usize, level: f64, len: usize, after: usize) -> Vec<f64> {
    let mut s = vec![2.5; rest];
    s.extend(std::iter::repeat_n(level, len));
    s.extend(std::iter::repeat_n(2.5, after));
    s
}

fn burst(action: Action, start: Tick, end: Tick) -> DetectorEvent {
    DetectorEvent::Burst(Burst { action, start, end })
}

#[test]
fn short_and_long_with_exact_durations() {
    let c = DetectorConfig::default(); // min 40, long 500, glitch 5
    // A 100 ms puff from tick 10: ends at 110, confirmed at 115.
    assert_eq!(
        run(&c, &square(10, 4.0, 100, 50)),
        [(115, burst(Action::ShortPuff, 10, 110))]
    );
    assert_eq!(
        run(&c, &square(10, 1.0, 500, 50)),
        [(515, burst(Action::LongSip, 10, 510))]
    );
    assert_eq!(
        run(&c, &square(10, 1.0, 499, 50)),
        [(514, burst(Action::ShortSip, 10, 509))]
    );
    assert_eq!(
        run(&c, &square(0, 4.0, 40, 50)),
        [(45, burst(Action::ShortPuff, 0, 40))]
    );
    assert_eq!(run(&c, &square(0, 4.0, 39, 50)), []);
}

#[test]
fn threshold_and_hysteresis() {
    let c = DetectorConfig::default(); // puff 3.0, hysteresis 0.1
    // Exactly at the threshold is not past it.
    assert_eq!(run(&c, &square(5, 3.0, 200, 50)), []);
    // Dropping to 2.95 is inside the hysteresis band: the puff goes on.
    let mut s = square(5, 3.5, 100, 0);
    s.extend(std::iter::repeat_n(2.95, 100));
    s.extend(std::iter::repeat_n(2.5, 50));
    assert_eq!(run(&c, &s), [(210, burst(Action::ShortPuff, 5, 205))]);
}

#[test]
fn sips_may_have_their_own_hysteresis() {
    // Strong puffs end 0.3 V back inside their threshold, weak sips 0.05 V.
    let c = DetectorConfig {
        hysteresis_volts: 0.3,
        sip_hysteresis_volts: Some(0.05),
        ..DetectorConfig::default()
    };
    // A puff that dips to 2.8 V (0.2 V inside) goes on.
    let mut s = square(5, 3.5, 100, 0);
    s.extend(std::iter::repeat_n(2.8, 100));
    s.extend(std::iter::repeat_n(2.5, 50));
    assert_eq!(run(&c, &s), [(210, burst(Action::ShortPuff, 5, 205))]);
    // A sip that comes back to 2.1 V (0.1 V inside) has ended.
    let mut s = square(5, 1.5, 100, 0);
    s.extend(std::iter::repeat_n(2.1, 100));
    assert_eq!(run(&c, &s), [(110, burst(Action::ShortSip, 5, 105))]);
    // Without its own, a sip shares the puff's 0.3 V and goes on.
    let shared = DetectorConfig {
        sip_hysteresis_volts: None,
        ..c
    };
    let mut s = square(5, 1.5, 100, 0);
    s.extend(std::iter::repeat_n(2.1, 100));
    s.extend(std::iter::repeat_n(2.5, 50));
    assert_eq!(run(&shared, &s), [(210, burst(Action::ShortSip, 5, 205))]);
}

#[test]
fn glitches_neither_create_nor_split_bursts() {
    let c = DetectorConfig::default();
    // Spikes of 1..=5 samples to both rails at rest: nothing.
    for len in 1..=5 {
        for level in [0.0, 5.0] {
            assert_eq!(run(&c, &square(20, level, len, 50)), [], "{len} at {level}");
        }
    }
    // The same spikes inside a long puff, and a dropout to 0 V: one burst.
    for len in 1..=5 {
        let mut s = square(10, 4.0, 300, 0);
        s[150..150 + len].fill(0.0);
        s[250..250 + len].fill(5.0);
        s.extend(std::iter::repeat_n(2.5, 50));
        assert_eq!(
            run(&c, &s),
            [(315, burst(Action::ShortPuff, 10, 310))],
            "{len}"
        );
    }
    // Six samples is longer than a glitch: the puff is split.
    let mut s = square(10, 4.0, 300, 0);
    s[150..156].fill(2.5);
    s.extend(std::iter::repeat_n(2.5, 50));
    assert_eq!(run(&c, &s).len(), 2);
}

#[test]
fn direct_reversal_ends_one_burst_and_starts_the_other() {
    let c = DetectorConfig::default();
    let mut s = square(10, 4.0, 100, 0);
    s.extend(std::iter::repeat_n(1.0, 100));
    s.extend(std::iter::repeat_n(2.5, 20));
    assert_eq!(
        run(&c, &s),
        [
            (115, burst(Action::ShortPuff, 10, 110)),
            (215, burst(Action::ShortSip, 110, 210)),
        ]
    );
}

#[test]
fn held_and_strength_follow_the_breath() {
    let c = DetectorConfig::default();
    let mut d = BurstDetector::new(&c);
    for t in 0..10 {
        assert_eq!(d.step(t, Volts(2.5)).held, Held::default());
    }
    let mut out = DetectorOutput::default();
    for t in 10..20 {
        out = d.step(t, Volts(3.7));
    }
    assert_eq!(out.held.breath, Some(Breath::Puff));
    assert!((out.held.strength_volts - 0.7).abs() < 1e-12);
    // A one-sample spike keeps the held state and its strength.
    let spike = d.step(20, Volts(0.0));
    assert_eq!(spike.held, out.held);
    assert!(spike.in_progress);
}

#[test]
fn slow_drift_neither_creates_nor_loses_bursts() {
    let c = DetectorConfig::default();
    let mut d = BurstDetector::new(&c);
    let mut bursts = 0;
    // +0.3 V over one minute, with a 150 ms puff of 0.9 V every 2 s.
    for t in 0..60_000u64 {
        let neutral = 2.5 + 0.3 * t as f64 / 60_000.0;
        let phase = t % 2000;
        let v = if (1000..1150).contains(&phase) {
            neutral + 0.9
        } else {
            neutral
        };
        if let Some(DetectorEvent::Burst(b)) = d.step(t, Volts(v)).event {
            assert_eq!(b.action, Action::ShortPuff);
            assert_eq!(b.duration_ms(), 150);
            bursts += 1;
        }
    }
    assert_eq!(bursts, 30);
    // An exponential tracker lags a ramp by rate × (τ + delay) =
    // 0.005 V/s × 1.1 s, a little more for the pauses during breaths.
    let lag = 2.8 - d.neutral_volts();
    assert!((0.005..0.008).contains(&lag), "lag {lag}");
    // Then back down −0.3 V below the start with sips.
    for t in 60_000..180_000u64 {
        let neutral = 2.8 - 0.6 * (t - 60_000) as f64 / 120_000.0;
        let phase = t % 2000;
        let v = if (1000..1150).contains(&phase) {
            neutral - 0.9
        } else {
            neutral
        };
        if let Some(DetectorEvent::Burst(b)) = d.step(t, Volts(v)).event {
            assert_eq!(b.action, Action::ShortSip);
            bursts += 1;
        }
    }
    assert_eq!(bursts, 90);
}

#[test]
fn neutral_is_tracked_at_rest_only() {
    let c = DetectorConfig::default();
    let mut d = BurstDetector::new(&c);
    // A 5 s breath, then a one-sample spike and the start of another
    // breath (crossings pending): none of it moves the neutral.
    for t in 0..5_000 {
        d.step(t, Volts(4.0));
    }
    for t in 5_000..5_100 {
        d.step(t, Volts(2.5));
    }
    assert_eq!(d.neutral_volts(), 2.5);
    d.step(5_100, Volts(0.0));
    for t in 5_101..5_104 {
        d.step(t, Volts(4.0));
    }
    assert_eq!(d.neutral_volts(), 2.5);
    // A resting level that moved by 0.2 V is followed with the
    // configured time constant: 1 − e⁻¹ of the way after 1 s.
    // Tracking starts once the signal has been at rest for twice the
    // delay; each tick then consumes the sample one delay old.
    let mut d = BurstDetector::new(&c);
    let start = 2 * TRACKING_DELAY_MS as u64;
    for t in 0..start + 1000 {
        d.step(t, Volts(2.7));
    }
    let followed = (d.neutral_volts() - 2.5) / 0.2;
    let expected = 1.0 - (1.0 - 1.0 / 1000.0f64).powi(1000);
    assert!((followed - expected).abs() < 1e-9, "{followed}");
}

#[test]
fn faults_are_never_bursts_and_recover_at_rest() {
    let c = DetectorConfig::default(); // recovery 250 ms, margin 0.5 V
    let mut s = square(10, 4.0, 100, 0); // puff in progress …
    s.push(f64::NAN); // … dropped by a fault
    s.extend(std::iter::repeat_n(4.0, 100));
    s.extend(std::iter::repeat_n(2.5, 300));
    let events = run(&c, &s);
    assert_eq!(
        events,
        [
            (110, DetectorEvent::Fault(FaultReason::NotANumber)),
            // At rest from 211; 250 samples later.
            (460, DetectorEvent::Recovered),
        ]
    );
    assert_eq!(
        run(&c, &[2.5, f64::INFINITY])[0].1,
        DetectorEvent::Fault(FaultReason::Infinite)
    );
    assert_eq!(
        run(&c, &[2.5, 5.6])[0].1,
        DetectorEvent::Fault(FaultReason::OutOfRange { volts: 5.6 })
    );
    assert_eq!(run(&c, &[5.5, -0.5, 0.0, 5.0]), []); // within the margin
}

#[test]
fn recovery_ignores_glitches_but_not_breaths() {
    let c = DetectorConfig::default(); // recovery 250 ms, glitch 5 ms
    // Spikes to the rails every 100 ms do not hold recovery off.
    let mut s = vec![f64::NAN];
    s.extend(std::iter::repeat_n(2.5, 400));
    for i in (60..400).step_by(100) {
        s[i] = 5.0;
    }
    assert_eq!(run(&c, &s)[1], (250, DetectorEvent::Recovered));
    // A breath (longer than a glitch) restarts the count.
    let mut s = vec![f64::NAN];
    s.extend(std::iter::repeat_n(2.5, 100));
    s.extend(std::iter::repeat_n(4.0, 6));
    s.extend(std::iter::repeat_n(2.5, 400));
    assert_eq!(run(&c, &s)[1], (356, DetectorEvent::Recovered));
}

#[test]
fn a_stale_sensor_faults_and_a_fresh_one_recovers() {
    let c = DetectorConfig::default(); // stale 50 ms, recovery 250 ms
    let mut d = BurstDetector::new(&c);
    for t in 0..100 {
        d.step(t, Volts(3.8)); // puff held …
    }
    for t in 100..149 {
        let out = d.step(t, Missing); // … then the sensor goes quiet
        assert_eq!(out.held.breath, Some(Breath::Puff), "held until stale");
        assert!(out.event.is_none());
    }
    let out = d.step(149, Missing);
    assert_eq!(
        out.event,
        Some(DetectorEvent::Fault(FaultReason::Stale { ms: 50 }))
    );
    assert!(out.faulted);
    assert_eq!(out.held, Held::default());
    assert_eq!(d.step(500, Missing).event, None, "one event per fault");
    let events: Vec<_> = (501..800)
        .filter_map(|t| d.step(t, Volts(2.5)).event)
        .collect();
    assert_eq!(events, [DetectorEvent::Recovered]);
    // Never a sample from start: stale too.
    let mut d = BurstDetector::new(&c);
    assert!(d.step(48, Missing).event.is_none());
    assert!(d.step(49, Missing).event.is_some());
}

#[test]
fn output_reports_fault_state() {
    let c = DetectorConfig::default();
    let mut d = BurstDetector::new(&c);
    let out = d.step(0, Volts(f64::NEG_INFINITY));
    assert!(out.faulted);
    assert_eq!(out.held, Held::default());
    assert!(
        d.step(1, Volts(f64::NAN)).event.is_none(),
        "one event per fault"
    );
}

#[test]
fn a_tick_that_does_not_increase_is_a_fault_not_an_overflow() {
    let c = DetectorConfig::default();
    let mut d = BurstDetector::new(&c);
    for t in 1000..1100 {
        d.step(t, Volts(3.8)); // a puff held
    }
    let out = d.step(5, Volts(3.8)); // time went back
    assert_eq!(
        out.event,
        Some(DetectorEvent::Fault(FaultReason::TickNotIncreasing {
            tick: 5,
            previous: 1099
        }))
    );
    assert!(out.faulted && out.held == Held::default());
    // The same tick again, and a missing sample at an earlier one: still
    // one fault (the sensor is in fault already), no panic.
    assert_eq!(d.step(5, Volts(2.5)).event, None);
    assert_eq!(d.step(3, Missing).event, None);
    // Time goes on from there: valid samples at rest recover.
    let recovered: Vec<_> = (6..400)
        .filter_map(|t| d.step(t, Volts(2.5)).event)
        .collect();
    assert_eq!(recovered, [DetectorEvent::Recovered]);
    assert_eq!(
        FaultReason::TickNotIncreasing {
            tick: 5,
            previous: 1099
        }
        .to_string(),
        "tick 5 is not after the previous tick 1099: the runtime's clock is broken"
    );
}

#[test]
fn a_breath_longer_than_max_hold_is_a_stuck_fault() {
    let c = DetectorConfig::default(); // max hold 6000 ms, re-zero 2000 ms
    // Held to the limit and one less: long bursts.
    assert_eq!(
        run(&c, &square(10, 4.0, 5999, 50)),
        [(6014, burst(Action::LongPuff, 10, 6009))]
    );
    assert_eq!(
        run(&c, &square(10, 4.0, 6000, 50)),
        [(6015, burst(Action::LongPuff, 10, 6010))]
    );
    // One more: stuck, on the tick it became longer, and no burst.
    let reason = FaultReason::Stuck {
        volts: 4.0,
        held_ms: 6000,
    };
    let stuck = DetectorEvent::Fault(reason);
    assert_eq!(
        run(&c, &square(10, 4.0, 6001, 500)),
        [(6010, stuck), (6011 + 249, DetectorEvent::Recovered)]
    );
    // A glitch pending at the limit delays the verdict by its length.
    let mut s = square(10, 4.0, 7000, 0);
    s[6010..6013].fill(2.5);
    assert_eq!(
        run(&c, &s)[0],
        (
            6013,
            DetectorEvent::Fault(FaultReason::Stuck {
                volts: 4.0,
                held_ms: 6003
            })
        )
    );
    assert_eq!(
        reason.to_string(),
        "breath held 6000 ms at 4.00 V, the limit detector.max_hold_ms sets — arm stopped: a breath as long as the settings allow (raise detector.max_hold_ms if it was meant), or the sensor stuck or its offset shifted"
    );
}

#[test]
fn a_steady_stuck_level_becomes_the_neutral_but_never_a_rail() {
    let c = DetectorConfig::default();
    // Stuck at 4.0 V: faulted at 6010; steady for 2000 ms after it,
    // and 4.0 + 0.5 + 0.1 < 5 V: the new neutral on tick 8010.
    let events = run(&c, &square(10, 4.0, 60_000, 0));
    assert_eq!(events.len(), 2, "{events:?}");
    assert_eq!(events[1].0, 8010);
    let DetectorEvent::Rezeroed {
        neutral_volts,
        previous_volts,
    } = events[1].1
    else {
        panic!("{events:?}")
    };
    assert!((neutral_volts - 4.0).abs() < 1e-12 && previous_volts == 2.5);
    // At a rail there is no room for a threshold: faulted for good.
    for rail in [5.0, 0.0] {
        let events = run(&c, &square(10, rail, 60_000, 0));
        assert_eq!(events.len(), 1, "{rail} V: {events:?}");
        assert!(matches!(
            events[0],
            (6010, DetectorEvent::Fault(FaultReason::Stuck { .. }))
        ));
    }
    // A level that wanders (±0.1 V at 0.5 Hz) is a breath, not an
    // offset: never re-zeroed; released, it recovers.
    let mut s = vec![2.5; 10];
    s.extend((0..20_000).map(|t| 4.0 + 0.1 * (std::f64::consts::PI * t as f64 / 1000.0).sin()));
    s.extend(std::iter::repeat_n(2.5, 300));
    let events = run(&c, &s);
    assert_eq!(events.len(), 2, "{events:?}");
    assert!(matches!(
        events[0].1,
        DetectorEvent::Fault(FaultReason::Stuck { .. })
    ));
    assert_eq!(events[1], (20_010 + 249, DetectorEvent::Recovered));
    // Another fault while waiting ends the chance to re-zero (the arm
    // stays stopped; rest recovers as after any fault).
    let mut s = square(10, 4.0, 7000, 0);
    s[7000] = f64::NAN;
    s.extend(std::iter::repeat_n(4.0, 10_000));
    assert_eq!(run(&c, &s).len(), 1);
}

#[test]
fn a_tick_jump_longer_than_stale_is_a_stall() {
    let c = DetectorConfig::default(); // stale 50 ms
    let mut d = BurstDetector::new(&c);
    for t in 0..600 {
        d.step(t, Volts(3.8)); // a puff held
    }
    // A gap of 50 ms (49 ticks missed) is not a stall; 51 ms is.
    assert_eq!(d.step(649, Volts(3.8)).event, None);
    let out = d.step(700, Volts(3.8));
    assert_eq!(
        out.event,
        Some(DetectorEvent::Fault(FaultReason::Stalled { ms: 51 }))
    );
    assert!(out.faulted && out.held == Held::default());
    // Seen on a tick without a sample too; then rest recovers.
    let mut d = BurstDetector::new(&c);
    d.step(0, Volts(2.5));
    assert_eq!(
        d.step(2000, Missing).event,
        Some(DetectorEvent::Fault(FaultReason::Stalled { ms: 2000 }))
    );
    let events: Vec<_> = (2001..2300)
        .filter_map(|t| d.step(t, Volts(2.5)).event)
        .collect();
    assert_eq!(events, [DetectorEvent::Recovered]);
    assert_eq!(
        FaultReason::Stalled { ms: 2000 }.to_string(),
        "the control loop stalled for 2000 ms (process stopped or machine paused): samples of the gap discarded — arm stopped"
    );
}
