//! A session's samples read whole from a file, for fitting: a `tick,volts`
//! CSV or a `run --record` directory. The fit takes the samples; this is
//! where they come from on disk.

use std::fmt;
use std::path::Path;

use crate::control::sample::Sample;
use crate::control::tick::TickInput;
use crate::fit::signal::{FitError, Signal};
use crate::sensor::csv::CsvSignal;
use crate::tools::recording::format::samples::SampleItem;
use crate::tools::recording::read::Recording;

/// A day of samples: no calibration is longer.
const MAX_SAMPLES: usize = 86_400_000;

/// Reads a CSV file or a recording directory.
pub fn read_signal(path: &Path) -> Result<Signal, FitError> {
    if path.is_dir() {
        recorded_signal(path)
    } else {
        csv_signal(path)
    }
}

/// Reads the `volts` column of a CSV recording (1 kHz).
pub fn csv_signal(path: &Path) -> Result<Signal, FitError> {
    let in_file = |e: &dyn fmt::Display| FitError::new(format!("{}: {e}", path.display()));
    let mut csv = CsvSignal::open(path).map_err(|e| in_file(&e))?;
    let mut volts = Vec::new();
    while let Some(v) = csv.next_sample().map_err(|e| in_file(&e))? {
        volts.push(v);
    }
    Ok(Signal::from_volts(volts))
}

/// Reads the samples of a `run --record` directory, tick 0 its first tick.
/// A device lost during the session makes the signal unusable for
/// fitting.
pub fn recorded_signal(dir: &Path) -> Result<Signal, FitError> {
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
            return Err(in_dir(&format_args!(
                "the sensor was lost at tick {tick}: the session cannot be fitted; check the sensor's cable and record it again"
            )));
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
