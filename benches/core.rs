//! Per-sample cost of the core and of its stages.
//!
//! * `per_sample/*`: 10 s of noisy signal through the detector alone, the
//!   mode machine alone (fed what the core's detector and matcher made of
//!   the same signal) and the whole core (detector → matcher → modes →
//!   motion), against a reference measured in the same run: the bare
//!   threshold comparison every detector must make.
//! * `matcher_per_burst/{9,64,256}`: bursts entering every sequence of a
//!   prefix-free library in turn (the built-in 9; all 64 sequences of 3
//!   actions; all 256 of 4): the CS compared with the whole library.
//! * `ruckig/*`: one `rsruckig` update of six degrees of freedom (more
//!   than a motion channel holds): velocity interface steady (same target)
//!   and on a new target every update; position interface (go to point) on
//!   a new target.
//! * `tick/*`: one full tick (detector → matcher → modes → Ruckig →
//!   100 Hz decimation → simulated arm): at rest (no breath, the arm
//!   still; against one sample's bare threshold test); steady, holding a
//!   puff in `translate_x` (after a few thousand iterations the tool
//!   stands at the edge of its reach, the held request refused every
//!   tick); and on a new target every tick (sip and puff alternating
//!   each sample, glitch filter off).
//! * `replay/*`: `sipnpuff replay` end to end on 60 s of noisy recording
//!   (CSV parsing, core, simulated arm, JSON events to a sink) against the
//!   core alone and the CSV reading alone on the same samples.
//! * `gesture/*`: the tick that classifies a segment (`Recognizer::step`
//!   on the tick its end is confirmed), with 10 gestures × 5 templates:
//!   `classify_worst_case`, a segment of `MAX_FRAMES` frames against 50
//!   templates as long, each nearer than the one before so LB_Keogh
//!   prunes none and no DTW abandons; `classify_typical`, a nod against
//!   examples of ten head gestures; against `step_at_rest`, one tick
//!   with nothing to classify.
//! * `design/*`: `design --check`'s analysis of a library for the study's
//!   user (the built-in 9 entries; 12 entries with prefixes), against one
//!   simulated participant doing the study's first task (the unit a
//!   study or a search's verification is made of).

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use sipnpuff::arm::sim::SimulatedJaco;
use sipnpuff::config::Config;
use sipnpuff::control::action::{Action, ActionSeq};
use sipnpuff::control::detector::{Burst, BurstDetector};
use sipnpuff::control::event::Event;
use sipnpuff::control::mode::{Held, Mode};
use sipnpuff::control::modes::ModeMachine;
use sipnpuff::control::pipeline::Pipeline;
use sipnpuff::control::sample::Sample;
use sipnpuff::control::selection::SequenceEntry;
use sipnpuff::control::selection::matcher::{MatcherConfig, SequenceMatcher};
use sipnpuff::control::tick::{TickInput, TickOutput};
use sipnpuff::sensor::csv::CsvSignal;
use sipnpuff::sim::script::random_session;
use sipnpuff::sim::sensor_model::{SignalGenerator, SignalParams, write_csv};
use sipnpuff::tools::csv_replay::replay;

fn noisy_signal(config: &Config) -> Vec<f64> {
    let params = SignalParams::clean(config.core().detector(), 5)
        .with_noise(0.05)
        .with_hum(0.1)
        .with_spikes_every(100);
    let (script, _) = random_session(config, 10, 5);
    SignalGenerator::new(params, &script).take(10_000).collect()
}

