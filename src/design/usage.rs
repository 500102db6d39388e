//! How often each library entry is selected: evenly, as the study's three
//! tasks select them, or as recordings of the person's own use did.
//! Counted mixes give every entry one selection more, so an entry never
//! seen still has a place that costs something.

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::control::selection::SequenceEntry;
use crate::control::target::Target;
use crate::sim::study::tasks::TASKS;
use crate::tools::recording::EVENTS;

/// Each entry's share of selections, in the library's order.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Usage {
    /// Where the shares come from, in words.
    pub source: String,
    /// Shares, summing to 1.
    pub shares: Vec<f64>,
    /// Selections counted (0 for the even mix).
    pub counted: u64,
    /// Matches of targets the library does not have.
    pub elsewhere: u64,
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
            "the mode changes of the study's three tasks",
            counts,
            elsewhere,
        )
    }

    /// The `match` events of recordings: each path is a recording (a
    /// directory with `events.jsonl`) or a directory of recordings.
    pub fn recordings(library: &[SequenceEntry], paths: &[PathBuf]) -> Result<Usage, String> {
        let mut files = Vec::new();
        for path in paths {
            if path.join(EVENTS).is_file() {
                files.push(path.join(EVENTS));
                continue;
            }
            let dir = std::fs::read_dir(path).map_err(|e| {
                format!(
                    "--usage {}: {e} (give a recording made with `run --record DIR`, or a directory of them)",
                    path.display()
                )
            })?;
            let mut inside: Vec<PathBuf> = dir
                .filter_map(|e| e.ok().map(|e| e.path().join(EVENTS)))
                .filter(|p| p.is_file())
                .collect();
            if inside.is_empty() {
                return Err(format!(
                    "--usage {}: no recording there (no {EVENTS} in it or in a directory inside it)",
                    path.display()
                ));
            }
            inside.sort();
            files.append(&mut inside);
        }
        let mut counts = vec![0u64; library.len()];
        let mut elsewhere = 0;
        for file in &files {
            read_matches(file, library, &mut counts, &mut elsewhere)?;
        }
        Ok(smoothed(
            &format!("the matches of {} recording(s)", files.len()),
            counts,
            elsewhere,
        ))
    }
}

/// Counts the `match` lines of one event log.
fn read_matches(
    file: &Path,
    library: &[SequenceEntry],
    counts: &mut [u64],
    elsewhere: &mut u64,
) -> Result<(), String> {
    let text = std::fs::read_to_string(file)
        .map_err(|e| format!("cannot read {}: {e}", file.display()))?;
    let targets: Vec<serde_json::Value> = library
        .iter()
        .map(|e| serde_json::to_value(e.target).unwrap_or_default())
        .collect();
    for (n, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let value: serde_json::Value = serde_json::from_str(line)
            .map_err(|e| format!("{} line {}: not JSON ({e})", file.display(), n + 1))?;
        if value.get("event").and_then(|v| v.as_str()) != Some("match") {
            continue;
        }
        let same = |t: &serde_json::Value| {
            t.as_object()
                .is_some_and(|t| t.iter().all(|(k, v)| value.get(k) == Some(v)))
        };
        match targets.iter().position(same) {
            Some(i) => counts[i] += 1,
            None => *elsewhere += 1,
        }
    }
    Ok(())
}

fn count(counts: &mut [u64], elsewhere: &mut u64, library: &[SequenceEntry], target: Target) {
    match library.iter().position(|e| e.target == target) {
        Some(i) => counts[i] += 1,
        None => *elsewhere += 1,
    }
}

/// Shares of counts plus one each.
fn smoothed(source: &str, counts: Vec<u64>, elsewhere: u64) -> Usage {
    let counted: u64 = counts.iter().sum();
    let total = (counted + counts.len() as u64).max(1) as f64;
    Usage {
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
    fn a_recording_counts_its_matches() {
        let config = Config::default();
        let library = config.core().sequences();
        let dir = std::env::temp_dir().join(format!("sipnpuff-usage-{}", std::process::id()));
        let rec = dir.join("one");
        std::fs::create_dir_all(&rec).unwrap();
        std::fs::copy(
            concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/demo.events.jsonl"),
            rec.join(EVENTS),
        )
        .unwrap();
        let usage = Usage::recordings(library, std::slice::from_ref(&dir)).unwrap();
        let matches = std::fs::read_to_string(rec.join(EVENTS))
            .unwrap()
            .lines()
            .filter(|l| l.contains("\"match\""))
            .count() as u64;
        assert_eq!(usage.counted + usage.elsewhere, matches);
        assert!(usage.counted > 0);
        let _ = std::fs::remove_dir_all(&dir);
        assert!(Usage::recordings(library, &[dir]).is_err());
    }
}
