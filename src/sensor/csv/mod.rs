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
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;

use self::breaks::BOM;
pub use self::decimal::parse_volts;
use self::decimal::{decimal_prefix, fast_decimal};
use self::lines::{Line, PlainLine, PlainLines, Unread};
use crate::clock::MonotonicClock;
use crate::sensor::pacer::Pacer;
use crate::sensor::ring::{RingSamples, SAMPLE_RING, ring};
use crate::sensor::{Producer, Sensor, SensorError, Started};

mod breaks;
mod decimal;
mod lines;

/// The period of a recording's samples: 1 ms.
const SAMPLE_PERIOD_NS: u64 = 1_000_000;

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

/// Streams the `volts` column of a CSV recording to the values and errors
/// the `csv` crate's trimmed `StringRecord`s and std's parser give (the
/// tests hold those as the oracle), each error on the line an editor
/// shows. Plain lines, nearly all, are split at their commas without the
/// parser; from the first that is not (a quote, a lone `\r`, a line
/// longer than the buffer) to the end, the `csv` crate reads the rest.
pub struct CsvSignal<R: Read> {
    rows: Rows<R>,
    column: usize,
    /// Fields in the header: every row must have as many.
    fields: usize,
    /// Two fields, the volts second: a typical line, `digits,decimal\n`,
    /// is read in one pass.
    tick_then_volts: bool,
}

/// Where the rows come from.
enum Rows<R: Read> {
    /// Plain lines; `line` is the number of the next one.
    Lines { lines: PlainLines<R>, line: u64 },
    /// The `csv` crate (its input numbers its rows' lines).
    Csv {
        reader: csv::Reader<Unread<R>>,
        record: csv::ByteRecord,
    },
    /// Between the two (never seen outside [`CsvSignal::switch_to_csv`]).
    Switching,
}

/// The plain lines' buffer: 64 KiB.
const LINE_BUFFER: usize = 1 << 16;

impl CsvSignal<File> {
    /// Opens a recording file.
    pub fn open(path: &Path) -> Result<Self, CsvError> {
        let file = File::open(path).map_err(|e| CsvError {
            line: 0,
            message: format!("cannot open {}: {e}", path.display()),
        })?;
        // (Read a buffer at a time: no `BufReader` needed.)
        CsvSignal::new(file)
    }
}

impl<R: Read> CsvSignal<R> {
    /// Reads the header and finds the `volts` column.
    pub fn new(input: R) -> Result<Self, CsvError> {
        Self::with_buffer(input, LINE_BUFFER)
    }

    /// [`CsvSignal::new`] with plain lines of at most `capacity` bytes.
    fn with_buffer(input: R, capacity: usize) -> Result<Self, CsvError> {
        let mut lines = PlainLines::new(input, capacity);
        let (plain_header, read_one) = match lines.next_line().map_err(io_error)? {
            Line::Plain(header) => (plain_names(header.bytes), true),
            Line::Other | Line::End => (None, false),
        };
        if plain_header.is_none() && read_one {
            lines.put_back();
        }
        let (rows, names, header_line): (Rows<R>, Vec<String>, u64) = match plain_header {
            Some(names) => (Rows::Lines { lines, line: 2 }, names, 1),
            None => {
                // Not plain (quoted, empty lines first, not UTF-8): the
                // `csv` crate reads the whole file, header included.
                let mut reader = csv::ReaderBuilder::new()
                    .has_headers(true)
                    .from_reader(lines.into_rest());
                let (names, at) = match reader.headers() {
                    Ok(headers) => (
                        headers.iter().map(|h| h.trim().to_owned()).collect(),
                        headers.position().map_or(0, csv::Position::byte),
                    ),
                    Err(e) => return Err(parser_error(&e, reader.get_mut())),
                };
                let header_line = reader.get_mut().line_of(at);
                let record = csv::ByteRecord::new();
                (Rows::Csv { reader, record }, names, header_line)
            }
        };
        let column = names
            .iter()
            .position(|h| *h == "volts")
            .ok_or_else(|| CsvError {
                line: header_line,
                message: format!(
                    "the header has no `volts` column (found: {})",
                    names.join(", ")
                ),
            })?;
        Ok(CsvSignal {
            rows,
            column,
            fields: names.len(),
            tick_then_volts: names.len() == 2 && column == 1,
        })
    }

