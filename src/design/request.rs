//! What the designer is asked: the files that name the person (their
//! breathing and their gestures), the library and its usage; the search's
//! limits; the study's size; where the result goes.

use std::path::PathBuf;

use crate::control::action::Action;
use crate::control::gesture::name::GestureName;
use crate::design::usage::Mix;

/// Something the person cannot make reliably (`--without`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Without {
    /// One burst.
    Burst(Action),
    /// All four bursts: the person does not breathe into the sensor.
    Breaths,
    /// One of their gestures.
    Gesture(GestureName),
}

impl Without {
    /// `short_sip`, `long_sip`, `short_puff`, `long_puff`, `breaths`, or
    /// a gesture's name.
    pub fn parse(text: &str) -> Result<Without, String> {
        let burst = Action::ALL
            .into_iter()
            .find(|a| a.to_string().replace(' ', "_") == text);
        match (burst, text) {
            (Some(a), _) => Ok(Without::Burst(a)),
            (None, "breaths") => Ok(Without::Breaths),
            (None, _) => GestureName::new(text).map(Without::Gesture).ok_or_else(|| {
                format!(
                    "`{text}` is neither a burst (short_sip, long_sip, short_puff, long_puff, or breaths for all four) nor a gesture's name"
                )
            }),
        }
    }

    /// Whether this leaves out the burst `a`.
    pub fn covers(self, a: Action) -> bool {
        match self {
            Without::Burst(b) => a == b,
            Without::Breaths => true,
            Without::Gesture(_) => false,
        }
    }
}

/// A design or a check, as asked.
#[derive(Debug, Clone)]
pub struct Request {
    /// The library to analyse, or whose entries to place (`None`: the
    /// built-in one, or the profile's).
    pub library: Option<PathBuf>,
    /// The person: a profile `sipnpuff fit` wrote (`None`: the study's
    /// simulated user).
    pub user: Option<PathBuf>,
    /// The person's gesture set, in place of the settings' `[gestures]
    /// set` (`None`: that one, or the library file's).
    pub gestures: Option<PathBuf>,
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
    /// Bursts and gestures the person cannot make reliably.
    pub without: Vec<Without>,
    /// Place breaths too when the library has none (by default a library
    /// of gestures alone is designed with gestures alone: the person may
    /// have no breath sensor).
    pub with_breaths: bool,
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn without_names_a_burst_all_four_or_a_gesture() {
        assert_eq!(
            Without::parse("long_sip"),
            Ok(Without::Burst(Action::LongSip))
        );
        assert_eq!(Without::parse("breaths"), Ok(Without::Breaths));
        let shake = GestureName::new("shake").unwrap();
        assert_eq!(Without::parse("shake"), Ok(Without::Gesture(shake)));
        assert!(Without::parse("Shake").is_err());
        assert!(Without::Breaths.covers(Action::ShortPuff));
        assert!(!Without::Gesture(shake).covers(Action::ShortPuff));
    }
}
