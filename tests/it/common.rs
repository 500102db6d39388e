//! Checks shared by the integration tests.

use sipnpuff::config::Config;
use sipnpuff::control::action::Breath;
use sipnpuff::control::event::Event;
use sipnpuff::control::mode::Mode;
use sipnpuff::control::motion::MotionEvent;
use sipnpuff::control::pipeline::Pipeline;
use sipnpuff::sim::sensor_model::Step;

/// Runs `samples` through a fresh core and checks it against the script
/// that made them: every scripted breath detected exactly once, in order,
/// as the right sip or puff, within `tolerance_ms` of its scripted length
/// and in the right length class (unless it lies within the tolerance of
/// the boundary); every selected mode matched, in order; no reset, no
/// fault, no burst invented. Returns the number of samples.
pub fn assert_session(
    config: &Config,
    samples: impl Iterator<Item = f64>,
    script: &[Step],
    modes: &[Mode],
    tolerance_ms: u64,
) -> u64 {
    let mut core: Pipeline = Pipeline::new(config.core());
    let mut bursts = Vec::new();
    let mut matched = Vec::new();
    let mut n = 0;
    for (t, v) in samples.enumerate() {
        for event in core.step(t as u64, v).events.iter() {
            match event {
                Event::Burst(b) => bursts.push(*b),
                Event::Match { mode, .. } => matched.push(*mode),
                Event::Reset { .. }
                | Event::Fault { .. }
                | Event::Recovered
                | Event::Rezeroed { .. }
                | Event::Motion(MotionEvent::TrajectoryError) => {
                    panic!("unexpected {event:?} at tick {t}")
                }
                Event::Detection { .. } | Event::Highlight { .. } | Event::Motion(_) => {}
            }
        }
        n += 1;
    }
    let scripted: Vec<(Breath, u64)> = script
        .iter()
        .filter_map(|s| match *s {
            Step::Breath { breath, ms } => Some((breath, u64::from(ms))),
            _ => None,
        })
        .collect();
    let long = u64::from(config.core().detector().long_burst_ms);
    assert_eq!(bursts.len(), scripted.len(), "bursts detected vs scripted");
    for (b, &(breath, ms)) in bursts.iter().zip(&scripted) {
        assert_eq!(b.action.breath(), breath, "{b:?}");
        assert!(
            b.duration_ms().abs_diff(ms) <= tolerance_ms,
            "{b:?} scripted {ms} ms"
        );
        if ms.abs_diff(long) > tolerance_ms {
            assert_eq!(b.action.is_long(), ms >= long, "{b:?} scripted {ms} ms");
        }
    }
    assert_eq!(matched, modes);
    n
}

/// A file in `fixtures/`.
pub fn fixture(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
}

/// The paper's example library (with prefixes) and its settings.
pub fn paper_config() -> Config {
    Config::from_file(&fixture("paper-example.toml")).expect("the paper's example config")
}
