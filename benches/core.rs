//! Per-sample cost of the core, and the matcher's data structure chosen by
//! measurement.
//!
//! * `per_sample/*`: 10 s of noisy signal through the detector alone and
//!   through the whole core (detector → matcher → modes), against a
//!   reference measured in the same run: the bare threshold comparison
//!   every detector must make.
//! * `matcher_per_burst/{trie,scan}/{9,64,256}`: bursts entering every
//!   sequence of a prefix-free library in turn (the built-in 9; all 64
//!   sequences of 3 actions; all 256 of 4).

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use sipnpuff::action::{Action, ActionSeq};
use sipnpuff::config::{Config, SequenceEntry};
use sipnpuff::detector::{Burst, BurstDetector};
use sipnpuff::matcher::{ScanIndex, SequenceIndex, SequenceMatcher, TrieIndex};
use sipnpuff::modes::Mode;
use sipnpuff::pipeline::Core;
use sipnpuff::signal::{SignalGenerator, SignalParams, random_session};

fn noisy_signal(config: &Config) -> Vec<f64> {
    let mut params = SignalParams::clean(config.detector(), 5);
    params.noise_volts = 0.05;
    params.hum_volts = 0.1;
    params.spike_every_ms = 100;
    let (script, _) = random_session(config, 10, 5);
    SignalGenerator::new(params, &script).take(10_000).collect()
}

fn per_sample(c: &mut Criterion) {
    let config = Config::default();
    let samples = noisy_signal(&config);
    let mut group = c.benchmark_group("per_sample");
    group.throughput(Throughput::Elements(samples.len() as u64));

    let (low, high) = (
        config.detector().sip_threshold_volts,
        config.detector().puff_threshold_volts,
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

    let mut detector = BurstDetector::new(config.detector());
    let mut tick = 0u64;
    group.bench_function("detector", |b| {
        b.iter(|| {
            for &v in &samples {
                black_box(detector.step(tick, black_box(v)));
                tick += 1;
            }
        })
    });

    let mut core: Core = Core::new(&config);
    let mut tick = 0u64;
    group.bench_function("core", |b| {
        b.iter(|| {
            for &v in &samples {
                black_box(core.step(tick, black_box(v)));
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
            SequenceEntry {
                actions: ActionSeq::from_slice(&actions).unwrap(),
                mode: Mode::ALL[n % Mode::ALL.len()],
            }
        })
        .collect()
}

fn bench_matcher<I: SequenceIndex>(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    name: &str,
    library: &[SequenceEntry],
) {
    let bursts: Vec<Action> = library
        .iter()
        .flat_map(|e| e.actions.as_slice().to_vec())
        .collect();
    let mut matcher: SequenceMatcher<I> = SequenceMatcher::new(library, 1000);
    let mut end = 0u64;
    group.throughput(Throughput::Elements(bursts.len() as u64));
    group.bench_function(BenchmarkId::new(name, library.len()), |b| {
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
        Config::default().sequences().to_vec(),
        all_sequences(3),
        all_sequences(4),
    ];
    for library in &libraries {
        bench_matcher::<TrieIndex>(&mut group, "trie", library);
        bench_matcher::<ScanIndex>(&mut group, "scan", library);
    }
    group.finish();
}

criterion_group!(benches, per_sample, matcher_per_burst);
criterion_main!(benches);
