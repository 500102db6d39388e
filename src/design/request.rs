//! What the designer is asked: the files that name the person, the
//! library and its usage; the search's limits; the study's size; where
//! the result goes.

use std::path::PathBuf;

use crate::control::action::Action;
use crate::design::usage::Mix;

/// A design or a check, as asked.
#[derive(Debug, Clone)]
pub struct Request {
    /// The library to analyse, or whose entries to place (`None`: the
    /// built-in one, or the profile's).
    pub library: Option<PathBuf>,
    /// The person: a profile `sipnpuff fit` wrote (`None`: the study's
    /// simulated user).
    pub user: Option<PathBuf>,
    /// The settings in use (`--config`, later files over earlier ones);
    /// none: the profile's, or the built-in ones.
    pub config: Vec<PathBuf>,
    /// Recordings (or directories of them) whose `match` events give the
    /// usage.
    pub usage: Vec<PathBuf>,
    /// The usage mix without recordings (`None`: the study's tasks when
    /// the library selects their modes, every entry as often otherwise).
    pub mix: Option<Mix>,
    /// The cost of a wrong selection beyond the attempt, ms (`None`: the
    /// inactivity timeout).
    pub wrong_cost_ms: Option<f64>,
    /// Chance a burst is read as the other breath.
    pub swap_rate: f64,
    /// Fewest bursts in a designed sequence.
    pub min_breaths: u8,
    /// Most bursts in a designed sequence.
    pub max_breaths: u8,
    /// Bursts the person cannot breathe reliably.
    pub without: Vec<Action>,
    /// Entries that keep their sequence, by what they select.
    pub keep: Vec<String>,
    /// Stop branching after this many seconds.
    pub time_limit_s: f64,
    /// Write the designed library (a configuration) here.
    pub out: Option<PathBuf>,
    /// Draw each entry's expected time and error to this SVG.
    pub svg: Option<PathBuf>,
    /// Participants in the study that tries the designed library.
    pub users: u64,
    /// The study's seed.
    pub seed: u64,
    /// Skip the study.
    pub no_study: bool,
    /// Write the designed library even when it is slower than the one it
    /// replaces.
    pub force: bool,
}