    /// The next sample, `Ok(None)` at the end. `NaN` and `inf` are read as
    /// such (the detector treats them as sensor faults); anything else that
    /// is not a number is an error.
    pub fn next_sample(&mut self) -> Result<Option<f64>, CsvError> {
        loop {
            let (row, line) = match &mut self.rows {
                Rows::Lines { lines, line } => {
                    if self.tick_then_volts
                        && let Some(volts) = lines.next_tick_and(decimal_prefix)
                    {
                        // A typical line: its value as `read_volts` would
                        // read it (two fields, ASCII, a plain decimal).
                        *line += 1;
                        return Ok(Some(volts));
                    }
                    match lines.next_line() {
                        Err(e) => return Err(io_error(e)),
                        Ok(Line::End) => return Ok(None),
                        Ok(Line::Other) => {
                            self.switch_to_csv();
                            continue;
                        }
                        // The parser skips empty lines.
                        Ok(Line::Plain(row)) if row.bytes.is_empty() => {
                            *line += 1;
                            continue;
                        }
                        Ok(Line::Plain(row)) => {
                            *line += 1;
                            (Row::Plain(row), *line - 1)
                        }
                    }
                }
                Rows::Csv { reader, record } => {
                    match reader.read_byte_record(record) {
                        Ok(true) => {}
                        Ok(false) => return Ok(None),
                        Err(e) => return Err(parser_error(&e, reader.get_mut())),
                    }
                    let at = record.position().map_or(0, csv::Position::byte);
                    (Row::Record(record), reader.get_mut().line_of(at))
                }
                Rows::Switching => return Ok(None),
            };
            return read_volts(row, line, self.column, self.fields);
        }
    }

    /// From the line not plain on, the `csv` crate reads the rest.
    fn switch_to_csv(&mut self) {
        if let Rows::Lines { lines, line } = std::mem::replace(&mut self.rows, Rows::Switching) {
            let reader = csv::ReaderBuilder::new()
                .has_headers(false)
                // The fields are counted here, as the plain lines' are.
                .flexible(true)
                .from_reader(lines.into_rest_mid_file(line));
            self.rows = Rows::Csv {
                reader,
                record: csv::ByteRecord::new(),
            };
        }
    }
}

/// The names in a plain header line, trimmed; `None` if the parser is to
/// read it (empty: it skips empty lines; a byte order mark: it drops it;
/// not UTF-8: it refuses it).
fn plain_names(header: &[u8]) -> Option<Vec<String>> {
    if header.is_empty() || header.starts_with(BOM) {
        return None;
    }
    let header = std::str::from_utf8(header).ok()?;
    Some(
        header
            .split(',')
            .map(|name| name.trim().to_owned())
            .collect(),
    )
}

/// One row's bytes.
enum Row<'a> {
    Plain(PlainLine<'a>),
    Record(&'a csv::ByteRecord),
}

impl Row<'_> {
    fn bytes(&self) -> &[u8] {
        match self {
            Row::Plain(line) => line.bytes,
            Row::Record(record) => record.as_slice(),
        }
    }

    fn ascii(&self) -> bool {
        match self {
            Row::Plain(line) => line.ascii,
            Row::Record(record) => record.as_slice().is_ascii(),
        }
    }

    fn fields(&self) -> usize {
        match self {
            Row::Plain(line) => line.fields,
            Row::Record(record) => record.len(),
        }
    }

    fn field(&self, column: usize) -> &[u8] {
        match self {
            Row::Plain(line) => line.field(column),
            Row::Record(record) => record.get(column).unwrap_or(b""),
        }
    }
}

/// The volts of `row`, on line `line` (with `fields` fields in the
/// header, the value in `column`), or what is wrong with it.
fn read_volts(
    row: Row<'_>,
    line: u64,
    column: usize,
    fields: usize,
) -> Result<Option<f64>, CsvError> {
    if row.fields() != fields {
        return Err(CsvError {
            line,
            message: unequal_lengths(row.fields(), fields),
        });
    }
    // Nearly every row: ASCII, so valid UTF-8, and a plain decimal, so
    // nothing to trim and what `parse_volts` below would return.
    let field = row.field(column);
    if row.ascii()
        && let Some(volts) = fast_decimal(field)
    {
        return Ok(Some(volts));
    }
    // A row that is not UTF-8 is refused, as a StringRecord refuses
    // it, whichever column holds the bad bytes.
    if !row.ascii() && std::str::from_utf8(row.bytes()).is_err() {
        return Err(CsvError {
            line,
            message: "not valid UTF-8".into(),
        });
    }
    // Valid: the whole row is.
    let field = std::str::from_utf8(field).unwrap_or("").trim();
    if field.is_empty() {
        return Err(CsvError {
            line,
            message: "the volts value is empty".into(),
        });
    }
    parse_volts(field).map(Some).ok_or_else(|| CsvError {
        line,
        message: format!("the volts value {field:?} is not a number"),
    })
}

