//! How often each library entry is selected: evenly, as the study's three
//! tasks select them, or as recordings of the person's own use did.
//! Counted mixes give every entry one selection more, so an entry never
//! seen still has a place that costs something.

use serde::Serialize;

use crate::control::selection::SequenceEntry;
use crate::control::target::Target;
use crate::sim::study::tasks::TASKS;

/// Each entry's share of selections, in the library's order.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Usage {
    /// Which mix this is.
    pub kind: UsageKind,
    /// Where the shares come from, in words.
    pub source: String,
    /// Shares, summing to 1.
    pub shares: Vec<f64>,
    /// Selections counted (0 for the even mix).
    pub counted: u64,
    /// Matches of targets the library does not have.
    pub elsewhere: u64,
}

/// Where a usage comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum UsageKind {
    /// Every entry as often.
    Uniform,
    /// The study's tasks' mode changes: the usage the study measures.
    Tasks,
    /// The person's recordings.
    Recorded,
}

/// Which usage mix.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Default)]
pub enum Mix {
    /// Every entry as often.
    #[default]
    Uniform,
    /// As the study's three tasks change mode.
    Tasks,
}

impl Usage {
    /// Every entry as often.
    pub fn uniform(library: &[SequenceEntry]) -> Usage {
        let n = library.len().max(1) as f64;
        Usage {
            kind: UsageKind::Uniform,
            source: "every entry as often".into(),
            shares: vec![1.0 / n; library.len()],
            counted: 0,
            elsewhere: 0,
        }
    }

    /// The mode changes of the study's three tasks, once each.
    pub fn tasks(library: &[SequenceEntry]) -> Usage {
        let mut counts = vec![0u64; library.len()];
        let mut elsewhere = 0;
        for mode in TASKS.iter().flat_map(|t| t.mode_changes()) {
            count(&mut counts, &mut elsewhere, library, Target::Mode(mode));
        }
        smoothed(
            UsageKind::Tasks,
            "the mode changes of the study's three tasks",
            counts,
            elsewhere,
        )
    }

    /// As the person selected them: `matches` are the `match` events of
    /// `recordings` recordings of their own use, as `run` wrote them.
    pub fn recorded(
        library: &[SequenceEntry],
        matches: &[serde_json::Value],
        recordings: usize,
    ) -> Usage {
        let targets: Vec<serde_json::Value> = library
            .iter()
            .map(|e| serde_json::to_value(e.target).unwrap_or_default())
            .collect();
        let mut counts = vec![0u64; library.len()];
        let mut elsewhere = 0;
        for event in matches {
            let same = |t: &serde_json::Value| {
                t.as_object()
                    .is_some_and(|t| t.iter().all(|(k, v)| event.get(k) == Some(v)))
            };
            match targets.iter().position(same) {
                Some(i) => counts[i] += 1,
                None => elsewhere += 1,
            }
        }
        smoothed(
            UsageKind::Recorded,
            &format!("the matches of {recordings} recording(s)"),
            counts,
            elsewhere,
        )
    }
}

fn count(counts: &mut [u64], elsewhere: &mut u64, library: &[SequenceEntry], target: Target) {
    match library.iter().position(|e| e.target == target) {
        Some(i) => counts[i] += 1,
        None => *elsewhere += 1,
    }
}

/// Shares of counts plus one each.
fn smoothed(kind: UsageKind, source: &str, counts: Vec<u64>, elsewhere: u64) -> Usage {
    let counted: u64 = counts.iter().sum();
    let total = (counted + counts.len() as u64).max(1) as f64;
    Usage {
        kind,
        source: format!("{source} ({counted} selections, each entry one more)"),
        shares: counts.iter().map(|c| (c + 1) as f64 / total).collect(),
        counted,
        elsewhere,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;

    #[test]
    fn the_tasks_change_mode_33_times() {
        let config = Config::default();
        let library = config.core().sequences();
        let usage = Usage::tasks(library);
        assert_eq!(usage.counted, 33);
        assert_eq!(usage.elsewhere, 0);
        assert!((usage.shares.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        // save_point and goto_point are never used: one of 42 each.
        let save = library
            .iter()
            .position(|e| e.target == Target::Mode(crate::control::mode::Mode::SavePoint))
            .unwrap();
        assert!((usage.shares[save] - 1.0 / 42.0).abs() < 1e-12);
    }

    #[test]
    fn recorded_matches_count_for_their_entries_and_others_apart() {
        let config = Config::default();
        let library = config.core().sequences();
        let target = |t: Target| {
            let mut event = serde_json::json!({"tick": 7, "event": "match", "sequence": [-1]});
            for (k, v) in serde_json::to_value(t).unwrap().as_object().unwrap() {
                event[k] = v.clone();
            }
            event
        };
        let first = library[0].target;
        let matches = [
            target(first),
            target(first),
            target(Target::Click(crate::control::target::Click::Left)),
        ];
        let usage = Usage::recorded(library, &matches, 2);
        assert_eq!((usage.counted, usage.elsewhere), (2, 1));
        let n = library.len() as f64;
        assert!((usage.shares[0] - 3.0 / (2.0 + n)).abs() < 1e-12);
        assert!((usage.shares[1] - 1.0 / (2.0 + n)).abs() < 1e-12);
        assert_eq!(
            usage.source,
            "the matches of 2 recording(s) (2 selections, each entry one more)"
        );
    }
}
