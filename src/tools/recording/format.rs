//! The recording's two binary streams: `samples.bin` (the core's input,
//! tick by tick) and `commands.bin` (the 100 Hz arm commands the core
//! produced). Compact, exact and checked:
//!
//! * **exact**: every `f64` is stored as its 8 bits (NaN payloads and
//!   `-0.0` included), every tick number is kept, so replay makes exactly
//!   the calls the control tick made;
//! * **compact**: runs are counted, not repeated. A sample-and-hold
//!   sensor repeats its value for many ticks: one `REPEAT n` op. A tick
//!   without a sample, a skipped tick or a stall costs a varint, not a
//!   record. Worst case (a new value every tick, a noisy 1 kHz analog
//!   sensor): 9 bytes a tick, 32.4 MB an hour;
//! * **checked**: a header (magic and version) and an end marker with the
//!   CRC-32 of everything before it, so a truncated or corrupted file is
//!   an error naming the offset, never a silent wrong replay.
//!
//! ```text
//! header   "SIPNPUFF" kind ('S' or 'C') version (1)
//! samples  0x01 bits:u64le    one tick, a new value          0x02 n   n ticks repeating the last value
//!          0x03 n             n ticks without a sample        0x04 n   n ticks skipped before the next
//!          0x05 t             the next tick is t (absolute)   0x06     begin_stop after the last tick
//!          0x07 n             n ticks lost (not recorded)
//! commands 0x00–0x7f mask Δtick [bits:u64le per set bit]       one command: the mask says which of
//!                                                              v(3), ω(3), fingers changed
//!          0x80 seq           the next command's number       0x81 n   n commands lost
//! end      0xff crc32:u32le   CRC-32 (IEEE) of every byte before the CRC
//! ```
//!
//! `n`, `t`, `seq` and `Δtick` are LEB128 varints; a tick follows the
//! previous one (`+1`) unless a gap says otherwise; a command's number
//! follows the previous (`+1`), its tick is the previous one plus `Δtick`,
//! and an unchanged component is the previous command's (all start at
//! `+0.0`).

use std::fmt;
use std::io::{self, Read, Write};

use crate::control::Tick;
use crate::control::motion::stream::ArmCommand;
use crate::rt::telemetry::{CoreInput, CoreSample};

/// The version of both streams this build writes and reads.
pub const FORMAT_VERSION: u8 = 1;
/// Every stream starts with these bytes.
pub const MAGIC: &[u8; 8] = b"SIPNPUFF";
/// Bytes of the header.
pub const HEADER_BYTES: u64 = 10;
/// Bytes of the end marker.
pub const END_BYTES: u64 = 5;

const VALUE: u8 = 0x01;
const REPEAT: u8 = 0x02;
const MISSING: u8 = 0x03;
const GAP: u8 = 0x04;
const AT_TICK: u8 = 0x05;
const STOP: u8 = 0x06;
const LOST_TICKS: u8 = 0x07;
const SEQ: u8 = 0x80;
const LOST_COMMANDS: u8 = 0x81;
const END: u8 = 0xff;

/// Which stream a file holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stream {
    /// `samples.bin`.
    Samples,
    /// `commands.bin`.
    Commands,
}

impl Stream {
    fn kind(self) -> u8 {
        match self {
            Stream::Samples => b'S',
            Stream::Commands => b'C',
        }
    }

    /// The header of this stream.
    pub fn header(self) -> [u8; 10] {
        let mut h = [0u8; 10];
        h[..8].copy_from_slice(MAGIC);
        h[8] = self.kind();
        h[9] = FORMAT_VERSION;
        h
    }
}

// ------------------------------------------------------------------ CRC-32

/// CRC-32 (IEEE 802.3, as zlib and PNG), table-driven.
#[derive(Debug, Clone, Copy)]
pub struct Crc32(u32);

const CRC_TABLE: [u32; 256] = {
    let mut table = [0u32; 256];
    let mut i = 0;
    while i < 256 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
            k += 1;
        }
        table[i] = c;
        i += 1;
    }
    table
};

impl Default for Crc32 {
    fn default() -> Self {
        Crc32(0xFFFF_FFFF)
    }
}

impl Crc32 {
    /// Adds bytes.
    pub fn update(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = CRC_TABLE[usize::from((self.0 as u8) ^ b)] ^ (self.0 >> 8);
        }
    }

    /// The CRC of the bytes so far.
    pub fn value(&self) -> u32 {
        !self.0
    }
}

