//! Predicted misreadings of a user's breaths under given detector
//! settings: from the spread of their levels and durations (a normal
//! model of each class, fitted to the calibration), and from the rest's
//! noise for bursts that were never breathed.

use serde::Serialize;

use crate::control::action::{Action, Breath};
use crate::control::detector::DetectorConfig;
use crate::fit::breaths::Found;
use crate::fit::protocol::Ask;
use crate::fit::session::Answers;
use crate::fit::signal::Signal;
use crate::fit::stats::{mean_sd, normal_cdf};

/// Predicted rates of one kind of breath (sip or puff), as fractions.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct KindRates {
    /// Intended breaths not read at all (too weak, or too short).
    pub missed: f64,
    /// Short breaths read as long.
    pub short_as_long: f64,
    /// Long breaths read as short.
    pub long_as_short: f64,
}

/// Predicted rates under one set of detector settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Rates {
    /// Puffs.
    pub puff: KindRates,
    /// Sips.
    pub sip: KindRates,
    /// Bursts per hour at rest that nobody breathed (the rest's noise
    /// passing a threshold for a whole burst).
    pub false_per_hour: f64,
}

impl Rates {
    /// The rates of one kind.
    pub fn of(&self, breath: Breath) -> &KindRates {
        match breath {
            Breath::Puff => &self.puff,
            Breath::Sip => &self.sip,
        }
    }

    /// The largest short/long confusion of either kind.
    pub fn worst_confusion(&self) -> f64 {
        [self.puff, self.sip]
            .iter()
            .map(|k| k.short_as_long.max(k.long_as_short))
            .fold(0.0, f64::max)
    }
}

/// The durations (ms) of `ask`'s breaths as `d` would measure them; `None`
/// for a breath that never passes the threshold.
pub fn durations(
    signal: &Signal,
    answers: &Answers,
    ask: Ask,
    d: &DetectorConfig,
) -> Vec<Option<usize>> {
    let (on, off) = levels(d, ask.breath());
    answers
        .of(ask)
        .map(|r| r.duration_at(signal, on, off, d.glitch_ms as usize))
        .collect()
}

/// A kind's threshold and release level, volts from the neutral.
pub fn levels(d: &DetectorConfig, breath: Breath) -> (f64, f64) {
    let on = match breath {
        Breath::Puff => d.puff_threshold_volts - d.neutral_volts,
        Breath::Sip => d.neutral_volts - d.sip_threshold_volts,
    };
    (on, on - d.hysteresis_of(breath))
}

/// A spread never taken as smaller than this fraction of the mean (eight
/// breaths underestimate it).
const MIN_SPREAD_FRACTION: f64 = 0.05;
/// Nor smaller than this, ms or (for levels) hundredths of a volt.
const MIN_SPREAD_MS: f64 = 10.0;
const MIN_SPREAD_VOLTS: f64 = 0.02;

/// Mean and spread of values, the spread floored.
pub fn fitted(values: &[f64], floor: f64) -> (f64, f64) {
    let (mean, sd) = mean_sd(values);
    (mean, sd.max(MIN_SPREAD_FRACTION * mean.abs()).max(floor))
}

/// Mean and floored spread of durations, ms.
pub fn fitted_ms(values: &[f64]) -> (f64, f64) {
    fitted(values, MIN_SPREAD_MS)
}

/// The predicted rates of `d` on this user's calibration.
pub fn predict(signal: &Signal, found: &Found, answers: &Answers, d: &DetectorConfig) -> Rates {
    let kind = |breath: Breath| {
        let (on, _) = levels(d, breath);
        let plateaus: Vec<f64> = answers
            .answers
            .iter()
            .filter(|a| a.ask.breath() == breath)
            .map(|a| a.region.plateau)
            .collect();
        let (level, spread) = fitted(&plateaus, MIN_SPREAD_VOLTS);
        let too_weak = normal_cdf((on - level) / spread);
        let class = |action: Action| -> Option<(f64, f64)> {
            let read: Vec<f64> = durations(signal, answers, Ask::Breath(action), d)
                .into_iter()
                .flatten()
                .map(|ms| ms as f64)
                .collect();
            (!read.is_empty()).then(|| fitted_ms(&read))
        };
        let long = f64::from(d.long_burst_ms);
        let min = f64::from(d.min_burst_ms);
        let short = class(Action::new(breath, false));
        let long_class = class(Action::new(breath, true));
        let too_short = short.map_or(1.0, |(m, s)| normal_cdf((min - m) / s));
        KindRates {
            missed: 1.0 - (1.0 - too_weak) * (1.0 - too_short / 2.0),
            short_as_long: short.map_or(0.0, |(m, s)| 1.0 - normal_cdf((long - m) / s)),
            long_as_short: long_class.map_or(0.0, |(m, s)| normal_cdf((long - m) / s)),
        }
    };
    Rates {
        puff: kind(Breath::Puff),
        sip: kind(Breath::Sip),
        false_per_hour: false_per_hour(found, d),
    }
}

/// Bursts per hour the rest would make: its periodic part (a tremor,
/// hum, a wander: the largest excursion measured at rest, less the
/// noise's share of it) plus Gaussian noise of its sample-to-sample
/// spread, staying past a threshold for a whole `min_burst_ms` (samples
/// taken as independent, the periodic part at its peak throughout: an
/// upper bound).
fn false_per_hour(found: &Found, d: &DetectorConfig) -> f64 {
    let rest = &found.rest;
    let sd = rest.white_sd.max(1e-6);
    let per_ms: f64 = [Breath::Puff, Breath::Sip]
        .iter()
        .map(|&b| {
            let (on, _) = levels(d, b);
            let excursion = match b {
                Breath::Puff => rest.excursion_up,
                Breath::Sip => rest.excursion_down,
            };
            let periodic = (excursion - NOISE_PEAK_SDS * sd).max(0.0);
            let past = 1.0 - normal_cdf((on - periodic) / sd);
            past.powf(f64::from(d.min_burst_ms))
        })
        .sum();
    per_ms * 3_600_000.0
}

/// How far the noise alone reaches in the rest's few seconds, in its
/// standard deviations: what of the largest excursion is noise.
const NOISE_PEAK_SDS: f64 = 3.5;
