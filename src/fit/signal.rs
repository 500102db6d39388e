//! A calibration's signal in memory: one sample per millisecond from the
//! first tick (`tools::signal_file` reads one from a CSV or a recording).
//! A calibration lasts minutes, so it fits in memory.

use std::fmt;

use crate::control::sample::Sample;

/// Why a signal could not be read or fitted. Every message says what to do.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FitError {
    /// What went wrong, in plain words.
    pub message: String,
}

impl FitError {
    /// An error with this message.
    pub fn new(message: impl Into<String>) -> FitError {
        FitError {
            message: message.into(),
        }
    }
}

impl fmt::Display for FitError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for FitError {}

/// The samples of a session, tick 0 first. A tick without a sample is
/// [`Sample::Missing`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Signal {
    /// One sample per millisecond.
    pub samples: Vec<Sample>,
}

impl Signal {
    /// A signal of these volts, one per millisecond.
    pub fn from_volts(volts: impl IntoIterator<Item = f64>) -> Signal {
        Signal {
            samples: volts.into_iter().map(Sample::Volts).collect(),
        }
    }

    /// Milliseconds of signal.
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// Whether there is no sample at all.
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// The value at `tick`, if it is a finite voltage.
    pub fn volts(&self, tick: usize) -> Option<f64> {
        match self.samples.get(tick) {
            Some(Sample::Volts(v)) if v.is_finite() => Some(*v),
            _ => None,
        }
    }
}
