//! A gesture set made ready for the core: its names as the library writes
//! them, its templates and thresholds, and the front end's settings it
//! was recorded with, checked with the configuration's head settings.
//! Every gesture the library names must be in the set.

use std::path::Path;

use crate::control::core_config::CoreConfig;
use crate::control::gesture::name::GestureName;
use crate::control::head::{GestureSetup, Head};
use crate::control::imu::Channels;
use crate::control::token::Token;
use crate::gestures::set::GestureSet;

/// The core's setup for `set` under `core`'s library and `[gestures]`
/// settings, or every problem (a library entry naming a gesture the set
/// lacks is named by its key, `sequence #N.actions`).
pub fn setup(core: &CoreConfig, set: &GestureSet) -> Result<GestureSetup, Vec<String>> {
    let mut problems = Vec::new();
    let names: Vec<GestureName> = set
        .gestures
        .iter()
        .filter_map(|g| GestureName::new(&g.name))
        .collect();
    let known: Vec<&str> = names.iter().map(GestureName::as_str).collect();
    for (i, entry) in core.sequences().iter().enumerate() {
        let missing: Vec<String> = entry
            .actions
            .as_slice()
            .iter()
            .filter_map(|token| match token {
                Token::Gesture(name) if !names.contains(name) => Some(format!("`{name}`")),
                _ => None,
            })
            .collect();
        if !missing.is_empty() {
            problems.push(format!(
                "sequence #{}.actions: {} not in the gesture set (it has {})",
                i + 1,
                missing.join(", "),
                known.join(", ")
            ));
        }
    }
    let setup = GestureSetup {
        names,
        recognizer: set.config,
        templates: set.templates(None, 1.0),
        channels: set.channels,
    };
    if let Err(bad) = Head::new(&setup, core.head()) {
        problems.extend(bad);
    }
    if problems.is_empty() {
        Ok(setup)
    } else {
        Err(problems)
    }
}

/// Refuses an IMU (`sensor`, giving `channels`) that lacks a channel the
/// person's gestures were recorded with: one line naming both.
pub fn check_channels(core: &CoreConfig, sensor: &str, channels: Channels) -> Result<(), String> {
    let Some(setup) = core.gestures() else {
        return Ok(());
    };
    if channels.covers(setup.channels) {
        return Ok(());
    }
    Err(format!(
        "{sensor}: gives {channels} but the gesture set {} was recorded with {}: a set from another sensor's channels (record the gestures again with this IMU)",
        core.gesture_set_file()
            .map_or_else(|| "in use".to_string(), |p| p.display().to_string()),
        setup.channels
    ))
}

/// The setup for `core` from the set in the file at `path` (read,
/// parsed, checked against the library): every problem in one line
/// naming the file.
pub fn load(core: &CoreConfig, path: &Path) -> Result<GestureSetup, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("[gestures] set: cannot read {}: {e}", path.display()))?;
    let set = GestureSet::from_toml(&text)
        .map_err(|e| format!("{}: {}", path.display(), e.join("; ")))?;
    setup(core, &set).map_err(|e| format!("{}: {}", path.display(), e.join("; ")))
}
