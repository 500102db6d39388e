//! A breath held too long is a stuck sensor, and a stall of the process
//! is a fault, both seen through the whole pipeline.

use crate::common::TickByTick;
use sipnpuff::config::Config;
use sipnpuff::control::action::Action;
use sipnpuff::control::detector::FaultReason;
use sipnpuff::control::event::{Event, TimedEvent};
use sipnpuff::control::mode::{Mode, ModeState};
use sipnpuff::control::modes::DetectionReason;
use sipnpuff::control::pipeline::Pipeline;
use sipnpuff::control::target::Target;
use sipnpuff::control::tick::TickOutput;
use sipnpuff::sim::sensor_model::{SignalGenerator, SignalParams, Step};

/// Steps a pipeline sample by sample, keeping every event with its tick.
struct Run {
    core: Pipeline,
    tick: u64,
    events: Vec<(u64, Event)>,
    last: Option<TickOutput>,
}

impl Run {
    fn new(config: &Config) -> Run {
        Run {
            core: Pipeline::new(config.core()),
            tick: 0,
            events: Vec::new(),
            last: None,
        }
    }

    /// `ms` samples at `volts`; `check` sees every output.
    fn hold_with(&mut self, volts: f64, ms: u64, mut check: impl FnMut(&TickOutput)) {
        for _ in 0..ms {
            let out = self.core.tick(self.tick, volts);
            self.events
                .extend(out.events.iter().map(|e| (self.tick, *e)));
            check(&out);
            self.last = Some(out);
            self.tick += 1;
        }
    }

    fn hold(&mut self, volts: f64, ms: u64) {
        self.hold_with(volts, ms, |_| {});
    }

    /// Rest, then two long puffs: rotate_z (`[-2, -2]`), the mode that
    /// turned 64 rad in a minute.
    fn enter_rotate_z(&mut self) {
        self.hold(2.5, 1000);
        self.hold(4.0, 800);
        self.hold(2.5, 300);
        self.hold(4.0, 800);
        self.hold(2.5, 300);
        assert!(
            self.events.iter().any(|(_, e)| matches!(
                e,
                Event::Match {
                    target: Target::Mode(Mode::RotateZ),
                    ..
                }
            )),
            "{:?}",
            self.events
        );
        self.events.clear();
    }

    fn speed(&self) -> f64 {
        let m = self.last.as_ref().unwrap().motion;
        m.linear
            .iter()
            .chain(&m.angular)
            .map(|v| v * v)
            .sum::<f64>()
            .sqrt()
    }
}

/// Turning for the whole 6 s of `max_hold_ms` without reaching the twist
/// limit: 0.4 rad/s (a jerk that keeps hold-to-run at that speed) and the
/// widest twist range, 170°.
fn turning_config() -> Config {
    Config::from_toml_str(
        "[motion]\nangular_speed_radps = 0.4\nangular_jerk_radps3 = 100.0\n[workspace]\nmax_twist_rad = 2.967\n",
    )
    .unwrap()
}

/// A sensor stuck at 4.0 V, 5 V or 0 V while rotating: a fault at exactly
/// the breath's start + `max_hold_ms` (6000 by default), command mode
/// left, no burst, and the commanded motion brakes to zero and stays
/// there for the rest of the minute.
#[test]
fn a_stuck_sensor_is_a_fault_at_max_hold_and_the_arm_stops() {
    let config = turning_config();
    for stuck in [4.0, 5.0, 0.0] {
        let mut run = Run::new(&config);
        run.enter_rotate_z();
        let start = run.tick;
        let (mut last_moving, mut speed_before_fault) = (None, 0.0);
        run.hold_with(stuck, 60_000, |out| {
            let m = out.motion;
            let speed = m
                .linear
                .iter()
                .chain(&m.angular)
                .map(|v| v * v)
                .sum::<f64>();
            if speed > 0.0 {
                last_moving = Some(out.tick);
            }
            if out.tick == start + 5999 {
                speed_before_fault = speed.sqrt();
            }
        });
        let faults: Vec<_> = run
            .events
            .iter()
            .filter(|(_, e)| matches!(e, Event::Fault { .. }))
            .collect();
        assert_eq!(faults.len(), 1, "{stuck} V: {:?}", run.events);
        assert_eq!(faults[0].0, start + 6000, "{stuck} V: {:?}", run.events);
        assert!(
            run.events.contains(&(
                start + 6000,
                Event::Detection {
                    reason: DetectionReason::Fault
                }
            )),
            "{stuck} V: {:?}",
            run.events
        );
        assert!(
            !run.events.iter().any(|(_, e)| matches!(e, Event::Burst(_))),
            "{stuck} V: {:?}",
            run.events
        );
        // Turning at full speed until the fault, then braking through
        // Ruckig (well under a second from 0.4 rad/s), then still to the end.
        assert!(speed_before_fault > 0.39, "{stuck} V: {speed_before_fault}");
        let last_moving = last_moving.expect("it moved");
        assert!(
            (start + 6000..start + 7000).contains(&last_moving),
            "{stuck} V: last moving at {last_moving}, fault at {}",
            start + 6000
        );
        assert_eq!(run.speed(), 0.0);
        assert_eq!(
            run.last.unwrap().command.state,
            ModeState::Detection,
            "{stuck} V"
        );
    }
}