fn per_sample(c: &mut Criterion) {
    let config = Config::default();
    let samples = noisy_signal(&config);
    let mut group = c.benchmark_group("per_sample");
    group.throughput(Throughput::Elements(samples.len() as u64));

    let (low, high) = (
        config.core().detector().sip_threshold_volts,
        config.core().detector().puff_threshold_volts,
    );
    group.bench_function("reference_threshold_compare", |b| {
        b.iter(|| {
            let mut past = 0u32;
            for &v in &samples {
                past += u32::from(black_box(v) > high || v < low);
            }
            black_box(past)
        })
    });

    let mut detector = BurstDetector::new(config.core().detector());
    let mut tick = 0u64;
    group.bench_function("detector", |b| {
        b.iter(|| {
            for &v in &samples {
                black_box(detector.step(tick, black_box(Sample::Volts(v))));
                tick += 1;
            }
        })
    });

    // What the mode machine sees of this signal, tick by tick.
    let mut core = Pipeline::new(config.core());
    let mut out = TickOutput::default();
    let inputs: Vec<(Held, Option<Mode>, bool)> = samples
        .iter()
        .enumerate()
        .map(|(t, &v)| {
            core.step(&TickInput::volts(t as u64, v), &mut out);
            let matched = out.events.iter().find_map(|e| match e {
                Event::Match { target, .. } => target.mode(),
                _ => None,
            });
            (out.held, matched, out.faulted)
        })
        .collect();
    assert!(
        inputs.iter().any(|i| i.1.is_some()),
        "a selection in the signal"
    );
    let mut modes = ModeMachine::new(config.core().command());
    let mut tick = 0u64;
    group.bench_function("mode_machine", |b| {
        b.iter(|| {
            for &(held, matched, faulted) in &inputs {
                black_box(modes.step(tick, black_box(held), matched, faulted));
                tick += 1;
            }
        })
    });

    let mut core = Pipeline::new(config.core());
    let mut tick = 0u64;
    group.bench_function("core", |b| {
        b.iter(|| {
            for &v in &samples {
                core.step(&TickInput::new(tick, black_box(Sample::Volts(v))), &mut out);
                black_box(&out);
                tick += 1;
            }
        })
    });
    group.finish();
}

/// Every sequence of `len` actions, each selecting some mode.
fn all_sequences(len: u32) -> Vec<SequenceEntry> {
    (0..4usize.pow(len))
        .map(|n| {
            let actions: Vec<Action> = (0..len)
                .map(|i| Action::ALL[(n / 4usize.pow(i)) % 4])
                .collect();
            SequenceEntry::mode(
                ActionSeq::from_slice(&actions).unwrap(),
                Mode::ALL[n % Mode::ALL.len()],
            )
        })
        .collect()
}

fn bench_matcher(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    library: &[SequenceEntry],
) {
    let bursts: Vec<Action> = library
        .iter()
        .flat_map(|e| e.breaths().unwrap().as_slice().to_vec())
        .collect();
    let mut matcher = SequenceMatcher::new(
        library,
        &MatcherConfig {
            sequence_timeout_ms: 1000,
        },
    );
    let mut end = 0u64;
    group.throughput(Throughput::Elements(bursts.len() as u64));
    group.bench_function(BenchmarkId::from_parameter(library.len()), |b| {
        b.iter(|| {
            for &action in &bursts {
                end += 200;
                let burst = Burst {
                    action,
                    start: end - 100,
                    end,
                };
                black_box(matcher.on_burst(black_box(&burst)));
                black_box(matcher.on_tick(end, false));
            }
        })
    });
}

fn matcher_per_burst(c: &mut Criterion) {
    let mut group = c.benchmark_group("matcher_per_burst");
    let libraries = [
        Config::default().core().sequences().to_vec(),
        all_sequences(3),
        all_sequences(4),
    ];
    for library in &libraries {
        bench_matcher(&mut group, library);
    }
    group.finish();
}