// ------------------------------------------------------------------ writing

fn varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

fn op(out: &mut Vec<u8>, tag: u8, n: u64) {
    out.push(tag);
    varint(out, n);
}

/// Encodes the core's inputs into `samples.bin` ops (not the header or
/// end marker: [`StreamFile`] writes those). Runs are held until they
/// end; [`SampleEncoder::flush`] writes them out.
#[derive(Debug, Default)]
pub struct SampleEncoder {
    next_tick: Tick,
    last_bits: Option<u64>,
    repeat: u64,
    missing: u64,
}

impl SampleEncoder {
    /// Appends one tick's input.
    pub fn input(&mut self, out: &mut Vec<u8>, input: &CoreInput) {
        if input.tick != self.next_tick {
            self.flush(out);
            if input.tick > self.next_tick {
                op(out, GAP, input.tick - self.next_tick);
            } else {
                op(out, AT_TICK, input.tick);
            }
        }
        match input.sample {
            CoreSample::Volts(v) if self.last_bits == Some(v.to_bits()) => {
                if self.missing > 0 {
                    self.flush(out);
                }
                self.repeat += 1;
            }
            CoreSample::Volts(v) => {
                self.flush(out);
                out.push(VALUE);
                out.extend_from_slice(&v.to_bits().to_le_bytes());
                self.last_bits = Some(v.to_bits());
            }
            CoreSample::Missing => {
                if self.repeat > 0 {
                    self.flush(out);
                }
                self.missing += 1;
            }
        }
        self.next_tick = input.tick.wrapping_add(1);
        if input.began_stop {
            self.flush(out);
            out.push(STOP);
        }
    }

    /// Appends a mark for `n` ticks that were lost before reaching the
    /// recording.
    pub fn lost(&mut self, out: &mut Vec<u8>, n: u64) {
        if n > 0 {
            self.flush(out);
            op(out, LOST_TICKS, n);
        }
    }

    /// Ticks in the runs held (not yet in the ops).
    pub fn held(&self) -> u64 {
        self.repeat + self.missing
    }

    /// Writes out the runs held.
    pub fn flush(&mut self, out: &mut Vec<u8>) {
        if self.repeat > 0 {
            op(out, REPEAT, self.repeat);
            self.repeat = 0;
        }
        if self.missing > 0 {
            op(out, MISSING, self.missing);
            self.missing = 0;
        }
    }
}

/// The 7 components of a command, as bits.
fn components(c: &ArmCommand) -> [u64; 7] {
    let [v0, v1, v2] = c.linear;
    let [w0, w1, w2] = c.angular;
    [v0, v1, v2, w0, w1, w2, c.fingers].map(f64::to_bits)
}

/// Encodes arm commands into `commands.bin` ops.
#[derive(Debug, Default)]
pub struct CommandEncoder {
    next_seq: u64,
    last_tick: Tick,
    last: [u64; 7],
}

impl CommandEncoder {
    /// Appends one command.
    pub fn command(&mut self, out: &mut Vec<u8>, c: &ArmCommand) {
        if c.seq != self.next_seq {
            op(out, SEQ, c.seq);
        }
        let bits = components(c);
        let mut mask = 0u8;
        for (i, (new, old)) in bits.iter().zip(&self.last).enumerate() {
            if new != old {
                mask |= 1 << i;
            }
        }
        op(out, mask, c.tick.wrapping_sub(self.last_tick));
        for (i, b) in bits.iter().enumerate() {
            if mask & (1 << i) != 0 {
                out.extend_from_slice(&b.to_le_bytes());
            }
        }
        self.next_seq = c.seq.wrapping_add(1);
        self.last_tick = c.tick;
        self.last = bits;
    }

    /// Appends a mark for `n` commands lost before reaching the recording.
    pub fn lost(&mut self, out: &mut Vec<u8>, n: u64) {
        if n > 0 {
            op(out, LOST_COMMANDS, n);
        }
    }
}

/// A stream's file: the header, then whole ops, then the end marker; it
/// keeps the CRC and counts the bytes.
#[derive(Debug)]
pub struct StreamFile<W: Write> {
    out: W,
    crc: Crc32,
    bytes: u64,
}

