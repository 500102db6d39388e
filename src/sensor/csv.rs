//! Recorded signals: a CSV with a header row and a `volts` column (other
//! columns ignored), one row per 1 ms sample. Read as a stream, so an
//! hour-long recording never sits in memory. A malformed row is an error
//! naming its file and line; no row is ever skipped.
//!
//! [`CsvSignal`] reads a recording as fast as asked (`replay`);
//! [`CsvSensor`] plays one in real time, one sample per millisecond, from
//! its own thread (`run --sensor csv:PATH`).

use std::fmt;
use std::fs::File;
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use crate::sensor::ring::{RingSamples, SAMPLE_RING, ring};
use crate::sensor::{Producer, Sensor, SensorError, Started};

/// The period of a recording's samples: 1 ms.
const SAMPLE_PERIOD: Duration = Duration::from_millis(1);

/// A problem with a recording, naming the line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CsvError {
    /// 1-based line in the file (the header is line 1); 0 if unknown.
    pub line: u64,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for CsvError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line > 0 {
            write!(f, "line {}: {}", self.line, self.message)
        } else {
            f.write_str(&self.message)
        }
    }
}

impl std::error::Error for CsvError {}

/// Streams the `volts` column of a CSV recording.
pub struct CsvSignal<R: Read> {
    reader: csv::Reader<R>,
    column: usize,
    record: csv::StringRecord,
}

impl CsvSignal<BufReader<File>> {
    /// Opens a recording file.
    pub fn open(path: &Path) -> Result<Self, CsvError> {
        let file = File::open(path).map_err(|e| CsvError {
            line: 0,
            message: format!("cannot open {}: {e}", path.display()),
        })?;
        CsvSignal::new(BufReader::with_capacity(1 << 16, file))
    }
}

impl<R: Read> CsvSignal<R> {
    /// Reads the header and finds the `volts` column.
    pub fn new(input: R) -> Result<Self, CsvError> {
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(true)
            .trim(csv::Trim::All)
            .from_reader(input);
        let headers = reader.headers().map_err(|e| error(&e))?;
        let column = headers
            .iter()
            .position(|h| h == "volts")
            .ok_or_else(|| CsvError {
                line: 1,
                message: format!(
                    "the header has no `volts` column (found: {})",
                    headers.iter().collect::<Vec<_>>().join(", ")
                ),
            })?;
        Ok(CsvSignal {
            reader,
            column,
            record: csv::StringRecord::new(),
        })
    }

    /// The next sample, `Ok(None)` at the end. `NaN` and `inf` are read as
    /// such (the detector treats them as sensor faults); anything else that
    /// is not a number is an error.
    pub fn next_sample(&mut self) -> Result<Option<f64>, CsvError> {
        if !self
            .reader
            .read_record(&mut self.record)
            .map_err(|e| error(&e))?
        {
            return Ok(None);
        }
        let line = self.record.position().map_or(0, |p| p.line());
        let field = self.record.get(self.column).unwrap_or("");
        if field.is_empty() {
            return Err(CsvError {
                line,
                message: "the volts value is empty".into(),
            });
        }
        field.parse::<f64>().map(Some).map_err(|_| CsvError {
            line,
            message: format!("the volts value {field:?} is not a number"),
        })
    }
}

/// A recording played in real time as a sensor.
pub struct CsvSensor {
    path: PathBuf,
    signal: CsvSignal<BufReader<File>>,
}

impl CsvSensor {
    /// Opens the recording and reads its header.
    pub fn open(path: &Path) -> Result<CsvSensor, SensorError> {
        let file = File::open(path).map_err(|e| SensorError::opening(path, e))?;
        let signal = CsvSignal::new(BufReader::with_capacity(1 << 16, file))
            .map_err(|e| bad_data(path, &e))?;
        Ok(CsvSensor {
            path: path.to_path_buf(),
            signal,
        })
    }
}

/// A bad row as a sensor error naming the file and the line.
fn bad_data(path: &Path, e: &CsvError) -> SensorError {
    SensorError::BadData {
        context: if e.line > 0 {
            format!("{} line {}", path.display(), e.line)
        } else {
            path.display().to_string()
        },
        message: e.message.clone(),
    }
}

impl Sensor for CsvSensor {
    type Samples = RingSamples;

    fn describe(&self) -> String {
        format!("csv:{}", self.path.display())
    }

    /// Starts the thread that plays one sample per millisecond into the
    /// ring until the recording ends or the sensor is stopped.
    fn start(self) -> Result<Started<RingSamples>, SensorError> {
        let (mut feed, samples) = ring(SAMPLE_RING);
        let CsvSensor { path, mut signal } = self;
        let producer = Producer::spawn("sensor", move |stop| {
            // Deadlines from the start, so lateness never accumulates.
            let mut deadline = Instant::now();
            while let Some(volts) = signal.next_sample().map_err(|e| bad_data(&path, &e))? {
                if stop.load(Ordering::Relaxed) {
                    break;
                }
                deadline += SAMPLE_PERIOD;
                if let Some(wait) = deadline.checked_duration_since(Instant::now()) {
                    std::thread::sleep(wait);
                }
                // Full: the loop is behind; the sample is lost and the loop
                // counts what it discards.
                feed.push(volts);
            }
            Ok(())
        })?;
        Ok(Started { samples, producer })
    }
}

fn error(e: &csv::Error) -> CsvError {
    let line = e.position().map_or(0, |p| p.line());
    let message = match e.kind() {
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => format!("{len} fields, the header has {expected_len}"),
        csv::ErrorKind::Utf8 { .. } => "not valid UTF-8".into(),
        _ => e.to_string(),
    };
    CsvError { line, message }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read_all(text: &str) -> Result<Vec<f64>, CsvError> {
        let mut s = CsvSignal::new(text.as_bytes())?;
        let mut out = Vec::new();
        while let Some(v) = s.next_sample()? {
            out.push(v);
        }
        Ok(out)
    }

    #[test]
    fn reads_the_volts_column_only() {
        let v = read_all("tick,volts,note\n0,2.5,a\n1, 3.25 ,b\n2,NaN,c\n").unwrap();
        assert_eq!(v[..2], [2.5, 3.25]);
        assert!(v[2].is_nan());
        assert_eq!(read_all("volts\n1\n").unwrap(), [1.0]);
    }

    #[test]
    fn bad_rows_name_their_line() {
        let e = read_all("tick,volts\n0,2.5\n1,abc\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "line 3: the volts value \"abc\" is not a number"
        );
        let e = read_all("tick,volts\n0,2.5\n1,2.5\n2\n").unwrap_err();
        assert_eq!(e.to_string(), "line 4: 1 fields, the header has 2");
        let e = read_all("tick,volts\n0,\n").unwrap_err();
        assert_eq!(e.to_string(), "line 2: the volts value is empty");
        let e = read_all("tick,voltage\n0,2.5\n").unwrap_err();
        assert_eq!(e.line, 1);
        assert!(e.message.contains("no `volts` column"), "{e}");
    }
}