/// A recording played in real time as a sensor.
pub struct CsvSensor {
    path: PathBuf,
    signal: CsvSignal<File>,
}

impl CsvSensor {
    /// Opens the recording and reads its header.
    pub fn open(path: &Path) -> Result<CsvSensor, SensorError> {
        let file = File::open(path).map_err(|e| SensorError::opening(path, e))?;
        let signal = CsvSignal::new(file).map_err(|e| bad_data(path, &e))?;
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
        let producer = Producer::spawn("sensor", move |stop, log| {
            // A row a millisecond from the loop's first tick; after a late
            // wake-up the rows owed come at once (the ring keeps the
            // newest two).
            feed.wait_for_reader(&stop);
            let mut pacer = Pacer::new(MonotonicClock, SAMPLE_PERIOD_NS, true);
            log.due_on("its row's deadline");
            while let Some(volts) = signal.next_sample().map_err(|e| bad_data(&path, &e))? {
                if stop.load(Ordering::Relaxed) {
                    break;
                }
                log.woke(pacer.wait());
                // Full: the loop is behind; the sample is lost and the loop
                // counts what it discards.
                feed.push(volts);
            }
            Ok(())
        })?;
        Ok(Started { samples, producer })
    }
}

/// A row's fields are not the header's.
fn unequal_lengths(fields: usize, header: usize) -> String {
    format!("{fields} fields, the header has {header}")
}

/// An error of the `csv` crate, on the line its input places it.
fn parser_error<R: Read>(e: &csv::Error, input: &mut Unread<R>) -> CsvError {
    error(e, |byte| input.line_of(byte))
}

/// The input could not be read (no line).
fn io_error(e: std::io::Error) -> CsvError {
    error(&e.into(), |_| 0)
}