impl<W: Write> StreamFile<W> {
    /// Writes the header of `stream` to `out`.
    pub fn start(mut out: W, stream: Stream) -> io::Result<Self> {
        let header = stream.header();
        out.write_all(&header)?;
        let mut crc = Crc32::default();
        crc.update(&header);
        Ok(StreamFile {
            out,
            crc,
            bytes: HEADER_BYTES,
        })
    }

    /// Writes encoded ops (whole ones: what an encoder appended).
    pub fn write(&mut self, ops: &[u8]) -> io::Result<()> {
        self.out.write_all(ops)?;
        self.crc.update(ops);
        self.bytes += ops.len() as u64;
        Ok(())
    }

    /// Bytes written so far.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    /// Flushes what was written to the file (not to the disk).
    pub fn flush(&mut self) -> io::Result<()> {
        self.out.flush()
    }

    /// Writes the end marker and flushes; returns the writer.
    pub fn end(mut self) -> io::Result<W> {
        self.crc.update(&[END]);
        let crc = self.crc.value();
        self.out.write_all(&[END])?;
        self.out.write_all(&crc.to_le_bytes())?;
        self.bytes += END_BYTES;
        self.out.flush()?;
        Ok(self.out)
    }
}

// ------------------------------------------------------------------ reading

/// What is wrong with a stream, and where.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FormatError {
    /// Offset in the file of the op (or header, or end marker) at fault.
    pub offset: u64,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for FormatError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "offset {}: {}", self.offset, self.message)
    }
}

impl std::error::Error for FormatError {}

/// Reads bytes, counting the offset and the CRC.
struct Bytes<R: Read> {
    input: R,
    offset: u64,
    crc: Crc32,
    /// Offset of the op being read (errors name it).
    op_start: u64,
}

impl<R: Read> Bytes<R> {
    fn error(&self, message: impl Into<String>) -> FormatError {
        FormatError {
            offset: self.op_start,
            message: message.into(),
        }
    }

    /// The next byte, `None` at the end of the file.
    fn next(&mut self) -> Result<Option<u8>, FormatError> {
        let mut b = [0u8; 1];
        loop {
            return match self.input.read(&mut b) {
                Ok(0) => Ok(None),
                Ok(_) => {
                    self.offset += 1;
                    self.crc.update(&b);
                    Ok(Some(b[0]))
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => Err(self.error(format!("cannot read: {e}"))),
            };
        }
    }

    fn byte(&mut self) -> Result<u8, FormatError> {
        self.next()?.ok_or_else(|| {
            self.error("truncated: the file ends inside this op (the writer did not finish)")
        })
    }

    fn u64le(&mut self) -> Result<u64, FormatError> {
        let mut b = [0u8; 8];
        for byte in &mut b {
            *byte = self.byte()?;
        }
        Ok(u64::from_le_bytes(b))
    }

    fn varint(&mut self) -> Result<u64, FormatError> {
        let mut v = 0u64;
        for i in 0..10 {
            let b = self.byte()?;
            let bits = u64::from(b & 0x7f);
            if i == 9 && b > 1 {
                break;
            }
            v |= bits << (7 * i);
            if b & 0x80 == 0 {
                return Ok(v);
            }
        }
        Err(self.error("a number longer than 64 bits (the file is corrupted)"))
    }

    /// A count of ticks or commands: at least 1.
    fn count(&mut self, what: &str) -> Result<u64, FormatError> {
        match self.varint()? {
            0 => Err(self.error(format!("{what} of 0 (the file is corrupted)"))),
            n => Ok(n),
        }
    }

    fn header(&mut self, stream: Stream) -> Result<(), FormatError> {
        let mut h = [0u8; 10];
        for byte in &mut h {
            *byte = self
                .next()?
                .ok_or_else(|| self.error("too short for a header (empty or truncated file)"))?;
        }
        if &h[..8] != MAGIC {
            return Err(self.error("not a sipnpuff recording stream (no SIPNPUFF header)"));
        }
        if h[8] != stream.kind() {
            return Err(self.error(format!(
                "holds the {} stream, not the {} stream",
                if h[8] == b'S' { "samples" } else { "commands" },
                if stream == Stream::Samples {
                    "samples"
                } else {
                    "commands"
                }
            )));
        }
        if h[9] != FORMAT_VERSION {
            return Err(self.error(format!(
                "format version {}, this sipnpuff reads version {FORMAT_VERSION}",
                h[9]
            )));
        }
        Ok(())
    }

    /// Checks the end marker (its tag just read) and that nothing follows.
    fn end(&mut self) -> Result<(), FormatError> {
        let expected = self.crc.value();
        let mut b = [0u8; 4];
        for byte in &mut b {
            *byte = self.byte()?;
        }
        let found = u32::from_le_bytes(b);
        if found != expected {
            return Err(self.error(format!(
                "checksum mismatch at the end marker (stored {found:08x}, computed {expected:08x}): the data before it is corrupted"
            )));
        }
        let end = self.offset;
        let mut extra = 0u64;
        while self.next()?.is_some() {
            extra += 1;
        }
        if extra > 0 {
            self.op_start = end;
            return Err(self.error(format!(
                "{extra} bytes after the end marker (the file is corrupted)"
            )));
        }
        Ok(())
    }

    /// The tag of the next op; `None` at the end of the file, which is an
    /// error: a finished stream ends with its marker.
    fn tag(&mut self) -> Result<u8, FormatError> {
        self.op_start = self.offset;
        self.next()?.ok_or_else(|| {
            self.error("truncated: no end marker (the writer did not finish: the run was killed, or the disk failed)")
        })
    }
}

/// One item of `samples.bin`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SampleItem {
    /// One tick's step.
    Input {
        /// The tick.
        tick: Tick,
        /// Its sample, or none.
        sample: CoreSample,
    },
    /// `begin_stop` after the last step.
    BeginStop,
    /// Ticks lost before reaching the recording: what follows is not the
    /// core's whole input.
    Lost(u64),
}

