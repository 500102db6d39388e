//! IMU recordings as CSV: a header `tick,ax,ay,az,gx,gy,gz` (any subset
//! of the six channels, in any order, named by the header; `tick`
//! required), then one row per sample: the tick in whole ms, increasing,
//! and each value in m/s² (gravity included) or rad/s. A 100 Hz
//! recording has ticks 0, 10, 20, …; the core holds the last sample
//! between them.
//!
//! Values are written as the shortest text that reads back as the same
//! `f64`, so [`read_imu_csv`] of [`write_imu_csv`] gives the samples back
//! bit for bit. A malformed file is one error, on one line, naming the
//! file, the line and the column.

use std::fmt;
use std::io::{self, Write};
use std::path::Path;

use crate::control::Tick;
use crate::control::imu::{CHANNELS, Channel, Channels, ImuSample};
use crate::tools::float_text::push_f64;

/// A recording read from a CSV: the channels its header names (the
/// others read as zero) and its samples, ticks increasing.
#[derive(Debug, Clone, PartialEq)]
pub struct ImuRecording {
    /// The channels the file gives.
    pub channels: Channels,
    /// Its samples.
    pub samples: Vec<(Tick, ImuSample)>,
}

/// What is wrong with an IMU CSV, where. Displayed on one line:
/// `FILE: line L, column C (NAME): MESSAGE`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ImuCsvError {
    /// The file, as given.
    pub file: String,
    /// 1-based line (the header is line 1); 0 for the whole file.
    pub line: u64,
    /// 1-based column and its header name, if one column is wrong.
    pub column: Option<(usize, String)>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for ImuCsvError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: ", self.file)?;
        if self.line > 0 {
            write!(f, "line {}", self.line)?;
            if let Some((column, name)) = &self.column {
                write!(f, ", column {column}")?;
                if !name.is_empty() {
                    write!(f, " ({name})")?;
                }
            }
            f.write_str(": ")?;
        }
        f.write_str(&self.message)
    }
}

impl std::error::Error for ImuCsvError {}

/// The header a full recording has.
pub const FULL_HEADER: &str = "tick,ax,ay,az,gx,gy,gz";

/// Whether the file at `path` is an IMU recording: its header names
/// `tick` and one of the six channels (a breath signal's names `volts`).
pub fn is_imu_csv(path: &Path) -> bool {
    use std::io::BufRead;
    let Ok(file) = std::fs::File::open(path) else {
        return false;
    };
    let mut header = String::new();
    if io::BufReader::new(file).read_line(&mut header).is_err() {
        return false;
    }
    let names: Vec<&str> = header.trim().split(',').map(str::trim).collect();
    names.first() == Some(&"tick") && names.iter().any(|n| Channel::from_name(n).is_some())
}

/// Reads an IMU recording from `path`.
pub fn read_imu_csv(path: &Path) -> Result<ImuRecording, ImuCsvError> {
    let file = path.display().to_string();
    let text = std::fs::read(path).map_err(|e| ImuCsvError {
        file: file.clone(),
        line: 0,
        column: None,
        message: format!("cannot read: {e}"),
    })?;
    let text = String::from_utf8(text).map_err(|_| ImuCsvError {
        file: file.clone(),
        line: 0,
        column: None,
        message: "not UTF-8 text".to_string(),
    })?;
    parse_imu_csv(&text, &file)
}

/// What a header column holds.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Column {
    Tick,
    Value(Channel),
}