fn bursts(events: &[(u64, Event)]) -> Vec<(u64, Action, u64)> {
    events
        .iter()
        .filter_map(|(t, e)| match e {
            Event::Burst(b) => Some((*t, b.action, b.duration_ms())),
            _ => None,
        })
        .collect()
}

/// The sensor's offset shifts by 0.7 V (2.5 → 3.2 V) within a sample while
/// rotating: a puff held for ever. Stuck at start + 6000, the arm brakes
/// and stays still; the level is steady, so 2000 ms later it is the new
/// neutral, and breaths around it are detected as usual (the thresholds
/// moved by their offsets: puffs above 3.7 V, sips below 2.7 V).
#[test]
fn an_offset_shift_faults_then_rezeroes_and_detection_resumes() {
    let config = turning_config();
    let mut run = Run::new(&config);
    run.enter_rotate_z();
    let start = run.tick;
    let mut moved_after = None;
    run.hold_with(3.2, 9000, |out| {
        let m = out.motion;
        if out.tick > start + 7000 && m.angular.iter().chain(&m.linear).any(|v| *v != 0.0) {
            moved_after = Some(out.tick);
        }
    });
    assert_eq!(moved_after, None, "still after braking");
    let fault = start + 6000;
    assert!(matches!(
        run.events[0],
        (t, Event::Fault { reason: FaultReason::Stuck { held_ms: 6000, .. } }) if t == fault
    ));
    assert_eq!(
        run.events[1],
        (
            fault,
            Event::Detection {
                reason: DetectionReason::Fault
            }
        )
    );
    let (
        tick,
        Event::Rezeroed {
            neutral_volts,
            previous_volts,
        },
    ) = run.events[2]
    else {
        panic!("{:?}", run.events)
    };
    assert_eq!(tick, fault + 2000);
    assert!((neutral_volts - 3.2).abs() < 1e-9 && previous_volts == 2.5);
    assert_eq!(run.events.len(), 3, "{:?}", run.events);
    assert!((run.core.detector().neutral_volts() - 3.2).abs() < 1e-9);
    let line: serde_json::Value = serde_json::to_value(TimedEvent {
        tick,
        event: run.events[2].1,
    })
    .unwrap();
    assert_eq!(line["event"], "rezeroed", "{line}");
    assert!((line["neutral_volts"].as_f64().unwrap() - 3.2).abs() < 1e-9);
    assert_eq!(line["previous_volts"], 2.5);
    run.events.clear();

    // Around the new neutral: a short puff to 4.2 V and a short sip to
    // 2.4 V; a dip to 2.9 V (a puff-sized breath before) is rest now.
    run.hold(4.2, 150);
    run.hold(3.2, 300);
    run.hold(2.4, 150);
    run.hold(3.2, 1500);
    run.hold(2.9, 150);
    run.hold(3.2, 1500);
    let t0 = start + 9000;
    assert_eq!(
        bursts(&run.events),
        [
            (t0 + 155, Action::ShortPuff, 150),
            (t0 + 605, Action::ShortSip, 150),
        ]
    );
    // And the mode is entered again with two long puffs, and moves.
    run.events.clear();
    run.hold(4.2, 800);
    run.hold(3.2, 300);
    run.hold(4.2, 800);
    run.hold(3.2, 300);
    assert!(run.events.iter().any(|(_, e)| matches!(
        e,
        Event::Match {
            target: Target::Mode(Mode::RotateZ),
            ..
        }
    )));
    run.hold(4.2, 1000);
    assert!(run.speed() > 0.39, "{}", run.speed());
}

