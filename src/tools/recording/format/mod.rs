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
//! header   "SIPNPUFF" kind ('S' or 'C') version (3; version 1 lacks the arm's ops, 2 the IMU's)
//! samples  0x01 bits:u64le    one tick, a new value          0x02 n   n ticks repeating the last value
//!          0x03 n             n ticks without a sample        0x04 n   n ticks skipped before the next
//!          0x05 t             the next tick is t (absolute)   0x06     the safe stop begins
//!          0x07 n             n ticks lost (not recorded)      0x08 n   n ticks with the device gone
//!          0x09 bits:u64le×7  the arm's measured start pose     0x0a bits:u64le×7  a measured pose
//!          0x0b               the arm's link lost               0x0c bits:u64le×6  an IMU sample
//!          0x0d               the IMU's device gone             (0x06, 0x09–0x0d are part of the
//!                                                              next tick's input; a pose is x, y,
//!                                                              z, then the unit quaternion i, j,
//!                                                              k, w; an IMU sample ax, ay, az,
//!                                                              gx, gy, gz)
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

pub mod commands;
pub mod samples;

/// The version of both streams this build writes; it reads every version
/// up to it (a version 1 file has none of the arm's ops, 0x09–0x0b; a
/// version 2 file none of the IMU's, 0x0c–0x0d).
pub const FORMAT_VERSION: u8 = 3;
/// Every stream starts with these bytes.
pub const MAGIC: &[u8; 8] = b"SIPNPUFF";
/// Bytes of the header.
pub const HEADER_BYTES: u64 = 10;
/// Bytes of the end marker.
pub const END_BYTES: u64 = 5;