/// Reads an IMU recording from `text`, naming it `file` in errors.
pub fn parse_imu_csv(text: &str, file: &str) -> Result<ImuRecording, ImuCsvError> {
    let error = |line: u64, column: Option<(usize, &str)>, message: String| ImuCsvError {
        file: file.to_string(),
        line,
        column: column.map(|(c, name)| (c, name.to_string())),
        message,
    };
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let text = text.strip_suffix('\n').unwrap_or(text);
    let mut lines = text.split('\n').map(|l| l.strip_suffix('\r').unwrap_or(l));
    let expected =
        format!("expected `tick` and any of ax, ay, az, gx, gy, gz, as in `{FULL_HEADER}`");
    let header = match lines.next() {
        Some(h) if !h.trim().is_empty() => h,
        _ => return Err(error(0, None, format!("empty file: {expected}"))),
    };
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    if !names.iter().any(|n| Channel::from_name(n).is_some()) {
        return Err(error(
            1,
            None,
            format!("no IMU channel in the header {header:?}: {expected}"),
        ));
    }
    let mut columns = Vec::with_capacity(names.len());
    let mut channels = Channels::NONE;
    for (i, &name) in names.iter().enumerate() {
        let at = Some((i + 1, name));
        let column = match (name, Channel::from_name(name)) {
            ("tick", _) => Column::Tick,
            (_, Some(channel)) => Column::Value(channel),
            (_, None) => return Err(error(1, at, format!("unknown column: {expected}"))),
        };
        if columns.contains(&column) {
            return Err(error(1, at, "repeated column".to_string()));
        }
        if let Column::Value(channel) = column {
            channels = channels.with(channel);
        }
        columns.push(column);
    }
    if !columns.contains(&Column::Tick) {
        return Err(error(1, None, format!("no `tick` column: {expected}")));
    }
    let mut samples = Vec::new();
    let mut last: Option<Tick> = None;
    for (line, row) in (2..).zip(lines) {
        let fields: Vec<&str> = row.split(',').map(str::trim).collect();
        if fields.len() != columns.len() {
            return Err(error(
                line,
                None,
                format!(
                    "{} field{}, but the header has {}",
                    fields.len(),
                    if fields.len() == 1 { "" } else { "s" },
                    columns.len()
                ),
            ));
        }
        let mut tick = 0;
        let mut values = [0.0; CHANNELS];
        for (i, (&column, field)) in columns.iter().zip(fields).enumerate() {
            let at = Some((i + 1, names[i]));
            match column {
                Column::Tick => {
                    tick = field.parse::<Tick>().map_err(|_| {
                        error(line, at, format!("not a whole number of ms: {field:?}"))
                    })?;
                    if let Some(before) = last.filter(|&b| tick <= b) {
                        return Err(error(
                            line,
                            at,
                            format!("tick {tick} is not after the previous one, {before}"),
                        ));
                    }
                }
                Column::Value(channel) => {
                    values[channel.index()] = field
                        .parse::<f64>()
                        .ok()
                        .filter(|v| v.is_finite())
                        .ok_or_else(|| {
                        error(line, at, format!("not a finite number: {field:?}"))
                    })?;
                }
            }
        }
        last = Some(tick);
        samples.push((tick, ImuSample { values }));
    }
    Ok(ImuRecording { channels, samples })
}

