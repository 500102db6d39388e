//! Selecting a mode: `[matcher]`, `[command]`, `[scanning]` and the
//! `[[sequence]]` library.

use std::collections::HashSet;

use crate::config::error::Problems;
use crate::control::core_config::CoreConfig;
use crate::control::modes::CommandConfig;
use crate::control::selection::matcher::MatcherConfig;
use crate::control::selection::scanning::ScanningConfig;
use crate::control::selection::{Interface, SequenceEntry};
use crate::control::target::Target;

/// Largest library the matcher accepts.
pub const MAX_SEQUENCES: usize = 256;

/// `[matcher]`.
pub(super) fn matcher(p: &mut Problems, c: &MatcherConfig) {
    p.positive_ms("matcher.sequence_timeout_ms", c.sequence_timeout_ms);
}

/// `[command]`: `motion_onset_ms` is 0 (off) or a timer.
pub(super) fn command(p: &mut Problems, c: &CommandConfig) {
    p.positive_ms("command.inactivity_timeout_ms", c.inactivity_timeout_ms);
    if c.motion_onset_ms > 0 {
        p.positive_ms("command.motion_onset_ms", c.motion_onset_ms);
    }
}

/// `[scanning]`: positive dwell times, each mode at most once, at least one.
pub(super) fn scanning(p: &mut Problems, c: &ScanningConfig) {
    p.positive_ms("scanning.dwell_ms", c.dwell_ms);
    p.positive_ms("scanning.first_dwell_ms", c.first_dwell_ms);
    if c.order_len > c.order.len() {
        p.add(
            "scanning.order",
            format!(
                "{} modes, at most {} (each mode once)",
                c.order_len,
                c.order.len()
            ),
        );
        return;
    }
    let mut seen = HashSet::new();
    for mode in c.modes() {
        if !seen.insert(mode) {
            p.add("scanning.order", format!("{:?} appears twice", mode.name()));
        }
    }
    if c.modes().is_empty() {
        p.add("scanning.order", "must list at least one mode");
    }
}

/// `[[sequence]]`: how many, none empty, none listed twice, no home
/// event used twice. An entry whose actions or target the reader found
/// wrong holds the built-in entry in its place and is not compared.
pub(super) fn library(p: &mut Problems, entries: &[SequenceEntry]) {
    let count = entries.len();
    if count == 0 {
        p.add("sequence", "the library has no sequence");
    }
    if count > MAX_SEQUENCES {
        p.add(
            "sequence",
            format!("{count} sequences, at most {MAX_SEQUENCES} allowed"),
        );
    }
    let mut seen = HashSet::new();
    let mut events = HashSet::new();
    for (i, entry) in entries.iter().enumerate() {
        let entry_key = format!("sequence #{}", i + 1);
        let key = format!("{entry_key}.actions");
        // Replaced by the built-in entry (an unknown key is only dropped).
        let replaced = ["", ".actions", ".mode", ".key", ".click", ".event"]
            .iter()
            .any(|k| p.has(&format!("{entry_key}{k}")));
        if replaced {
            continue;
        }
        if entry.actions.is_empty() {
            p.add(&key, "must hold at least one action");
        } else if !seen.insert(entry.actions) {
            p.add(&key, format!("{:?} is listed twice", entry.actions));
        }
        if let Target::Home(event) = entry.target
            && !events.insert(event)
        {
            p.add(
                format!("{entry_key}.event"),
                format!(
                    "{:?} is used twice: each home event has one sequence",
                    event.as_str()
                ),
            );
        }
    }
}

/// `[gestures]`: the head's settings, a set where the library names
/// gestures, and the sequences' interface.
pub(super) fn gestures(p: &mut Problems, core: &CoreConfig) {
    if let Err(bad) = core.head().validate() {
        for problem in bad {
            let (key, message) = problem.split_once(": ").unwrap_or(("", &problem));
            p.add(format!("gestures.{key}"), message);
        }
    }
    let has_set = core.gesture_set_file().is_some();
    for (i, entry) in core.sequences().iter().enumerate() {
        if entry.actions.has_gesture() && !has_set {
            p.add(
                format!("sequence #{}.actions", i + 1),
                format!(
                    "{:?} names gestures, but no gesture set is given: add [gestures] set = \"FILE\" (made by `sipnpuff gestures record`)",
                    entry.actions
                ),
            );
        }
    }
    if has_set && core.interface() == Interface::Bsp {
        p.add(
            "gestures.set",
            "gestures are read as sequences: they need `[interface] kind = \"asp\"`",
        );
    }
}