/// The same shift on the stress suite's harsh signal (noise σ = 0.1 V,
/// 0.2 V of 50 Hz hum, a rail spike every 100 ms, drift of 0.5 V a
/// minute): stuck, then re-zeroed exactly `rezero_ms` after the fault
/// (every 100 ms window steady), for every seed.
#[test]
fn an_offset_shift_on_the_harsh_signal_rezeroes() {
    let config = Config::default();
    for seed in 0..8 {
        let params = SignalParams {
            drift_period_ms: 2.0 * std::f64::consts::PI * 60_000.0,
            ..SignalParams::clean(config.core().detector(), seed)
                .with_noise(0.1)
                .with_hum(0.2)
                .with_spikes_every(100)
                .with_drift(0.5)
        };
        let script = [Step::Rest { ms: 20_000 }];
        let shift_at = 2000;
        let samples = SignalGenerator::new(params, &script)
            .enumerate()
            .map(|(t, v)| {
                // Spikes stay at their rail.
                if t < shift_at || v == 0.0 || v == 5.0 {
                    v
                } else {
                    (v + 0.7).clamp(0.0, 5.0)
                }
            });
        let samples: Vec<f64> = samples.collect();
        let mut core: Pipeline = Pipeline::new(config.core());
        let mut events = Vec::new();
        for (t, &v) in samples.iter().enumerate() {
            events.extend(core.tick(t as u64, v).events.iter().map(|e| (t as u64, *e)));
        }
        let fault = events
            .iter()
            .find(|(_, e)| matches!(e, Event::Fault { .. }))
            .unwrap_or_else(|| panic!("seed {seed}: {events:?}"))
            .0;
        // Noise moves the first crossing by a few ms.
        assert!(
            fault.abs_diff(shift_at as u64 + 6000) <= 30,
            "seed {seed}: {events:?}"
        );
        let rezero = events
            .iter()
            .find_map(|(t, e)| match e {
                Event::Rezeroed { neutral_volts, .. } => Some((*t, neutral_volts)),
                _ => None,
            })
            .unwrap_or_else(|| panic!("seed {seed}: {events:?}"));
        assert_eq!(rezero.0, fault + 2000, "seed {seed}");
        // The level of the 2 s before, drift included (0.5 V · sin(t / 60 s)).
        let drift = 0.5 * ((rezero.0 - 1000) as f64 / 60_000.0).sin();
        assert!(
            (rezero.1 - 3.2 - drift).abs() < 0.02,
            "seed {seed}: {} {drift}",
            rezero.1
        );
        assert!(
            !events.iter().any(|(_, e)| matches!(e, Event::Burst(_))),
            "seed {seed}: {events:?}"
        );
    }
}

/// A puff held 1500 ms in rotate_z, then the process stalls: the next tick
/// comes 2000 ms later, the puff still held, and the user goes on. The gap
/// is a fault on resumption (saying how long it was), the puff is dropped
/// (never a 3500 ms burst), command mode ends, the motion brakes to zero,
/// and the signal at rest recovers after `fault_recovery_ms`.
#[test]
fn a_stall_is_a_fault_on_resumption_and_nothing_is_stretched_across_it() {
    let config = turning_config();
    let mut run = Run::new(&config);
    run.enter_rotate_z();
    run.hold(4.0, 1500);
    assert!(run.speed() > 0.39, "turning before the stall");
    let resumed = run.tick + 1999; // one tick after the last, 2000 ms later
    run.tick = resumed;
    run.hold(4.0, 300); // still puffing after the gap
    run.hold(2.5, 1000);
    run.hold(4.0, 150); // the user's next breaths
    run.hold(2.5, 300);
    run.hold(4.0, 150);
    run.hold(2.5, 2000);
    let fault = run
        .events
        .iter()
        .find(|(_, e)| matches!(e, Event::Fault { .. }))
        .unwrap_or_else(|| panic!("no fault: {:?}", run.events));
    assert_eq!(fault.0, resumed, "{:?}", run.events);
    let Event::Fault { reason } = fault.1 else {
        unreachable!()
    };
    assert!(
        reason.to_string().contains("stalled for 2000 ms"),
        "{reason}"
    );
    assert!(run.events.contains(&(
        resumed,
        Event::Detection {
            reason: DetectionReason::Fault
        }
    )));
    // Rest from resumed + 300; 250 samples later.
    assert!(
        run.events
            .contains(&(resumed + 300 + 249, Event::Recovered)),
        "{:?}",
        run.events
    );
    // No burst but the user's two short puffs after recovery, which select
    // nothing (translate_x needs them, and gets them: detection mode).
    let found = bursts(&run.events);
    assert_eq!(found.len(), 2, "{found:?}");
    assert!(
        found
            .iter()
            .all(|(_, a, ms)| *a == Action::ShortPuff && *ms == 150)
    );
    // Motion: braking after the fault, still well before the puffs.
    let mut check = Run::new(&config);
    check.enter_rotate_z();
    check.hold(4.0, 1500);
    check.tick += 1999;
    let mut last_moving = 0;
    check.hold_with(4.0, 2000, |out| {
        if out
            .motion
            .angular
            .iter()
            .chain(&out.motion.linear)
            .any(|v| *v != 0.0)
        {
            last_moving = out.tick;
        }
        assert_eq!(out.command.state, ModeState::Detection);
    });
    assert!(
        last_moving < check.tick - 1000,
        "still moving at {last_moving}"
    );
    assert_eq!(check.speed(), 0.0);
}

