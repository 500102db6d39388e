//! Fitting the interface to the person: a calibration session's breaths
//! measured, and the settings that read them best proposed.
//!
//! One session's way: [`signal`] reads it; [`breaths`] finds the rest and
//! the breaths; [`session`] matches them to the [`protocol`]'s prompts;
//! [`propose`] derives the settings, each with its reason; [`predict`]
//! gives the misreadings they predict and [`check`] replays the session
//! through the real detector; [`profile`] writes the result, [`report`]
//! words it for a clinician and [`outcome`] sums it up for the page. A
//! live session is guided by [`prompter`], which owns the protocol's
//! progress tick by tick. Pure: no clock, no device.

pub mod breaths;
pub mod check;
pub mod drift;
pub mod outcome;
pub mod predict;
pub mod profile;
pub mod prompter;
pub mod propose;
pub mod protocol;
pub mod report;
pub mod session;
pub mod signal;
pub mod stats;
pub mod summary;
pub mod usage;

use crate::config::{Config, ConfigErrors};
use crate::control::detector::DetectorConfig;
use check::ConfusionMatrix;
use predict::Rates;
use propose::Proposal;
use protocol::{Ask, Protocol};
use session::Answers;
use signal::{FitError, Signal};
use summary::{Class, Spread};

/// A short/long confusion above this (predicted, either way, either
/// kind) means the classes overlap: no setting reads them reliably.
pub const MAX_CONFUSION: f64 = 0.05;

/// The outcome of fitting one calibration.
#[derive(Debug, Clone)]
pub struct Fit {
    /// The protocol the session followed; for ordinary use, the breaths
    /// found that selected a mode, one block per kind and length.
    pub protocol: Protocol,
    /// Fitted from ordinary use (recorded runs), not a calibration.
    pub ordinary_use: bool,
    /// The rest and the breaths found.
    pub found: breaths::Found,
    /// The breaths matched to the prompts.
    pub answers: Answers,
    /// What was measured of each kind of breath.
    pub classes: Vec<Class>,
    /// The pauses between breaths of a block, ms.
    pub gaps: Spread,
    /// The proposed settings and their reasons.
    pub proposal: Proposal,
    /// The current settings' detector, around the measured rest level (as
    /// a run's re-zero would set it).
    pub current: DetectorConfig,
    /// The configuration with the proposal: what the profile makes.
    pub config: Config,
    /// Predicted misreadings: current settings, then proposed.
    pub predicted: [Rates; 2],
    /// The session replayed through the detector: current, then proposed.
    pub replayed: [ConfusionMatrix; 2],
    /// When the user's short and long breaths overlap: what to do, in
    /// plain words.
    pub overlap: Option<String>,
    /// What the proposal predicts worse than the current settings, and
    /// why.
    pub worse: Vec<String>,
}

impl Fit {
    /// Whether a profile should be written without `--force`.
    pub fn is_reliable(&self) -> bool {
        self.overlap.is_none()
    }
}

/// Fits a calibration session that followed `protocol`, starting from the
/// `current` configuration.
pub fn fit(signal: &Signal, protocol: &Protocol, current: &Config) -> Result<Fit, FitError> {
    let found = breaths::find(signal)?;
    let answers = session::answers(protocol, &found)?;
    fit_answers(signal, protocol, found, answers, None, current)
}

/// Fits a session of ordinary use recorded with the settings `in_use`.
pub fn fit_use(signal: &Signal, in_use: &Config) -> Result<Fit, FitError> {
    let mut used = usage::measure(signal, in_use)?;
    // The breaths made in a mode moved the arm: read by the replay, but
    // neither split into short and long nor bursts nobody made.
    let selecting: std::collections::HashSet<usize> = used
        .answers
        .answers
        .iter()
        .map(|a| a.region.start)
        .collect();
    used.answers.extra = (used.found.regions.iter())
        .filter(|r| !selecting.contains(&r.start))
        .copied()
        .collect();
    used.answers.notes.push(format!(
        "ordinary use: {} breaths, {} of them to select a mode (split into short and long as you made them) and {} in a mode (they moved the arm: left out)",
        used.found.regions.len(),
        used.answers.answers.len(),
        used.answers.extra.len()
    ));
    if used.cut_by_fault > 0 {
        used.answers.notes.push(format!(
            "{} breath{} cut by a fault left out (the loop stalled, or a breath was held past detector.max_hold_ms = {} ms)",
            used.cut_by_fault,
            if used.cut_by_fault == 1 { "" } else { "s" },
            in_use.core().detector().max_hold_ms
        ));
    }
    fit_answers(
        signal,
        &used.protocol,
        used.found,
        used.answers,
        Some(&used.pauses),
        in_use,
    )
}

