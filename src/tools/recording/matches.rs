//! The `match` events of recordings, read for the designer's usage mix
//! (`design --usage DIR…`): each path is a recording (a directory with
//! `events.jsonl`) or a directory of recordings.

use std::path::{Path, PathBuf};

use crate::tools::recording::EVENTS;

/// The `match` events found, as the JSON objects `run` wrote.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Matches {
    /// Recordings read.
    pub recordings: usize,
    /// Their `match` events, in order.
    pub events: Vec<serde_json::Value>,
}

/// Reads the `match` events of the recordings in `paths`. The error says
/// which path or line is wrong and what to give instead.
pub fn read_matches(paths: &[PathBuf]) -> Result<Matches, String> {
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
    let mut events = Vec::new();
    for file in &files {
        read_file(file, &mut events)?;
    }
    Ok(Matches {
        recordings: files.len(),
        events,
    })
}

/// Appends the `match` lines of one event log to `events`.
fn read_file(file: &Path, events: &mut Vec<serde_json::Value>) -> Result<(), String> {
    let text = std::fs::read_to_string(file)
        .map_err(|e| format!("cannot read {}: {e}", file.display()))?;
    for (n, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let value: serde_json::Value = serde_json::from_str(line)
            .map_err(|e| format!("{} line {}: not JSON ({e})", file.display(), n + 1))?;
        if value.get("event").and_then(|v| v.as_str()) == Some("match") {
            events.push(value);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_directory_of_recordings_gives_their_matches_in_order() {
        let dir = std::env::temp_dir().join(format!("sipnpuff-matches-{}", std::process::id()));
        let demo = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/demo.events.jsonl");
        for name in ["a", "b"] {
            std::fs::create_dir_all(dir.join(name)).unwrap();
            std::fs::copy(demo, dir.join(name).join(EVENTS)).unwrap();
        }
        let in_demo = std::fs::read_to_string(demo)
            .unwrap()
            .lines()
            .filter(|l| l.contains("\"event\":\"match\""))
            .count();
        let found = read_matches(std::slice::from_ref(&dir)).unwrap();
        assert_eq!(found.recordings, 2);
        assert_eq!(found.events.len(), 2 * in_demo);
        assert!(in_demo > 0);
        let one = read_matches(&[dir.join("a")]).unwrap();
        assert_eq!((one.recordings, one.events.len()), (1, in_demo));
        let _ = std::fs::remove_dir_all(&dir);
        let gone = read_matches(std::slice::from_ref(&dir)).unwrap_err();
        assert!(
            gone.starts_with(&format!("--usage {}: ", dir.display())),
            "{gone}"
        );
    }
}
