//! The person, their settings, the library and its usage, read from what
//! the request names: a profile's measured breaths (or the study's
//! simulated user), their gesture set if they have one, a library file,
//! recordings' `match` events (or a mix).

use std::path::{Path, PathBuf};

use anyhow::Context;

use crate::config::Config;
use crate::config::invalid::invalid;
use crate::config::layers::Layered;
use crate::control::core_config::CoreConfig;
use crate::control::selection::Interface;
use crate::design::analysis::AttemptTiming;
use crate::design::breathing::Breathing;
use crate::design::gesturing::Gesturing;
use crate::design::request::Request;
use crate::design::usage::{Mix, Usage};
use crate::gestures::set::GestureSet;
use crate::sim::study::missing_modes;
use crate::tools::recording::matches::read_matches;

/// The person, their settings and the library, as the request says.
pub struct Inputs {
    /// How the person breathes.
    pub who: Breathing,
    /// Their settings, with the library.
    pub config: Config,
    /// The library in words ("the built-in library", its file).
    pub library_name: String,
    /// How often each entry is used.
    pub usage: Usage,
    /// Why this usage: asked for, or the default and what decided it.
    pub usage_why: String,
    /// The profile's text (`--user`), whose comments give its settings'
    /// reasons.
    pub profile_text: Option<String>,
    /// The times of an attempt.
    pub timing: AttemptTiming,
}

impl Inputs {
    /// Reads what `request` names; a file that is not a valid
    /// configuration, or a gesture set that does not load or lacks a
    /// gesture the library names, is an invalid start. The settings are
    /// the `--config` files' when given (the profile then gives only the
    /// breaths), else the profile's. The gestures are `--gestures`' set,
    /// else the settings' `[gestures] set`, else the library file's.
    pub fn read(request: &Request) -> anyhow::Result<Inputs> {
        let load = |path: &PathBuf| invalid(Config::from_file(path).map_err(anyhow::Error::from));
        let mut profile_text = None;
        let (config, who) = match &request.user {
            Some(path) => {
                let profile = load(path)?;
                let text = std::fs::read_to_string(path)
                    .with_context(|| format!("cannot read {}", path.display()))?;
                profile_text = Some(text.clone());
                let measured = crate::fit::profile::measured(&text).map_err(|e| {
                    anyhow::anyhow!(
                        "{}: {e}; fit the person first (`sipnpuff fit`) and give the profile it writes",
                        path.display()
                    )
                })?;
                let who = Breathing::of_profile(
                    &measured,
                    &profile,
                    &format!("measured by the profile {}", path.display()),
                );
                (profile, who)
            }
            None => {
                let config = Config::default();
                let who = Breathing::of_model(
                    &crate::sim::user::UserModel::POPULATION,
                    config.core().detector(),
                    "the study's simulated user",
                );
                (config, who)
            }
        };
        let (config, setup) = if request.config.is_empty() {
            (config, None)
        } else {
            let setup = invalid(Layered::read(&request.config).map_err(anyhow::Error::from))?;
            (setup.config().clone(), Some(setup))
        };
        let config = match &request.gestures {
            Some(path) => invalid(
                config
                    .with_gesture_set(path.clone())
                    .map_err(anyhow::Error::from),
            )?,
            None => config,
        };
        let (config, library_name) = match &request.library {
            Some(path) => {
                let library = load(path)?;
                let config = match library.core().gesture_set_file() {
                    Some(set) if config.core().gesture_set_file().is_none() => invalid(
                        config
                            .with_gesture_set(set.to_path_buf())
                            .map_err(anyhow::Error::from),
                    )?,
                    _ => config,
                };
                (
                    invalid(
                        config
                            .with_sequences(library.core().sequences().to_vec())
                            .map_err(anyhow::Error::from),
                    )?,
                    path.display().to_string(),
                )
            }
            None if setup.is_some() => {
                let name = match setup.as_ref().and_then(|s| s.source("sequence")) {
                    Some(layer) => format!("the library of {}", layer.path.display()),
                    None => "the built-in library".to_string(),
                };
                (config, name)
            }
            None => {
                let name = match (&request.user, &profile_text) {
                    (Some(path), Some(text)) if has_library(text) => {
                        format!("the library of {}", path.display())
                    }
                    _ => "the built-in library".to_string(),
                };
                (config, name)
            }
        };
        let library = config.core().sequences();
        let missing = missing_modes(&config, Interface::Asp);
        let (usage, usage_why) = if request.usage.is_empty() {
            match request.mix {
                Some(Mix::Uniform) => (Usage::uniform(library), "asked for (--mix uniform)".into()),
                Some(Mix::Tasks) => (Usage::tasks(library), "asked for (--mix tasks)".into()),
                None if missing.is_empty() => (
                    Usage::tasks(library),
                    "the default: the library selects the study's modes and no --usage recordings were given"
                        .into(),
                ),
                None => {
                    let names: Vec<&str> = missing.iter().map(|m| m.name()).collect();
                    (
                        Usage::uniform(library),
                        format!(
                            "the default: no --usage recordings, and the library lacks the study's {}",
                            names.join(", ")
                        ),
                    )
                }
            }
        } else {
            let found = read_matches(&request.usage).map_err(anyhow::Error::msg)?;
            (
                Usage::recorded(library, &found.events, found.recordings),
                "the person's recorded use (--usage)".into(),
            )
        };
        let gestures = match config.core().gesture_set_file() {
            Some(path) => Some(invalid(gesturing(config.core(), path))?),
            None => None,
        };
        let who = Breathing {
            swap_rate: request.swap_rate,
            gestures,
            ..who
        };
        let timing = AttemptTiming::of(&who, &config, request.wrong_cost_ms);
        Ok(Inputs {
            who,
            config,
            library_name,
            usage,
            usage_why,
            profile_text,
            timing,
        })
    }

    /// The usage in one line, with why it was chosen.
    pub fn usage_line(&self) -> String {
        format!("{} ({})", self.usage.source, self.usage_why)
    }
}

/// The person's gestures from the set at `path`: read, parsed, checked
/// against `core`'s library and head settings as `run` checks them, then
/// priced ([`Gesturing::of_set`]); every problem in one error naming the
/// file.
fn gesturing(core: &CoreConfig, path: &Path) -> anyhow::Result<Gesturing> {
    let text = std::fs::read_to_string(path).map_err(|e| {
        anyhow::anyhow!(
            "the gesture set {}: cannot read it: {e} (make it with `sipnpuff gestures record`)",
            path.display()
        )
    })?;
    let problems = |e: Vec<String>| anyhow::anyhow!("{}: {}", path.display(), e.join("; "));
    let set = GestureSet::from_toml(&text).map_err(problems)?;
    crate::gestures::setup::setup(core, &set).map_err(problems)?;
    Gesturing::of_set(&set, &path.display().to_string()).map_err(|e| problems(vec![e]))
}

/// Whether a configuration's text holds a library (`[[sequence]]`).
fn has_library(text: &str) -> bool {
    text.parse::<toml::Table>()
        .is_ok_and(|t| t.contains_key("sequence"))
}