fn fit_answers(
    signal: &Signal,
    protocol: &Protocol,
    found: breaths::Found,
    answers: Answers,
    pauses: Option<&usage::Pauses>,
    current: &Config,
) -> Result<Fit, FitError> {
    let proposal = propose::propose(signal, &found, &answers, current, pauses);
    let config = current
        .clone()
        .with_detector(proposal.detector)
        .and_then(|c| c.with_sequence_timeout_ms(proposal.sequence_timeout_ms))
        .and_then(|c| c.with_inactivity_timeout_ms(proposal.inactivity_timeout_ms))
        .map_err(|e| invalid(&e))?;
    let now = current.core().detector().with_neutral(found.rest.level);
    let d = proposal.detector;
    let predicted = [
        predict::predict(signal, &found, &answers, &now),
        predict::predict(signal, &found, &answers, &d),
    ];
    let asks: Vec<Ask> = protocol.blocks.iter().map(|b| b.ask).collect();
    let replayed = [
        check::confusion(signal, &answers, &asks, &now),
        check::confusion(signal, &answers, &asks, &d),
    ];
    let overlap = overlap(&predicted[1]);
    let worse = worse(&predicted);
    Ok(Fit {
        classes: summary::classes(signal, &answers, protocol, &d),
        gaps: summary::gaps(&answers),
        protocol: protocol.clone(),
        ordinary_use: pauses.is_some(),
        found,
        answers,
        proposal,
        current: now,
        config,
        predicted,
        replayed,
        overlap,
        worse,
    })
}

fn invalid(errors: &ConfigErrors) -> FitError {
    FitError::new(format!(
        "the proposed settings do not validate ({errors}): the calibration's breaths are too weak or too noisy to place thresholds; check the tube and the sensor, and record it again"
    ))
}

/// The plain-words finding when short and long breaths overlap.
fn overlap(proposed: &Rates) -> Option<String> {
    let worst = proposed.worst_confusion();
    (worst > MAX_CONFUSION).then(|| {
        format!(
            "your short and long breaths overlap: even the best boundary reads {:.0} % of them as the other length (more than {:.0} %). Try: a longer boundary with a slower library (fewer long breaths); a library with fewer long breaths; or practise holding long breaths longer and fit again",
            100.0 * worst,
            100.0 * MAX_CONFUSION
        )
    })
}

/// Each predicted rate the proposal makes worse than the current
/// settings, with the likely reason.
fn worse(predicted: &[Rates; 2]) -> Vec<String> {
    let [now, new] = predicted;
    let mut found = Vec::new();
    let mut compare = |what: &str, a: f64, b: f64, why: &str| {
        if b > a + 0.001 {
            found.push(format!(
                "{what}: {:.1} % → {:.1} % ({why})",
                100.0 * a,
                100.0 * b
            ));
        }
    };
    for (word, k0, k1) in [
        ("puffs", &now.puff, &new.puff),
        ("sips", &now.sip, &new.sip),
    ] {
        compare(
            &format!("{word} missed"),
            k0.missed,
            k1.missed,
            "the threshold moved up, away from the rest noise",
        );
        compare(
            &format!("short {word} read as long"),
            k0.short_as_long,
            k1.short_as_long,
            "the boundary moved down, to read more of your long breaths as long",
        );
        compare(
            &format!("long {word} read as short"),
            k0.long_as_short,
            k1.long_as_short,
            "the boundary moved up, to read more of your short breaths as short",
        );
    }
    if new.false_per_hour > now.false_per_hour + 0.1 {
        found.push(format!(
            "false bursts at rest: {:.1} → {:.1} per hour (the thresholds moved closer to the rest noise, to read weaker breaths)",
            now.false_per_hour, new.false_per_hour
        ));
    }
    found
}
