//! A session's samples read whole from a file, for fitting: a `tick,volts`
//! CSV or a `run --record` directory. The fit takes the samples; this is
//! where they come from on disk.

use std::fmt;
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::Path;

use crate::control::sample::Sample;
use crate::control::tick::TickInput;
use crate::fit::signal::{FitError, Signal};
use crate::sensor::csv::CsvSignal;
use crate::tools::recording::format::samples::SampleItem;
use crate::tools::recording::read::Recording;

/// A day of samples: no calibration is longer.
const MAX_SAMPLES: usize = 86_400_000;
/// Rows of a CSV whose ticks tell its rate.
const RATE_ROWS: usize = 1000;

/// Reads a CSV file or a recording directory.
pub fn read_signal(path: &Path) -> Result<Signal, FitError> {
    if path.is_dir() {
        recorded_signal(path)
    } else {
        csv_signal(path)
    }
}

/// Reads the `volts` column of a CSV recording (1 kHz; one whose `tick`
/// column shows another rate is refused).
pub fn csv_signal(path: &Path) -> Result<Signal, FitError> {
    let in_file = |e: &dyn fmt::Display| FitError::new(format!("{}: {e}", path.display()));
    if let Some(e) = other_rate(path) {
        return Err(in_file(&e));
    }
    let mut csv = CsvSignal::open(path).map_err(|e| in_file(&e))?;
    let mut volts = Vec::new();
    while let Some(v) = csv.next_sample().map_err(|e| in_file(&e))? {
        volts.push(v);
    }
    Ok(Signal::from_volts(volts))
}

/// What a CSV's `tick` column says of its rate over its first rows, when
/// it is not one row per 1 ms tick. Without the column (or a readable
/// start to it), nothing: the rows are taken as 1 kHz.
fn other_rate(path: &Path) -> Option<String> {
    let mut lines = BufReader::new(File::open(path).ok()?).lines();
    let header = lines.next()?.ok()?;
    let column = (header.trim_start_matches('\u{feff}').split(','))
        .position(|name| name.trim().trim_matches('"') == "tick")?;
    let ticks: Vec<u64> = lines
        .take(RATE_ROWS)
        .map_while(|line| line.ok()?.split(',').nth(column)?.trim().parse().ok())
        .collect();
    let (first, last) = (*ticks.first()?, *ticks.last()?);
    let span = last.checked_sub(first).filter(|&ms| ms > 0)?;
    let hz = 1000.0 * (ticks.len() - 1) as f64 / span as f64;
    ((hz - 1000.0).abs() > 10.0).then(|| {
        format!(
            "its ticks are {hz:.0} Hz ({} rows over {span} ms), where fit reads 1000 Hz (one row per 1 ms tick): resample it to 1 kHz and fit again",
            ticks.len()
        )
    })
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