fn ruckig_updates(c: &mut Criterion) {
    use rsruckig::prelude::*;
    let mut group = c.benchmark_group("ruckig");
    let limits = |input: &mut InputParameter<6>| {
        for i in 0..6 {
            let (v, a, j) = if i < 3 {
                (0.2, 0.64, 3.2)
            } else {
                (1.07, 2.75, 14.0)
            };
            input.max_velocity[i] = v;
            input.max_acceleration[i] = a;
            input.max_jerk[i] = j;
        }
    };
    let new = |interface, sync| {
        let mut input = InputParameter::<6>::new(None);
        input.control_interface = interface;
        input.synchronization = sync;
        limits(&mut input);
        (
            Ruckig::<6, ThrowErrorHandler>::new(None, 0.001),
            input,
            OutputParameter::<6>::new(None),
        )
    };

    let (mut otg, mut input, mut output) = new(ControlInterface::Velocity, Synchronization::None);
    input.target_velocity[0] = 0.2;
    for _ in 0..1000 {
        otg.update(&input, &mut output).unwrap();
        output.pass_to_input(&mut input);
    }
    group.bench_function("velocity_steady", |b| {
        b.iter(|| {
            black_box(otg.update(black_box(&input), &mut output).unwrap());
            output.pass_to_input(&mut input);
        })
    });

    let (mut otg, mut input, mut output) = new(ControlInterface::Velocity, Synchronization::None);
    let mut sign = 1.0;
    group.bench_function("velocity_new_target", |b| {
        b.iter(|| {
            sign = -sign;
            input.target_velocity[0] = 0.2 * sign;
            input.target_velocity[4] = 1.0 * sign;
            black_box(otg.update(black_box(&input), &mut output).unwrap());
            output.pass_to_input(&mut input);
        })
    });

    let (mut otg, mut input, mut output) = new(ControlInterface::Position, Synchronization::Time);
    let mut sign = 1.0;
    group.bench_function("position_new_target", |b| {
        b.iter(|| {
            sign = -sign;
            for i in 0..6 {
                input.target_position[i] = sign * (0.1 + 0.05 * i as f64);
            }
            black_box(otg.update(black_box(&input), &mut output).unwrap());
            output.pass_to_input(&mut input);
        })
    });
    group.finish();
}

/// A core (and arm) in `translate_x` command mode, after `warm_up` ticks.
fn in_translate_x(config: &Config) -> (Pipeline, SimulatedJaco, u64) {
    let mut core = Pipeline::new(config.core());
    let mut arm = SimulatedJaco::new(config.core());
    let mut out = TickOutput::default();
    let mut tick = 0u64;
    // Two short puffs select translate_x in the built-in library.
    let mut feed = |volts: f64, ms: u64, core: &mut Pipeline, arm: &mut SimulatedJaco| {
        for _ in 0..ms {
            core.step(&TickInput::volts(tick, volts), &mut out);
            arm.tick(out.motion.arm_command.as_ref());
            tick += 1;
        }
    };
    for (volts, ms) in [(2.5, 200), (3.8, 150), (2.5, 300), (3.8, 150), (2.5, 400)] {
        feed(volts, ms, &mut core, &mut arm);
    }
    (core, arm, tick)
}

fn full_tick(c: &mut Criterion) {
    let mut group = c.benchmark_group("tick");
    let config = Config::default();
    // The in-run reference: one sample's bare threshold test.
    let (low, high) = (
        config.core().detector().sip_threshold_volts,
        config.core().detector().puff_threshold_volts,
    );
    let mut volts = 2.5;
    group.bench_function("reference_threshold_compare", |b| {
        b.iter(|| {
            volts = black_box(volts);
            black_box(volts > high || volts < low)
        })
    });

    // At rest: no breath, the arm still, nothing asked (most of a day).
    let mut core = Pipeline::new(config.core());
    let mut out = TickOutput::default();
    let mut tick = 0u64;
    for _ in 0..5000 {
        core.step(&TickInput::volts(tick, 2.5), &mut out);
        tick += 1;
    }
    group.bench_function("at_rest", |b| {
        b.iter(|| {
            core.step(
                &TickInput::new(tick, black_box(Sample::Volts(2.5))),
                &mut out,
            );
            tick += 1;
            black_box(&out);
        })
    });

    let (mut core, mut arm, mut tick) = in_translate_x(&config);
    // Into steady forward motion (0.2 m/s after 0.51 s).
    for _ in 0..1000 {
        core.step(&TickInput::volts(tick, 3.8), &mut out);
        tick += 1;
    }
    group.bench_function("steady", |b| {
        b.iter(|| {
            core.step(
                &TickInput::new(tick, black_box(Sample::Volts(3.8))),
                &mut out,
            );
            arm.tick(out.motion.arm_command.as_ref());
            tick += 1;
            black_box(&out);
        })
    });

    let config = Config::from_toml_str("[detector]\nglitch_ms = 0\n").unwrap();
    let (mut core, mut arm, mut tick) = in_translate_x(&config);
    group.bench_function("new_target", |b| {
        b.iter(|| {
            let volts = if tick % 2 == 0 { 3.8 } else { 1.2 };
            core.step(
                &TickInput::new(tick, black_box(Sample::Volts(volts))),
                &mut out,
            );
            debug_assert!(out.motion.recalculated);
            arm.tick(out.motion.arm_command.as_ref());
            tick += 1;
            black_box(&out);
        })
    });
    group.finish();
}

