//! What was measured of each kind of breath, for the report and the
//! profile's header.

use serde::Serialize;

use crate::control::detector::DetectorConfig;
use crate::fit::predict::levels;
use crate::fit::protocol::{Ask, Protocol};
use crate::fit::session::Answers;
use crate::fit::signal::Signal;
use crate::fit::stats::mean_sd;

/// Mean, spread, smallest and largest of some values.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct Spread {
    /// The mean.
    pub mean: f64,
    /// The standard deviation.
    pub sd: f64,
    /// The smallest value.
    pub min: f64,
    /// The largest value.
    pub max: f64,
}

impl Spread {
    /// Of these values (all zero for none).
    pub fn of(values: &[f64]) -> Spread {
        let (mean, sd) = mean_sd(values);
        Spread {
            mean,
            sd,
            min: values.iter().copied().reduce(f64::min).unwrap_or(0.0),
            max: values.iter().copied().reduce(f64::max).unwrap_or(0.0),
        }
    }
}

/// One kind of prompted breath as measured.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Class {
    /// What was asked.
    pub ask: Ask,
    /// Breaths counted.
    pub breaths: usize,
    /// Plateau distance from the rest level, volts.
    pub plateau_volts: Spread,
    /// Peak distance (95th percentile of each breath), volts.
    pub peak_volts: Spread,
    /// Onset to release at the proposed thresholds, ms.
    pub duration_ms: Spread,
}

impl Class {
    /// "plateau 1.13 ± 0.05 V (weakest 1.06), 146 ± 30 ms (106–186)": the
    /// report's and the profile header's words (drift reads them back).
    pub fn measured(&self) -> String {
        format!(
            "plateau {:.2} ± {:.2} V (weakest {:.2}), {:.0} ± {:.0} ms ({:.0}–{:.0})",
            self.plateau_volts.mean,
            self.plateau_volts.sd,
            self.plateau_volts.min,
            self.duration_ms.mean,
            self.duration_ms.sd,
            self.duration_ms.min,
            self.duration_ms.max
        )
    }
}

/// Every kind's measurements, in the protocol's order; durations at the
/// levels of `d`.
pub fn classes(
    signal: &Signal,
    answers: &Answers,
    protocol: &Protocol,
    d: &DetectorConfig,
) -> Vec<Class> {
    protocol
        .blocks
        .iter()
        .map(|block| {
            let (on, off) = levels(d, block.ask.breath());
            let regions: Vec<_> = answers.of(block.ask).collect();
            let plateaus: Vec<f64> = regions.iter().map(|r| r.plateau).collect();
            let peaks: Vec<f64> = regions.iter().map(|r| r.peak).collect();
            let durations: Vec<f64> = regions
                .iter()
                .filter_map(|r| r.duration_at(signal, on, off, d.glitch_ms as usize))
                .map(|ms| ms as f64)
                .collect();
            Class {
                ask: block.ask,
                breaths: regions.len(),
                plateau_volts: Spread::of(&plateaus),
                peak_volts: Spread::of(&peaks),
                duration_ms: Spread::of(&durations),
            }
        })
        .collect()
}

/// The pauses between consecutive breaths of a block, ms.
pub fn gaps(answers: &Answers) -> Spread {
    let gaps: Vec<f64> = answers
        .answers
        .windows(2)
        .filter(|w| w[0].ask == w[1].ask)
        .map(|w| (w[1].region.start - w[0].region.end) as f64)
        .collect();
    Spread::of(&gaps)
}