/// Reads `samples.bin`, item by item, as a stream (an hour of recording
/// never sits in memory).
pub struct SampleDecoder<R: Read> {
    bytes: Bytes<R>,
    next_tick: Tick,
    last: Option<f64>,
    /// Ticks left of a run: (count, sample).
    run: Option<(u64, CoreSample)>,
    ended: bool,
}

impl<R: Read> SampleDecoder<R> {
    /// Reads and checks the header.
    pub fn new(input: R) -> Result<Self, FormatError> {
        let mut bytes = Bytes {
            input,
            offset: 0,
            crc: Crc32::default(),
            op_start: 0,
        };
        bytes.header(Stream::Samples)?;
        Ok(SampleDecoder {
            bytes,
            next_tick: 0,
            last: None,
            run: None,
            ended: false,
        })
    }

    fn tick(&mut self, sample: CoreSample) -> SampleItem {
        let tick = self.next_tick;
        self.next_tick = tick.wrapping_add(1);
        SampleItem::Input { tick, sample }
    }

    /// The next item; `Ok(None)` after a valid end marker.
    pub fn next_item(&mut self) -> Result<Option<SampleItem>, FormatError> {
        if let Some((left, sample)) = self.run {
            self.run = (left > 1).then_some((left - 1, sample));
            return Ok(Some(self.tick(sample)));
        }
        if self.ended {
            return Ok(None);
        }
        loop {
            let tag = self.bytes.tag()?;
            match tag {
                VALUE => {
                    let v = f64::from_bits(self.bytes.u64le()?);
                    self.last = Some(v);
                    return Ok(Some(self.tick(CoreSample::Volts(v))));
                }
                REPEAT | MISSING => {
                    let n = self.bytes.count("a run")?;
                    let sample = if tag == MISSING {
                        CoreSample::Missing
                    } else {
                        let v = self.last.ok_or_else(|| {
                            self.bytes
                                .error("a repeat before any value (the file is corrupted)")
                        })?;
                        CoreSample::Volts(v)
                    };
                    self.run = (n > 1).then_some((n - 1, sample));
                    return Ok(Some(self.tick(sample)));
                }
                GAP => {
                    let n = self.bytes.count("a gap")?;
                    self.next_tick = self.next_tick.wrapping_add(n);
                }
                AT_TICK => self.next_tick = self.bytes.varint()?,
                STOP => return Ok(Some(SampleItem::BeginStop)),
                LOST_TICKS => {
                    return Ok(Some(SampleItem::Lost(self.bytes.count("a loss")?)));
                }
                END => {
                    self.bytes.end()?;
                    self.ended = true;
                    return Ok(None);
                }
                other => {
                    return Err(self
                        .bytes
                        .error(format!("unknown op 0x{other:02x} (the file is corrupted)")));
                }
            }
        }
    }
}

/// One item of `commands.bin`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CommandItem {
    /// A command.
    Command(ArmCommand),
    /// Commands lost before reaching the recording.
    Lost(u64),
}