/// Writes `samples` as an IMU CSV of `channels` (the header, then a row
/// per sample), each value as the shortest text that reads back as it.
/// A non-finite value, or ticks not increasing, is an `InvalidInput`
/// error (write to a temporary file and rename it, so that nothing is
/// left half-written: [`crate::tools::output_file::write_whole`]).
pub fn write_imu_csv(
    mut out: impl Write,
    channels: Channels,
    samples: &[(Tick, ImuSample)],
) -> io::Result<()> {
    let invalid = |message: String| io::Error::new(io::ErrorKind::InvalidInput, message);
    if channels.is_empty() {
        return Err(invalid("no channel to write".to_string()));
    }
    let mut row = Vec::with_capacity(160);
    row.extend_from_slice(b"tick");
    for channel in channels.iter() {
        row.push(b',');
        row.extend_from_slice(channel.name().as_bytes());
    }
    row.push(b'\n');
    out.write_all(&row)?;
    let mut last = None;
    for (tick, sample) in samples {
        if last.is_some_and(|l| *tick <= l) {
            return Err(invalid(format!(
                "tick {tick} is not after the previous one"
            )));
        }
        last = Some(*tick);
        row.clear();
        row.extend_from_slice(tick.to_string().as_bytes());
        for channel in channels.iter() {
            let value = sample.get(channel);
            if !value.is_finite() {
                return Err(invalid(format!("{channel} at tick {tick} is {value}")));
            }
            row.push(b',');
            push_f64(&mut row, value);
        }
        row.push(b'\n');
        out.write_all(&row)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    fn message(text: &str) -> String {
        parse_imu_csv(text, "r.csv").unwrap_err().to_string()
    }

    #[test]
    fn any_subset_in_any_order_reads_by_its_header() {
        let r =
            parse_imu_csv("\u{feff}gz, tick ,ax\r\n0.5,0,9.8\r\n-1,10,1e-3\n", "r.csv").unwrap();
        assert_eq!(r.channels, Channels::of(&[Channel::Ax, Channel::Gz]));
        assert_eq!(r.samples.len(), 2);
        assert_eq!(r.samples[1].0, 10);
        assert_eq!(r.samples[1].1.values, [1e-3, 0.0, 0.0, 0.0, 0.0, -1.0]);
    }

    #[test]
    fn each_error_is_one_line_naming_file_line_and_column() {
        let cases = [
            (
                "",
                "r.csv: empty file: expected `tick` and any of ax, ay, az, gx, gy, gz, as in `tick,ax,ay,az,gx,gy,gz`",
            ),
            (
                "tick,volts\n0,1\n",
                "r.csv: line 1: no IMU channel in the header \"tick,volts\": expected `tick` and any of ax, ay, az, gx, gy, gz, as in `tick,ax,ay,az,gx,gy,gz`",
            ),
            (
                "tick,ax,temp\n",
                "r.csv: line 1, column 3 (temp): unknown column: expected `tick` and any of ax, ay, az, gx, gy, gz, as in `tick,ax,ay,az,gx,gy,gz`",
            ),
            (
                "tick,ax,ax\n",
                "r.csv: line 1, column 3 (ax): repeated column",
            ),
            (
                "tick,gx,tick\n",
                "r.csv: line 1, column 3 (tick): repeated column",
            ),
            (
                "gx,gy\n1,2\n",
                "r.csv: line 1: no `tick` column: expected `tick` and any of ax, ay, az, gx, gy, gz, as in `tick,ax,ay,az,gx,gy,gz`",
            ),
            (
                "tick,gx\n0,1\n10,x\n",
                "r.csv: line 3, column 2 (gx): not a finite number: \"x\"",
            ),
            (
                "tick,gx\n0,NaN\n",
                "r.csv: line 2, column 2 (gx): not a finite number: \"NaN\"",
            ),
            (
                "tick,gx\n0.5,1\n",
                "r.csv: line 2, column 1 (tick): not a whole number of ms: \"0.5\"",
            ),
            (
                "tick,gx\n0,1\n10,1\n10,2\n",
                "r.csv: line 4, column 1 (tick): tick 10 is not after the previous one, 10",
            ),
            (
                "tick,gx,gy\n0,1\n",
                "r.csv: line 2: 2 fields, but the header has 3",
            ),
            (
                "tick,gx\n0,1\n\n10,1\n",
                "r.csv: line 3: 1 field, but the header has 2",
            ),
        ];
        for (text, expected) in cases {
            let m = message(text);
            assert_eq!(m, expected, "{text:?}");
            assert!(!m.contains('\n'));
        }
        let missing = read_imu_csv(Path::new("/nonexistent/imu.csv")).unwrap_err();
        assert!(
            missing
                .to_string()
                .starts_with("/nonexistent/imu.csv: cannot read: "),
            "{missing}"
        );
    }

    #[test]
    fn writing_refuses_what_it_could_not_read_back() {
        let nan = ImuSample {
            values: [f64::NAN; CHANNELS],
        };
        assert!(write_imu_csv(Vec::new(), Channels::ALL, &[(0, nan)]).is_err());
        let zero = ImuSample::default();
        assert!(write_imu_csv(Vec::new(), Channels::ALL, &[(5, zero), (5, zero)]).is_err());
        assert!(write_imu_csv(Vec::new(), Channels::NONE, &[]).is_err());
    }

    fn finite() -> impl Strategy<Value = f64> {
        prop_oneof![
            any::<f64>().prop_filter("finite", |x| x.is_finite()),
            -20.0..20.0f64,
            Just(-0.0),
        ]
    }

    proptest! {
        #[test]
        fn read_of_write_gives_the_samples_back_bit_for_bit(
            set in 1u8..64,
            rows in proptest::collection::vec((1u64..50, proptest::array::uniform6(finite())), 0..40),
            first in 0u64..1000,
        ) {
            let channels = Channels::of(
                &Channel::ALL.into_iter().filter(|c| set & 1 << c.index() != 0).collect::<Vec<_>>(),
            );
            let mut tick = first;
            let samples: Vec<(Tick, ImuSample)> = rows
                .into_iter()
                .map(|(step, mut values)| {
                    tick += step;
                    for c in Channel::ALL.into_iter().filter(|&c| !channels.contains(c)) {
                        values[c.index()] = 0.0;
                    }
                    (tick, ImuSample { values })
                })
                .collect();
            let mut text = Vec::new();
            write_imu_csv(&mut text, channels, &samples).unwrap();
            let back = parse_imu_csv(std::str::from_utf8(&text).unwrap(), "t.csv").unwrap();
            prop_assert_eq!(back.channels, channels);
            prop_assert_eq!(back.samples.len(), samples.len());
            for ((t1, a), (t2, b)) in back.samples.iter().zip(&samples) {
                prop_assert_eq!(t1, t2);
                prop_assert_eq!(a.values.map(f64::to_bits), b.values.map(f64::to_bits));
            }
        }
    }
}
