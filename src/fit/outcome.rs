//! How a fit ended, for the page's summary of a live session: what the
//! fit found against the settings in use, and what was written, or why
//! nothing was.

use serde::Serialize;

use crate::config::Config;
use crate::fit::{Fit, profile};

/// How a session ended, for the page's summary: what the fit found
/// against the settings in use, and what was written, or why nothing was.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct Outcome {
    /// The calibration's breaths read right, of those asked, with the
    /// current settings and with the proposed ones (none: no fit).
    pub read_right: Option<ReadRight>,
    /// The settings the fit changes: current against proposed.
    pub changed: Vec<Changed>,
    /// Where the profile was written.
    pub profile: Option<String>,
    /// Where the session is recorded.
    pub recording: Option<String>,
    /// Why no profile was written.
    pub problem: Option<String>,
}

/// Breaths read right by the detector replaying the calibration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct ReadRight {
    /// With the settings in use.
    pub current: usize,
    /// With the proposed settings.
    pub proposed: usize,
    /// Breaths asked for (and found).
    pub asked: usize,
}

/// One setting the fit changes.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Changed {
    /// Its key, e.g. `detector.long_burst_ms`.
    pub key: &'static str,
    /// Its value now.
    pub current: String,
    /// Its proposed value.
    pub proposed: String,
    /// Why.
    pub reason: String,
}

impl Outcome {
    /// What `fit` found against `current`, the configuration in use.
    pub fn of(fit: &Fit, current: &Config) -> Outcome {
        let now = profile::values(current);
        let changed = fit
            .proposal
            .settings
            .iter()
            .filter_map(|s| {
                let value = now.get(s.key)?;
                (!profile::same(value, &s.value)).then(|| Changed {
                    key: s.key,
                    current: value.clone(),
                    proposed: s.value.clone(),
                    reason: s.reason.clone(),
                })
            })
            .collect();
        let (current, asked) = fit.replayed[0].right();
        let (proposed, _) = fit.replayed[1].right();
        Outcome {
            read_right: Some(ReadRight {
                current,
                proposed,
                asked,
            }),
            changed,
            ..Outcome::default()
        }
    }
}