/// Reads `commands.bin`, item by item, as a stream.
pub struct CommandDecoder<R: Read> {
    bytes: Bytes<R>,
    next_seq: u64,
    last_tick: Tick,
    last: [u64; 7],
    ended: bool,
}

impl<R: Read> CommandDecoder<R> {
    /// Reads and checks the header.
    pub fn new(input: R) -> Result<Self, FormatError> {
        let mut bytes = Bytes {
            input,
            offset: 0,
            crc: Crc32::default(),
            op_start: 0,
        };
        bytes.header(Stream::Commands)?;
        Ok(CommandDecoder {
            bytes,
            next_seq: 0,
            last_tick: 0,
            last: [0; 7],
            ended: false,
        })
    }

    /// The next item; `Ok(None)` after a valid end marker.
    pub fn next_item(&mut self) -> Result<Option<CommandItem>, FormatError> {
        if self.ended {
            return Ok(None);
        }
        loop {
            let tag = self.bytes.tag()?;
            match tag {
                0x00..=0x7f => {
                    let tick = self.last_tick.wrapping_add(self.bytes.varint()?);
                    for i in 0..7 {
                        if tag & (1 << i) != 0 {
                            self.last[i] = self.bytes.u64le()?;
                        }
                    }
                    let [v0, v1, v2, w0, w1, w2, fingers] = self.last.map(f64::from_bits);
                    let command = ArmCommand {
                        seq: self.next_seq,
                        tick,
                        linear: [v0, v1, v2],
                        angular: [w0, w1, w2],
                        fingers,
                    };
                    self.next_seq = self.next_seq.wrapping_add(1);
                    self.last_tick = tick;
                    return Ok(Some(CommandItem::Command(command)));
                }
                SEQ => self.next_seq = self.bytes.varint()?,
                LOST_COMMANDS => {
                    return Ok(Some(CommandItem::Lost(self.bytes.count("a loss")?)));
                }
                END => {
                    self.bytes.end()?;
                    self.ended = true;
                    return Ok(None);
                }
                other => {
                    return Err(self
                        .bytes
                        .error(format!("unknown op 0x{other:02x} (the file is corrupted)")));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn input(tick: Tick, volts: Option<f64>) -> CoreInput {
        CoreInput {
            tick,
            sample: volts.map_or(CoreSample::Missing, CoreSample::Volts),
            began_stop: false,
        }
    }

    fn encode_samples(inputs: &[CoreInput]) -> Vec<u8> {
        let mut file = StreamFile::start(Vec::new(), Stream::Samples).unwrap();
        let mut enc = SampleEncoder::default();
        let mut ops = Vec::new();
        for i in inputs {
            enc.input(&mut ops, i);
        }
        enc.flush(&mut ops);
        file.write(&ops).unwrap();
        file.end().unwrap()
    }

    fn decode_samples(bytes: &[u8]) -> Result<Vec<SampleItem>, FormatError> {
        let mut dec = SampleDecoder::new(bytes)?;
        let mut out = Vec::new();
        while let Some(item) = dec.next_item()? {
            out.push(item);
        }
        Ok(out)
    }

    #[test]
    fn the_crc_is_the_standard_one() {
        let mut crc = Crc32::default();
        crc.update(b"123456789");
        assert_eq!(crc.value(), 0xCBF4_3926);
    }

    #[test]
    fn a_held_value_costs_one_run() {
        let inputs: Vec<CoreInput> = (0..10_000).map(|t| input(t, Some(2.5))).collect();
        let bytes = encode_samples(&inputs);
        // Header, one value, one run of 9999, the end marker.
        assert_eq!(bytes.len(), 10 + 9 + 3 + 5, "{bytes:?}");
        let items = decode_samples(&bytes).unwrap();
        assert_eq!(items.len(), 10_000);
        assert_eq!(
            items[9_999],
            SampleItem::Input {
                tick: 9_999,
                sample: CoreSample::Volts(2.5)
            }
        );
    }

    #[test]
    fn gaps_missing_runs_stops_and_bits_survive() {
        let nan = f64::from_bits(0x7ff8_0000_dead_beef);
        let mut inputs = vec![
            input(5, Some(-0.0)),
            input(6, Some(0.0)),
            input(7, None),
            input(8, None),
            input(2008, Some(nan)),
            input(2009, Some(nan)),
            input(3, Some(1.0)),
        ];
        inputs[5].began_stop = true;
        let bytes = encode_samples(&inputs);
        let items = decode_samples(&bytes).unwrap();
        let mut back = Vec::new();
        for item in items {
            match item {
                SampleItem::Input { tick, sample } => back.push(CoreInput {
                    tick,
                    sample,
                    began_stop: false,
                }),
                SampleItem::BeginStop => back.last_mut().unwrap().began_stop = true,
                SampleItem::Lost(_) => panic!("nothing was lost"),
            }
        }
        assert_eq!(back.len(), inputs.len());
        for (a, b) in back.iter().zip(&inputs) {
            assert_eq!((a.tick, a.began_stop), (b.tick, b.began_stop));
            let bits = |s: CoreSample| match s {
                CoreSample::Volts(v) => Some(v.to_bits()),
                CoreSample::Missing => None,
            };
            assert_eq!(bits(a.sample), bits(b.sample));
        }
    }

    #[test]
    fn commands_store_only_what_changed() {
        let mut enc = CommandEncoder::default();
        let mut ops = Vec::new();
        let zero = ArmCommand::default();
        enc.command(&mut ops, &zero);
        assert_eq!(ops, [0x00, 0x00], "a zero command at tick 0: 2 bytes");
        ops.clear();
        let moving = ArmCommand {
            seq: 1,
            tick: 10,
            linear: [0.1, 0.0, 0.0],
            ..zero
        };
        enc.command(&mut ops, &moving);
        assert_eq!(ops.len(), 2 + 8);
        ops.clear();
        // A lost command shows as a new number.
        enc.command(
            &mut ops,
            &ArmCommand {
                seq: 3,
                tick: 30,
                ..moving
            },
        );
        assert_eq!(ops, [SEQ, 3, 0x00, 20]);
    }

    #[test]
    fn truncation_and_corruption_name_the_offset() {
        let inputs: Vec<CoreInput> = (0..100)
            .map(|t| input(t, Some(f64::from(t as u32) * 0.01)))
            .collect();
        let bytes = encode_samples(&inputs);
        let e = decode_samples(&bytes[..bytes.len() - 5]).unwrap_err();
        assert_eq!(e.offset, bytes.len() as u64 - 5);
        assert!(e.message.contains("no end marker"), "{e}");
        let e = decode_samples(&bytes[..bytes.len() - 2]).unwrap_err();
        assert!(e.message.contains("ends inside this op"), "{e}");
        // A flipped bit in a value: only the checksum can tell.
        let mut bad = bytes.clone();
        bad[10 + 9 * 50 + 3] ^= 0x10;
        let e = decode_samples(&bad).unwrap_err();
        assert_eq!(e.offset, bytes.len() as u64 - 5);
        assert!(e.message.contains("checksum mismatch"), "{e}");
        // A flipped op: named where it is.
        let mut bad = bytes.clone();
        bad[10 + 9 * 50] = 0x42;
        let e = decode_samples(&bad).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!(
                "offset {}: unknown op 0x42 (the file is corrupted)",
                10 + 9 * 50
            )
        );
        let mut extra = bytes.clone();
        extra.push(0);
        assert!(
            decode_samples(&extra)
                .unwrap_err()
                .message
                .contains("1 bytes after the end marker")
        );
        let e = decode_samples(b"SIPNPUFFC\x01").unwrap_err();
        assert!(e.message.contains("holds the commands stream"), "{e}");
        let e = decode_samples(b"SIPNPUFFS\x09").unwrap_err();
        assert!(e.message.contains("format version 9"), "{e}");
        let e = decode_samples(b"tick,volts\n").unwrap_err();
        assert!(e.message.contains("no SIPNPUFF header"), "{e}");
        assert!(
            decode_samples(b"")
                .unwrap_err()
                .message
                .contains("too short")
        );
    }

    #[test]
    fn a_varint_past_64_bits_is_an_error() {
        let mut bytes = Stream::Samples.header().to_vec();
        bytes.push(REPEAT);
        bytes.extend([0xff; 10]);
        let e = decode_samples(&bytes).unwrap_err();
        assert_eq!(e.offset, 10);
        assert!(e.message.contains("longer than 64 bits"), "{e}");
        let mut bytes = Stream::Samples.header().to_vec();
        bytes.extend([REPEAT, 3]);
        assert!(
            decode_samples(&bytes)
                .unwrap_err()
                .message
                .contains("a repeat before any value")
        );
    }
}