/// The end marker's tag, in both streams.
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
    pub(super) fn kind(self) -> u8 {
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

/// CRC-32 (IEEE 802.3, as zlib and PNG), by `crc32fast` (many bytes at
/// a time).
#[derive(Debug, Clone, Default)]
pub struct Crc32(crc32fast::Hasher);

impl Crc32 {
    /// Adds bytes.
    pub fn update(&mut self, bytes: &[u8]) {
        self.0.update(bytes);
    }

    /// The CRC of the bytes so far.
    pub fn value(&self) -> u32 {
        self.0.clone().finalize()
    }
}

// ------------------------------------------------------------------ writing

/// Appends `v` as a LEB128 varint.
pub(super) fn varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

/// Appends an op: its tag and a varint.
pub(super) fn op(out: &mut Vec<u8>, tag: u8, n: u64) {
    out.push(tag);
    varint(out, n);
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

/// Bytes read at a time.
const READ_SIZE: usize = 1 << 16;

/// Reads bytes, counting the offset and the CRC: [`READ_SIZE`] bytes at
/// a time, added to the CRC a buffer at a time.
pub(super) struct Bytes<R: Read> {
    input: R,
    buf: Box<[u8]>,
    /// The next byte to hand out, and the end of what was read, in `buf`.
    pos: usize,
    len: usize,
    /// `buf[..crc_to]` is in `crc`.
    crc_to: usize,
    offset: u64,
    crc: Crc32,
    /// Offset of the op being read (errors name it).
    op_start: u64,
}

impl<R: Read> Bytes<R> {
    /// Reads `input` from its start.
    pub(super) fn new(input: R) -> Self {
        Bytes {
            input,
            buf: vec![0; READ_SIZE].into_boxed_slice(),
            pos: 0,
            len: 0,
            crc_to: 0,
            offset: 0,
            crc: Crc32::default(),
            op_start: 0,
        }
    }

    pub(super) fn error(&self, message: impl Into<String>) -> FormatError {
        FormatError {
            offset: self.op_start,
            message: message.into(),
        }
    }

    /// The CRC of every byte handed out so far.
    fn crc_value(&mut self) -> u32 {
        self.crc.update(&self.buf[self.crc_to..self.pos]);
        self.crc_to = self.pos;
        self.crc.value()
    }

    /// The next byte, `None` at the end of the file.
    pub(super) fn next(&mut self) -> Result<Option<u8>, FormatError> {
        if self.pos == self.len && !self.refill()? {
            return Ok(None);
        }
        let b = self.buf[self.pos];
        self.pos += 1;
        self.offset += 1;
        Ok(Some(b))
    }

    /// Reads the next bytes into `buf` (the bytes handed out added to the
    /// CRC first); false at the end of the file.
    fn refill(&mut self) -> Result<bool, FormatError> {
        self.crc.update(&self.buf[self.crc_to..self.pos]);
        loop {
            match self.input.read(&mut self.buf) {
                Ok(n) => {
                    (self.pos, self.len, self.crc_to) = (0, n, 0);
                    return Ok(n > 0);
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(self.error(format!("cannot read: {e}"))),
            }
        }
    }

    pub(super) fn byte(&mut self) -> Result<u8, FormatError> {
        self.next()?.ok_or_else(|| {
            self.error("truncated: the file ends inside this op (the writer did not finish)")
        })
    }

    /// The next op if it is `tag` followed by a `u64le` and lies whole in
    /// the buffer (a noisy sensor's every tick: one `VALUE` op): its
    /// value, taken without a check per byte. `None` leaves everything
    /// as it was, for the op to be read the long way.
    pub(super) fn take_u64_op(&mut self, tag: u8) -> Option<u64> {
        match self.buf[self.pos..self.len].first_chunk::<9>() {
            Some(&[t, b0, b1, b2, b3, b4, b5, b6, b7]) if t == tag => {
                self.op_start = self.offset;
                self.pos += 9;
                self.offset += 9;
                Some(u64::from_le_bytes([b0, b1, b2, b3, b4, b5, b6, b7]))
            }
            _ => None,
        }
    }

    pub(super) fn u64le(&mut self) -> Result<u64, FormatError> {
        if let Some(b) = self.buf[self.pos..self.len].first_chunk::<8>() {
            let v = u64::from_le_bytes(*b);
            self.pos += 8;
            self.offset += 8;
            return Ok(v);
        }
        let mut b = [0u8; 8];
        for byte in &mut b {
            *byte = self.byte()?;
        }
        Ok(u64::from_le_bytes(b))
    }

    pub(super) fn varint(&mut self) -> Result<u64, FormatError> {
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
    pub(super) fn count(&mut self, what: &str) -> Result<u64, FormatError> {
        match self.varint()? {
            0 => Err(self.error(format!("{what} of 0 (the file is corrupted)"))),
            n => Ok(n),
        }
    }

    pub(super) fn header(&mut self, stream: Stream) -> Result<(), FormatError> {
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
        if !(1..=FORMAT_VERSION).contains(&h[9]) {
            return Err(self.error(format!(
                "format version {}, this sipnpuff reads versions 1 to {FORMAT_VERSION}",
                h[9]
            )));
        }
        Ok(())
    }

    /// Checks the end marker (its tag just read) and that nothing follows.
    pub(super) fn end(&mut self) -> Result<(), FormatError> {
        let expected = self.crc_value();
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

    /// The ops both streams share, after their own: `lost`, the stream's
    /// loss mark, gives its count; the end marker is checked and gives
    /// `None`; any other tag is an error.
    pub(super) fn loss_or_end(&mut self, tag: u8, lost: u8) -> Result<Option<u64>, FormatError> {
        match tag {
            END => self.end().map(|()| None),
            _ if tag == lost => self.count("a loss").map(Some),
            other => Err(self.error(format!("unknown op 0x{other:02x} (the file is corrupted)"))),
        }
    }

    /// The tag of the next op; `None` at the end of the file, which is an
    /// error: a finished stream ends with its marker.
    pub(super) fn tag(&mut self) -> Result<u8, FormatError> {
        self.op_start = self.offset;
        self.next()?.ok_or_else(|| {
            self.error("truncated: no end marker (the writer did not finish: the run was killed, or the disk failed)")
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_crc_is_the_standard_one() {
        let mut crc = Crc32::default();
        crc.update(b"123456789");
        assert_eq!(crc.value(), 0xCBF4_3926);
    }
}