fn replay_throughput(c: &mut Criterion) {
    let config = Config::default();
    let params = SignalParams::clean(config.core().detector(), 9)
        .with_noise(0.03)
        .with_hum(0.05);
    let (script, _) = random_session(&config, 60, 9);
    let samples: Vec<f64> = SignalGenerator::new(params, &script).take(60_000).collect();
    let mut csv = Vec::new();
    write_csv(&mut csv, samples.iter().copied()).expect("CSV in memory");
    let mut group = c.benchmark_group("replay");
    group.throughput(Throughput::Elements(samples.len() as u64));
    group.sample_size(20);
    group.bench_function("core_only", |b| {
        b.iter(|| {
            let mut core = Pipeline::new(config.core());
            let mut out = TickOutput::default();
            for (t, &v) in samples.iter().enumerate() {
                core.step(&TickInput::volts(t as u64, v), &mut out);
                black_box(&out);
            }
        })
    });
    group.bench_function("csv_only", |b| {
        b.iter(|| {
            let mut signal = CsvSignal::new(csv.as_slice()).expect("header");
            let mut sum = 0.0;
            while let Some(v) = signal.next_sample().expect("a sample") {
                sum += v;
            }
            black_box(sum)
        })
    });
    group.bench_function("csv_core_arm_json", |b| {
        b.iter(|| {
            let mut signal = CsvSignal::new(csv.as_slice()).expect("header");
            let summary =
                replay(config.core(), &mut signal, &mut std::io::sink(), None).expect("replay");
            black_box(summary)
        })
    });
    group.finish();
}

fn design(c: &mut Criterion) {
    use sipnpuff::design::analysis::{AttemptTiming, analyse};
    use sipnpuff::design::breathing::Breathing;
    use sipnpuff::design::usage::Usage;
    use sipnpuff::sim::study::tasks::TASKS;
    use sipnpuff::sim::user::{UserModel, run_task};
    let config = Config::default();
    let who = Breathing::of_model(&UserModel::POPULATION, config.core().detector(), "study");
    let timing = AttemptTiming::of(&who, &config, None);
    let mut group = c.benchmark_group("design");
    group.bench_function("reference_study_task_run", |b| {
        b.iter(|| black_box(run_task(&config, &TASKS[0], &UserModel::POPULATION, 7)))
    });
    let builtin = config.core().sequences().to_vec();
    let mut twelve = builtin.clone();
    for (actions, mode) in [
        (
            &[Action::ShortSip, Action::ShortSip, Action::ShortSip][..],
            Mode::PointerX,
        ),
        (
            &[Action::ShortSip, Action::ShortSip, Action::ShortPuff][..],
            Mode::PointerY,
        ),
        (
            &[Action::ShortSip, Action::ShortPuff, Action::ShortSip][..],
            Mode::Scroll,
        ),
    ] {
        twelve.push(SequenceEntry::mode(
            ActionSeq::from_slice(actions).unwrap(),
            mode,
        ));
    }
    for (name, library) in [
        ("analyse_9", &builtin),
        ("analyse_12_with_prefixes", &twelve),
    ] {
        let usage = Usage::uniform(library);
        group.bench_function(name, |b| {
            b.iter(|| black_box(analyse(library, &who, &usage, &timing)))
        });
    }
    group.finish();
}

