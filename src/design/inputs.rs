//! The person, their settings, the library and its usage, read from what
//! the request names: a profile's measured breaths (or the study's
//! simulated user), a library file, recordings' `match` events (or a
//! mix).

use std::path::PathBuf;

use anyhow::Context;

use crate::config::Config;
use crate::config::invalid::invalid;
use crate::config::layers::Layered;
use crate::design::analysis::AttemptTiming;
use crate::design::breathing::Breathing;
use crate::design::request::Request;
use crate::design::usage::{Mix, Usage};
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
    /// The times of an attempt.
    pub timing: AttemptTiming,
}

impl Inputs {
    /// Reads what `request` names; a file that is not a valid
    /// configuration is an invalid start. The settings are the `--config`
    /// files' when given (the profile then gives only the breaths), else
    /// the profile's.
    pub fn read(request: &Request) -> anyhow::Result<Inputs> {
        let load = |path: &PathBuf| invalid(Config::from_file(path).map_err(anyhow::Error::from));
        let (config, who) = match &request.user {
            Some(path) => {
                let profile = load(path)?;
                let text = std::fs::read_to_string(path)
                    .with_context(|| format!("cannot read {}", path.display()))?;
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
        let (config, library_name) = match &request.library {
            Some(path) => {
                let library = load(path)?;
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
            None if request.user.is_some() => (config, "the profile's library".to_string()),
            None => (config, "the built-in library".to_string()),
        };
        let library = config.core().sequences();
        let usage = if request.usage.is_empty() {
            match request.mix {
                Mix::Uniform => Usage::uniform(library),
                Mix::Tasks => Usage::tasks(library),
            }
        } else {
            let found = read_matches(&request.usage).map_err(anyhow::Error::msg)?;
            Usage::recorded(library, &found.events, found.recordings)
        };
        let who = Breathing {
            swap_rate: request.swap_rate,
            ..who
        };
        let timing = AttemptTiming::of(&who, &config, request.wrong_cost_ms);
        Ok(Inputs {
            who,
            config,
            library_name,
            usage,
            timing,
        })
    }
}
