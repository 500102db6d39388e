//! The detector's settings (`[detector]` in the config file) and the
//! levels they put around the neutral.

use serde::Serialize;

use crate::control::action::Breath;
use crate::control::detector::fault::FaultReason;

/// Burst detector settings (`[detector]` in the config file).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DetectorConfig {
    /// Sensor output at rest, in volts. The detector starts from it and then
    /// tracks slow drift.
    pub neutral_volts: f64,
    /// A puff starts above this voltage (relative to the tracked neutral, it
    /// moves with the neutral by the same offset).
    pub puff_threshold_volts: f64,
    /// A sip starts below this voltage (moves with the neutral likewise).
    pub sip_threshold_volts: f64,
    /// A burst ends when the signal is back past its threshold by this
    /// much: a puff's, and a sip's unless `sip_hysteresis_volts` is set.
    pub hysteresis_volts: f64,
    /// A sip's own hysteresis, volts, for a person whose sips and puffs
    /// differ much in strength; unset, sips share `hysteresis_volts`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sip_hysteresis_volts: Option<f64>,
    /// Bursts shorter than this are ignored.
    pub min_burst_ms: u32,
    /// Bursts at least this long are long; shorter ones are short.
    pub long_burst_ms: u32,
    /// Longest glitch (spike, dropout) ignored: a change of state must last
    /// longer than this to count.
    pub glitch_ms: u32,
    /// Time constant of the neutral tracker (exponential average of the
    /// resting signal, updated only while no breath is in progress).
    pub neutral_tracking_ms: u32,
    /// Samples further than this outside 0–5 V are sensor faults.
    pub fault_margin_volts: f64,
    /// After a fault, the signal must be valid and at rest this long before
    /// detection resumes.
    pub fault_recovery_ms: u32,
    /// No sample for this long is a sensor fault (stale sensor), and a
    /// tick more than this after the previous one is a stall (a fault).
    pub stale_ms: u32,
    /// A breath longer than this is a stuck sensor (a fault): the breath
    /// is dropped and command mode ends.
    pub max_hold_ms: u32,
    /// After a stuck fault, a level steady this long (and with room for
    /// both thresholds inside 0–5 V) becomes the new neutral.
    pub rezero_ms: u32,
}

impl Default for DetectorConfig {
    fn default() -> Self {
        DetectorConfig {
            neutral_volts: 2.5,
            puff_threshold_volts: 3.0,
            sip_threshold_volts: 2.0,
            hysteresis_volts: 0.1,
            sip_hysteresis_volts: None,
            min_burst_ms: 40,
            long_burst_ms: 500,
            glitch_ms: 5,
            neutral_tracking_ms: 1000,
            fault_margin_volts: 0.5,
            fault_recovery_ms: 250,
            stale_ms: 50,
            max_hold_ms: 6000,
            rezero_ms: 2000,
        }
    }
}

impl DetectorConfig {
    /// The puff threshold's distance above the neutral, volts: the
    /// threshold moves with the tracked neutral by this much.
    pub fn puff_offset_volts(&self) -> f64 {
        self.puff_threshold_volts - self.neutral_volts
    }

    /// The sip threshold's distance from the neutral, volts (negative: below
    /// it), kept as the neutral moves.
    pub fn sip_offset_volts(&self) -> f64 {
        self.sip_threshold_volts - self.neutral_volts
    }

    /// How far back past its threshold a breath of this kind ends, volts.
    pub fn hysteresis_of(&self, breath: Breath) -> f64 {
        match breath {
            Breath::Puff => self.hysteresis_volts,
            Breath::Sip => self.sip_hysteresis_volts.unwrap_or(self.hysteresis_volts),
        }
    }

    /// These settings around another neutral: the thresholds keep their
    /// distances from it (a re-zero at start measures the neutral).
    pub fn with_neutral(self, neutral_volts: f64) -> DetectorConfig {
        let shift = neutral_volts - self.neutral_volts;
        DetectorConfig {
            neutral_volts,
            puff_threshold_volts: self.puff_threshold_volts + shift,
            sip_threshold_volts: self.sip_threshold_volts + shift,
            ..self
        }
    }
}

/// What the detector works out once from its settings and reads every
/// tick: the thresholds' offsets from the neutral, the range a valid
/// sample lies in, the neutral tracker's step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Levels {
    /// [`DetectorConfig::puff_offset_volts`].
    pub(super) puff_offset: f64,
    /// [`DetectorConfig::sip_offset_volts`].
    pub(super) sip_offset: f64,
    /// 0–5 V widened by `fault_margin_volts` at each end.
    low_limit: f64,
    high_limit: f64,
    /// `1 / neutral_tracking_ms`: the tracker multiplies by it (a division
    /// would cost more and round otherwise).
    pub(super) tracking_alpha: f64,
}

impl Levels {
    pub(super) fn of(config: &DetectorConfig) -> Levels {
        Levels {
            puff_offset: config.puff_offset_volts(),
            sip_offset: config.sip_offset_volts(),
            low_limit: -config.fault_margin_volts,
            high_limit: 5.0 + config.fault_margin_volts,
            tracking_alpha: 1.0 / f64::from(config.neutral_tracking_ms),
        }
    }

    /// Whether a sample is a fault: NaN, infinite, or further outside
    /// 0–5 V than `fault_margin_volts`.
    pub(super) fn check(&self, volts: f64) -> Result<(), FaultReason> {
        if volts.is_nan() {
            Err(FaultReason::NotANumber)
        } else if volts.is_infinite() {
            Err(FaultReason::Infinite)
        } else if volts < self.low_limit || volts > self.high_limit {
            Err(FaultReason::OutOfRange { volts })
        } else {
            Ok(())
        }
    }
}