/// A recognizer one tick before it classifies the segment of `samples`
/// (stepping every tick, samples held), and that tick.
fn primed(
    recognizer: &sipnpuff::control::gesture::Recognizer,
    samples: &[(u64, sipnpuff::control::imu::ImuSample)],
) -> (sipnpuff::control::gesture::Recognizer, u64) {
    let mut probe = recognizer.clone();
    let mut next = samples.iter().peekable();
    let mut held = Vec::new();
    let last = samples.last().map_or(0, |s| s.0);
    let end = (0..=last)
        .find(|&tick| {
            let sample = next.next_if(|s| s.0 == tick).map(|s| s.1);
            held.push(sample);
            probe.step(tick, sample.as_ref()).is_some()
        })
        .expect("the recording holds a segment");
    let mut primed = recognizer.clone();
    for (tick, sample) in held.iter().enumerate().take(end as usize) {
        primed.step(tick as u64, sample.as_ref());
    }
    (primed, end)
}

fn gesture(c: &mut Criterion) {
    use criterion::BatchSize;
    use sipnpuff::control::gesture::{
        GestureConfig, GestureId, GestureTemplates, MAX_FRAMES, Recognizer, segments,
    };
    use sipnpuff::sim::head::{Head, HeadScript, Move, Noise, example_templates, ten_gestures};

    let config = GestureConfig {
        max_ms: GestureConfig::default().frame_ms * MAX_FRAMES as u32,
        ..GestureConfig::default()
    };
    let mut group = c.benchmark_group("gesture");

    // Worst case: a segment of MAX_FRAMES frames (a slow tilt's,
    // stretched) against 50 templates as long, each a little nearer than
    // the one before: LB_Keogh prunes none and no DTW abandons. Timed as
    // `classify` (the classifying tick is this plus one segmenter step,
    // `step_at_rest`).
    let tilt = Move::new(Head::TiltLeft).varied(0.3, 1.5).held(0);
    let script = HeadScript::new().rest(1000).then(tilt).rest(1000);
    let cut = segments(&config, script.samples(10, Noise::TYPICAL, 3));
    let frames = &cut.first().expect("a segment").frames;
    let query: Vec<_> = (0..MAX_FRAMES)
        .map(|i| frames[i * frames.len() / MAX_FRAMES])
        .collect();
    let mut templates = GestureTemplates::new();
    for k in 0..50u8 {
        let offset = 0.5 - 0.009 * f32::from(k);
        let shifted: Vec<_> = query
            .iter()
            .map(|f| {
                let mut f = *f;
                f[0] += offset;
                f
            })
            .collect();
        templates.add(GestureId(k / 5), &shifted).unwrap();
    }
    for g in 0..10 {
        templates.set_threshold(GestureId(g), 1.0);
    }
    let worst = Recognizer::new(config, templates).unwrap();
    eprintln!(
        "gesture: worst case: {} frames against 50 × {} (a tilt's segment: {} frames)",
        query.len(),
        MAX_FRAMES,
        frames.len()
    );
    group.bench_function("classify_worst_case", |b| {
        b.iter(|| black_box(worst.classify(black_box(&query))))
    });

    // Typical: a nod against examples of ten head gestures.
    let set = example_templates(&config, &ten_gestures(), 5, 0.6, 500);
    let typical = Recognizer::new(config, set).unwrap();
    let script = HeadScript::new()
        .rest(1000)
        .then(Move::new(Head::Nod))
        .rest(1000);
    let samples = script.samples(10, Noise::TYPICAL, 4);
    let (primed_typical, end) = primed(&typical, &samples);
    group.bench_function("classify_typical", |b| {
        b.iter_batched_ref(
            || primed_typical.clone(),
            |r| black_box(r.step(end, None)),
            BatchSize::SmallInput,
        )
    });

    let mut at_rest = typical.clone();
    let mut tick = 0u64;
    let still = samples[0].1;
    group.bench_function("step_at_rest", |b| {
        b.iter(|| {
            tick += 1;
            black_box(at_rest.step(tick, Some(black_box(&still))))
        })
    });
    group.finish();
}

criterion_group!(
    benches,
    gesture,
    design,
    per_sample,
    matcher_per_burst,
    ruckig_updates,
    full_tick,
    replay_throughput
);
criterion_main!(benches);
