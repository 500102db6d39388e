//! Checks shared by the integration tests.

use sipnpuff::action::Breath;
use sipnpuff::config::Config;
use sipnpuff::event::Event;
use sipnpuff::modes::Mode;
use sipnpuff::motion::MotionEvent;
use sipnpuff::pipeline::Core;
use sipnpuff::signal::Step;

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
    let mut core: Core = Core::new(config);
    let mut bursts = Vec::new();
    let mut matched = Vec::new();
    let mut n = 0;
    for (t, v) in samples.enumerate() {
        for event in core.step(t as u64, v).events.iter() {
            match event {
                Event::Burst(b) => bursts.push(*b),
                Event::Match { mode, .. } => matched.push(*mode),
                Event::Reset { .. }
                | Event::Fault(_)
                | Event::Recovered
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
    let long = u64::from(config.detector().long_burst_ms);
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