/// A profile's `max_hold_ms = 1000` with breaths held 1.5 s and 1.4 s:
/// the production loop counts two breaths held too long (the run's
/// report and exit status say them), and the fault's words name the
/// setting.
#[test]
fn breaths_held_past_max_hold_are_counted_by_the_loop_and_named() {
    use sipnpuff::control::action::Breath;
    use sipnpuff::rt::control_loop::SensorFaults;
    use sipnpuff::rt::simulated::run_simulated;
    use sipnpuff::sensor::Sensor;
    use sipnpuff::sim::synthetic_sensor::SyntheticSensor;

    let config = Config::from_toml_str("[detector]\nmax_hold_ms = 1000\n").unwrap();
    let script = vec![
        Step::Rest { ms: 3000 },
        Step::Breath {
            breath: Breath::Puff,
            ms: 1500,
        },
        Step::Rest { ms: 2000 },
        Step::Breath {
            breath: Breath::Puff,
            ms: 1400,
        },
        Step::Rest { ms: 2000 },
        Step::Breath {
            breath: Breath::Puff,
            ms: 300,
        },
        Step::Rest { ms: 2000 },
    ];
    let params = SignalParams::clean(config.core().detector(), 1);
    let sensor = SyntheticSensor::new(params, script).start().unwrap();
    let run = run_simulated(config.core(), sensor.samples);
    assert_eq!(
        run.faults,
        SensorFaults {
            held_too_long: 2,
            ..SensorFaults::default()
        }
    );
    let reason = FaultReason::Stuck {
        volts: 3.66,
        held_ms: 1000,
    };
    assert_eq!(
        reason.to_string(),
        "breath held 1000 ms at 3.66 V, the limit detector.max_hold_ms sets — arm stopped: a breath as long as the settings allow (raise detector.max_hold_ms if it was meant), or the sensor stuck or its offset shifted"
    );
}

/// A sensor read tick by tick from a list: each entry is a count of ticks
/// and what they read.
struct Plugged {
    plan: Vec<(u64, sipnpuff::control::sample::Sample)>,
    at: usize,
    left: u64,
}

impl Plugged {
    fn new(plan: &[(u64, sipnpuff::control::sample::Sample)]) -> Plugged {
        Plugged {
            plan: plan.to_vec(),
            at: 0,
            left: plan[0].0,
        }
    }
}

impl sipnpuff::sensor::Samples for Plugged {
    fn try_read(&mut self, _skipped: u64) -> sipnpuff::sensor::Reading {
        while self.left == 0 && self.at + 1 < self.plan.len() {
            self.at += 1;
            self.left = self.plan[self.at].0;
        }
        if self.left == 0 {
            return sipnpuff::sensor::Reading::default();
        }
        self.left -= 1;
        sipnpuff::sensor::Reading {
            sample: self.plan[self.at].1,
            ..sipnpuff::sensor::Reading::default()
        }
    }

    fn discard_backlog(&mut self, _skipped: u64) -> u64 {
        0
    }

    fn ended(&self) -> bool {
        self.left == 0 && self.at + 1 == self.plan.len()
    }
}

#[test]
fn a_disconnection_the_sensor_comes_back_from_is_counted_as_reconnected() {
    use sipnpuff::control::sample::Sample::{Lost, Volts};
    use sipnpuff::rt::control_loop::SensorFaults;
    use sipnpuff::rt::simulated::run_simulated;

    let config = Config::default();
    let rest = Volts(config.core().detector().neutral_volts);
    let back = run_simulated(
        config.core(),
        Plugged::new(&[(2000, rest), (500, Lost), (3000, rest)]),
    );
    assert_eq!(
        back.faults,
        SensorFaults {
            disconnected: 1,
            reconnected: 1,
            ..SensorFaults::default()
        }
    );
    assert_eq!(back.faults.failing(), 0);

    let gone = run_simulated(config.core(), Plugged::new(&[(2000, rest), (3000, Lost)]));
    assert_eq!(
        gone.faults,
        SensorFaults {
            disconnected: 1,
            ..SensorFaults::default()
        }
    );
    assert_eq!(gone.faults.failing(), 1);
}
