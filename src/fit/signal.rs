//! A calibration's signal in memory: one sample per millisecond from the
//! first tick, read from a `tick,volts` CSV or a `run --record` directory.
//! A calibration lasts minutes, so it fits in memory.

use std::fmt;
use std::path::{Path, PathBuf};

use crate::control::sample::Sample;
use crate::control::tick::TickInput;
use crate::sensor::csv::CsvSignal;
use crate::tools::recording::format::samples::SampleItem;
use crate::tools::recording::read::Recording;

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

    /// Reads the `volts` column of a CSV recording (1 kHz).
    pub fn from_csv(path: &Path) -> Result<Signal, FitError> {
        let in_file = |e: &dyn fmt::Display| FitError::new(format!("{}: {e}", path.display()));
        let mut csv = CsvSignal::open(path).map_err(|e| in_file(&e))?;
        let mut volts = Vec::new();
        while let Some(v) = csv.next_sample().map_err(|e| in_file(&e))? {
            volts.push(v);
        }
        Ok(Signal::from_volts(volts))
    }

    /// Reads the samples of a `run --record` directory. A device lost
    /// during the session makes the signal unusable for fitting.
    pub fn from_recording(dir: &Path) -> Result<Signal, FitError> {
        let in_dir = |e: &dyn fmt::Display| FitError::new(format!("{}: {e}", dir.display()));
        let recording = Recording::open(dir).map_err(|e| in_dir(&e))?;
        let mut decoder = recording.samples().map_err(|e| in_dir(&e))?;
        let mut samples = Vec::new();
        let mut first = None;
        while let Some(item) = decoder.next_item().map_err(|e| in_dir(&e))? {
            let SampleItem::Input(TickInput { tick, sample, .. }) = item else {
                continue;
            };
            if let Sample::Lost = sample {
                return Err(lost(dir, tick));
            }
            let first = *first.get_or_insert(tick);
            let at = usize::try_from(tick - first).unwrap_or(usize::MAX);
            if at >= MAX_SAMPLES {
                return Err(in_dir(&"longer than a day: not a calibration"));
            }
            if samples.len() < at {
                samples.resize(at, Sample::Missing);
            }
            samples.push(sample);
        }
        Ok(Signal { samples })
    }

    /// Reads a CSV file or a recording directory.
    pub fn read(path: &Path) -> Result<Signal, FitError> {
        if path.is_dir() {
            Signal::from_recording(path)
        } else {
            Signal::from_csv(path)
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

/// A day of samples: no calibration is longer.
const MAX_SAMPLES: usize = 86_400_000;

fn lost(dir: &Path, tick: u64) -> FitError {
    FitError::new(format!(
        "{}: the sensor was lost at tick {tick}: the session cannot be fitted; check the sensor's cable and record it again",
        PathBuf::from(dir).display()
    ))
}