/// An error of the `csv` crate; `line_of` turns its byte into its line.
fn error(e: &csv::Error, line_of: impl FnOnce(u64) -> u64) -> CsvError {
    let line = e.position().map_or(0, |p| line_of(p.byte()));
    let message = match e.kind() {
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => unequal_lengths(*len as usize, *expected_len as usize),
        csv::ErrorKind::Utf8 { .. } => "not valid UTF-8".into(),
        _ => e.to_string(),
    };
    CsvError { line, message }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The oracle: recordings read by the `csv` crate's trimmed
    /// `StringRecord`s and std's parser, each error on the line of the
    /// row's first byte, counted in the whole text.
    struct Oracle<'a> {
        reader: csv::Reader<&'a [u8]>,
        bytes: &'a [u8],
        column: usize,
        record: csv::StringRecord,
    }

    /// The line of what starts at `byte` of `bytes`, or after the line
    /// breaks there (where the parser leaves a row: before the empty lines
    /// it skips, on the `\n` of a `\r\n`) and a byte order mark at the
    /// start: one more than the `\n`s and lone `\r`s before it.
    fn line_at(bytes: &[u8], byte: u64) -> u64 {
        let mut at = byte as usize;
        if at == 0 && bytes.starts_with(BOM) {
            at = BOM.len();
        }
        while matches!(bytes.get(at), Some(b'\r' | b'\n')) {
            at += 1;
        }
        let breaks = (0..at.min(bytes.len()))
            .filter(|&i| match bytes[i] {
                b'\n' => true,
                b'\r' => bytes.get(i + 1) != Some(&b'\n'),
                _ => false,
            })
            .count();
        1 + breaks as u64
    }

    impl<'a> Oracle<'a> {
        fn new(bytes: &'a [u8]) -> Result<Self, CsvError> {
            let mut reader = csv::ReaderBuilder::new()
                .has_headers(true)
                .trim(csv::Trim::All)
                .from_reader(bytes);
            let headers = reader
                .headers()
                .map_err(|e| error(&e, |b| line_at(bytes, b)))?;
            let column = headers
                .iter()
                .position(|h| h == "volts")
                .ok_or_else(|| CsvError {
                    line: line_at(bytes, headers.position().map_or(0, |p| p.byte())),
                    message: format!(
                        "the header has no `volts` column (found: {})",
                        headers.iter().collect::<Vec<_>>().join(", ")
                    ),
                })?;
            Ok(Oracle {
                reader,
                bytes,
                column,
                record: csv::StringRecord::new(),
            })
        }

        fn next_sample(&mut self) -> Result<Option<f64>, CsvError> {
            let bytes = self.bytes;
            if !self
                .reader
                .read_record(&mut self.record)
                .map_err(|e| error(&e, |b| line_at(bytes, b)))?
            {
                return Ok(None);
            }
            let line = line_at(bytes, self.record.position().map_or(0, |p| p.byte()));
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

    /// Everything a reader makes of `bytes`: the samples' bits, then the
    /// error or the end. `Some(capacity)`: [`CsvSignal`], with plain
    /// lines of at most `capacity` bytes; `None`: the oracle.
    fn outcome(bytes: &[u8], fast: Option<usize>) -> (Vec<u64>, Option<CsvError>) {
        let mut values = Vec::new();
        let mut next: Box<dyn FnMut() -> Result<Option<f64>, CsvError>> =
            if let Some(capacity) = fast {
                match CsvSignal::with_buffer(bytes, capacity) {
                    Ok(mut s) => Box::new(move || s.next_sample()),
                    Err(e) => return (values, Some(e)),
                }
            } else {
                match Oracle::new(bytes) {
                    Ok(mut s) => Box::new(move || s.next_sample()),
                    Err(e) => return (values, Some(e)),
                }
            };
        loop {
            match next() {
                Ok(Some(v)) => values.push(v.to_bits()),
                Ok(None) => return (values, None),
                Err(e) => return (values, Some(e)),
            }
        }
    }

    /// Buffers from one byte (no line is plain, the `csv` crate reads
    /// all) through ones that end mid-line to the real one.
    const CAPACITIES: [usize; 6] = [1, 4, 7, 12, 31, LINE_BUFFER];

    fn same_as_before(bytes: &[u8]) {
        let oracle = outcome(bytes, None);
        for capacity in CAPACITIES {
            assert_eq!(
                outcome(bytes, Some(capacity)),
                oracle,
                "{:?}, buffer {capacity}",
                String::from_utf8_lossy(bytes)
            );
        }
    }

    #[test]
    fn recordings_read_as_they_always_did() {
        for text in [
            &b"tick,volts\n0,2.5\n1,2.25\n"[..],
            b"tick,volts\r\n0,2.5\r\n1,2.25\r\n",
            b"tick,volts\n0,2.5\n\n\n1,abc\n",
            b"\n\ntick,volts\n0,2.5\n",
            b"\xEF\xBB\xBFtick,volts\n0,2.5\n",
            b"tick,volts\n0,2.5\n\xEF\xBB\xBF1,2.5\n",
            b"tick,volts\n0,\"2.5\"\n1,3\n2,x\n",
            b"tick,volts\n0,2.5\r1,3\n2\n",
            b"\"tick\",\" volts \"\n0,2.5\n1,\n",
            b"tick,volts\n0,2.5",
            b"tick,volts\n0,2.5\r",
            b"tick,volts\n0, 2.5 \n1,\t3\xc2\xa0\n",
            b"tick,volts\n0,\"1\n2\",3\n4,5\n6\n",
            b"",
            b"volts",
            b"tick\n0\n",
            b"tick,volts\n0,2.5,9\n",
            b"tick,volts\n0,\xff\n",
            b"tick,volts\n0,2.5\n1,\"3\"\n2,2.75\n3\n",
            b"tick,volts\n0,2.5\n1,3\r2,4\n3,x,\n",
            b"tick,volts\n0,2.5\n\r\n\n1,3\n,\n",
            b"tick,volts\n0,2.5\n1,3\n2,\xff\n",
            b"tick,volts\n0,2.5\n12345678901234567890,1\n2,\n",
            b"tick,volts\n0,2.5\n1,\"a\n\nb\",3\n4,5,6\n",
            b"tick,volts\r\n\r\n0,2.5\r\n\"1\",3\r\n4\r\n",
            // Typical lines (read in one pass) beside ones that only
            // look like them.
            b"tick,volts\n0,2.5\n1,2.5.1\n2,-0.5\n3,+7\n4,.5\n5,5.\n6,-\n7,1e3\n",
            b"tick,volts\n0,1234567890123456\n1,0.0000000000000000000001\n2,007\n",
            b"tick,volts\n0,2.5\n1,3\r\n2,4\n3,2.5 \n4,2.5,\n5 ,1\n,1\n",
            b"tick,volts\n0,2.5\n1,+-2\n",
        ] {
            same_as_before(text);
        }
    }

    proptest::proptest! {
        /// Any text made of what CSV recordings are made of — digits,
        /// points, signs, commas, newlines, carriage returns, quotes,
        /// spaces, letters, a byte order mark, bytes that are not UTF-8 —
        /// reads to the same samples and the same error, on the same line.
        #[test]
        fn any_text_reads_as_it_always_did(
            header in proptest::sample::select(vec![
                "tick,volts\n", "volts\n", "tick,volts,note\n", " tick , volts \r\n",
                "\"tick\",volts\n", "tick,voltage\n", "\n",
            ]),
            pieces in proptest::collection::vec(proptest::sample::select(vec![
                "0", "1", "2", "5", ".", "-", "+", "e", ",", "\n", "\r\n", "\r", "\"", " ",
                "\t", "a", "NaN", "inf", "\u{feff}", "\u{a0}", "\u{fffd}", "2.5,", "\n1,",
                "\n3599999,", "0.0125\n", "-1.5\n", "4.999999999999999\n",
            ]), 0..60),
            bad_byte in proptest::option::of(0usize..200),
        ) {
            let mut bytes = header.as_bytes().to_vec();
            for piece in &pieces {
                bytes.extend_from_slice(piece.as_bytes());
            }
            if let Some(at) = bad_byte {
                let at = at.min(bytes.len());
                bytes.insert(at, 0xff);
            }
            let oracle = outcome(&bytes, None);
            for capacity in CAPACITIES {
                proptest::prop_assert_eq!(&outcome(&bytes, Some(capacity)), &oracle, "buffer {}", capacity);
            }
        }
    }

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
    fn a_row_that_is_not_utf8_is_refused_with_its_line_whatever_column() {
        for text in [
            &b"tick,volts,note\n0,2.5,a\n1,2.5,\xff\n"[..],
            &b"tick,volts\n0,2.5\n1,2.\xff5\n"[..],
        ] {
            let mut s = CsvSignal::new(text).unwrap();
            assert_eq!(s.next_sample().unwrap(), Some(2.5));
            assert_eq!(
                s.next_sample().unwrap_err().to_string(),
                "line 3: not valid UTF-8"
            );
        }
    }

    /// A bad row's error names the line an editor shows it on, however
    /// the file's lines end (`\n`, `\r\n`, a lone `\r`), whatever empty
    /// lines come before it, after a value quoted over two lines, and
    /// whichever reader (plain lines or the `csv` crate, from any buffer)
    /// reads it.
    #[test]
    fn bad_rows_name_their_line_however_lines_end() {
        for (text, line) in [
            // Windows line endings.
            (&b"tick,volts\r\n0,2.5\r\n1,abc\r\n"[..], 3),
            (b"tick,volts\r\n0,2.5\r\n1\r\n", 3),
            // Empty lines before the row.
            (b"tick,volts\n0,2.5\n\n\n1,abc\n", 5),
            (b"tick,volts\r\n0,2.5\r\n\r\n1,abc\r\n", 4),
            // Old Mac line endings: a lone `\r` ends a line.
            (b"tick,volts\n0,2.5\r1,3\r\r2,x\n", 5),
            // A value quoted over two lines; the rows after it.
            (b"tick,note,volts\n0,\"a\nb\",3\n\n4,5,x\n", 5),
            (b"tick,note,volts\r\n0,\"a\r\nb\",3\r\n4,5,\r\n", 4),
            // Empty lines, or a byte order mark and a quote, before the header.
            (b"\n\ntick,volts\n0,2.5\n1,x\n", 5),
            (b"\xEF\xBB\xBF\"tick\",volts\r\n0,1\r\n\r\n1,x\r\n", 4),
            (b"\n\n\"tick\",volts\r\n0,2.5\r\n\r\n2\r\n", 6),
            (b"\n\ntick,voltage\n0,2.5\n", 3),
            (b"\xEF\xBB\xBF\n\"tick\",voltage\n0,2.5\n", 2),
            // After the `csv` crate takes over mid-file (a quote).
            (b"tick,volts\n0,2.5\n1,\"3\"\n\n2,x\n", 5),
            (b"tick,volts\r\n0,2.5\r\n1,\"3\"\r\n\r\n\r\n2,x\r\n", 6),
            (b"tick,volts\n0,2.5\n1,\"3\"\n2,4\n3\n", 5),
        ] {
            for capacity in CAPACITIES {
                let (_, e) = outcome(text, Some(capacity));
                assert_eq!(
                    e.as_ref().map(|e| e.line),
                    Some(line),
                    "{:?}, buffer {capacity}: {e:?}",
                    String::from_utf8_lossy(text)
                );
            }
        }
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
