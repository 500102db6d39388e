//! The plain lines of a CSV recording, split without the CSV parser.
//!
//! Nearly every line a recording holds is plain: no quote, no carriage
//! return but the one of a `\r\n` ending, shorter than the buffer. Such a
//! line is one record whose fields are its bytes between commas, exactly
//! as the `csv` crate reads it, so it is handed out as it stands. The
//! first line that is not plain is left unread: from it on, the caller
//! reads the rest ([`PlainLines::into_rest`]) with the `csv` crate.

use std::io::{self, Cursor, Read};

use super::breaks::LineBreaks;

/// What the next line is.
pub(super) enum Line<'a> {
    /// A plain line.
    Plain(PlainLine<'a>),
    /// A line that is not plain, left unread.
    Other,
    /// The end of the input.
    End,
}

/// A plain line, as one pass over its bytes found it.
pub(super) struct PlainLine<'a> {
    /// Its bytes, without its `\n` or `\r\n`.
    pub(super) bytes: &'a [u8],
    /// Its fields: one more than its commas.
    pub(super) fields: usize,
    /// Where its first two commas are (`usize::MAX` for none): its first
    /// two fields without a second pass.
    pub(super) commas: [usize; 2],
    /// Every byte is ASCII.
    pub(super) ascii: bool,
}

impl<'a> PlainLine<'a> {
    /// Its field `column` (empty past the last), as the `csv` crate
    /// splits it: the first two from the commas found, others by a split.
    pub(super) fn field(&self, column: usize) -> &'a [u8] {
        let [first, second] = self.commas;
        let end = |comma: usize| comma.min(self.bytes.len());
        let range = match column {
            0 => 0..end(first),
            1 if first != usize::MAX => first + 1..end(second),
            1 => return b"",
            _ => return self.bytes.split(|b| *b == b',').nth(column).unwrap_or(b""),
        };
        self.bytes.get(range).unwrap_or(b"")
    }
}

/// Splits its input into lines, one buffer at a time.
pub(super) struct PlainLines<R: Read> {
    input: R,
    buffer: Vec<u8>,
    /// The unread bytes are `buffer[start..end]`.
    start: usize,
    end: usize,
    /// The input has ended.
    ended: bool,
    /// Where the last plain line began (for [`PlainLines::put_back`]).
    last: usize,
}

impl<R: Read> PlainLines<R> {
    /// Reads `input` through a buffer of `capacity` bytes (a longer line
    /// is [`Line::Other`]).
    pub(super) fn new(input: R, capacity: usize) -> Self {
        PlainLines {
            input,
            buffer: vec![0; capacity.max(1)],
            start: 0,
            end: 0,
            ended: false,
            last: 0,
        }
    }

    /// The next line; [`Line::Plain`] consumes it, [`Line::Other`] does not.
    pub(super) fn next_line(&mut self) -> io::Result<Line<'_>> {
        loop {
            let unread = &self.buffer[self.start..self.end];
            // One pass finds the line's end and what it holds (a line is
            // a few bytes: one call a search would cost more).
            let (mut commas, mut quotes, mut returns, mut high) = (0, 0, 0, 0);
            let mut comma_at = [usize::MAX; 2];
            let mut length = None;
            for (i, &b) in unread.iter().enumerate() {
                match b {
                    b'\n' => {
                        length = Some(i);
                        break;
                    }
                    b',' => {
                        if let Some(at) = comma_at.get_mut(commas) {
                            *at = i;
                        }
                        commas += 1;
                    }
                    b'"' => quotes += 1,
                    b'\r' => returns += 1,
                    _ => high |= b,
                }
            }
            let (length, terminated) = match length {
                Some(at) => (at, true),
                None if self.ended => (unread.len(), false),
                None if self.start == 0 && self.end == self.buffer.len() => return Ok(Line::Other),
                None => {
                    self.refill()?;
                    continue;
                }
            };
            if length == 0 && !terminated {
                return Ok(Line::End);
            }
            let mut bytes = &unread[..length];
            if terminated && bytes.last() == Some(&b'\r') {
                bytes = &bytes[..length - 1];
                returns -= 1;
            }
            // A quote may span lines and a lone `\r` ends a record: the
            // CSV parser's to read.
            if quotes + returns > 0 {
                return Ok(Line::Other);
            }
            let line_start = self.start;
            self.last = line_start;
            self.start += length + usize::from(terminated);
            return Ok(Line::Plain(PlainLine {
                bytes: &self.buffer[line_start..line_start + bytes.len()],
                fields: commas + 1,
                commas: comma_at,
                ascii: high < 0x80,
            }));
        }
    }

    /// The value of the next line if it is `digits,value\n`, all in the
    /// buffer (`read` returns the value and the bytes it took), and the
    /// line consumed; `None` leaves the line unread. If `read` takes only
    /// ASCII bytes other than quotes, commas and carriage returns, such a
    /// line is the plain one of two fields [`PlainLines::next_line`] would
    /// hand out.
    pub(super) fn next_tick_and<T>(
        &mut self,
        read: impl FnOnce(&[u8]) -> Option<(T, usize)>,
    ) -> Option<T> {
        let unread = &self.buffer[self.start..self.end];
        let digits = unread.iter().position(|b| !b.is_ascii_digit())?;
        if digits == 0 || unread[digits] != b',' {
            return None;
        }
        let field = unread.get(digits + 1..)?;
        let (value, used) = read(field)?;
        if field.get(used) != Some(&b'\n') {
            return None;
        }
        self.last = self.start;
        self.start += digits + 1 + used + 1;
        Some(value)
    }

    /// Makes the plain line just read unread again.
    pub(super) fn put_back(&mut self) {
        self.start = self.last;
    }

    /// Moves the unread bytes to the front and reads more after them.
    fn refill(&mut self) -> io::Result<()> {
        self.buffer.copy_within(self.start..self.end, 0);
        self.end -= self.start;
        self.start = 0;
        loop {
            match self.input.read(&mut self.buffer[self.end..]) {
                Ok(0) => {
                    self.ended = true;
                    return Ok(());
                }
                Ok(n) => {
                    self.end += n;
                    return Ok(());
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
    }

    /// The unread bytes, then the rest of the input, for the CSV parser
    /// to read from the start of the file.
    pub(super) fn into_rest(self) -> Unread<R> {
        self.rest(b"", LineBreaks::new(1, true))
    }

    /// [`PlainLines::into_rest`] from a line after the first: after a
    /// `\n`, which the parser skips as an empty line (so that, as it was
    /// mid-file, a byte order mark on that line is data: the parser drops
    /// one only at the very start).
    /// `line` is the number of the line it starts at.
    pub(super) fn into_rest_mid_file(self, line: u64) -> Unread<R> {
        // (The `\n` put first is on the line before.)
        self.rest(b"\n", LineBreaks::new(line - 1, false))
    }

    fn rest(self, lead: &[u8], breaks: LineBreaks) -> Unread<R> {
        let mut unread = lead.to_vec();
        unread.extend_from_slice(&self.buffer[self.start..self.end]);
        Unread {
            unread: Cursor::new(unread),
            input: self.input,
            breaks,
        }
    }
}

/// What [`PlainLines`] left unread, then the rest of its input.
pub(super) struct Unread<R: Read> {
    unread: Cursor<Vec<u8>>,
    input: R,
    /// The line breaks in what the parser has read.
    breaks: LineBreaks,
}

impl<R: Read> Unread<R> {
    /// The line of the row (or error) the parser places at `byte` of
    /// what it read (see [`LineBreaks::line_of`]).
    pub(super) fn line_of(&mut self, byte: u64) -> u64 {
        self.breaks.line_of(byte)
    }
}

impl<R: Read> Read for Unread<R> {
    /// Reads on into the input in the same call (as `Chain` does not):
    /// the parser's first buffer holds what it would have held, reading
    /// the file itself, whatever little was left unread (it looks for a
    /// byte order mark only in its first buffer).
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.unread.read(buf)?;
        let n = if n == buf.len() {
            n
        } else {
            match self.input.read(&mut buf[n..]) {
                Ok(more) => n + more,
                // (The error is met again on the next read.)
                Err(_) if n > 0 => n,
                Err(e) => return Err(e),
            }
        };
        self.breaks.see(buf.get(..n).unwrap_or(buf));
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every line as text ("<other>" where it stops), then the rest.
    fn split(bytes: &[u8], capacity: usize) -> (Vec<String>, Vec<u8>) {
        let mut lines = PlainLines::new(bytes, capacity);
        let mut seen = Vec::new();
        loop {
            match lines.next_line().unwrap() {
                Line::Plain(line) => {
                    let text = String::from_utf8_lossy(line.bytes);
                    assert_eq!(line.fields, text.split(',').count(), "{text}");
                    assert_eq!(line.ascii, line.bytes.is_ascii(), "{text}");
                    seen.push(text.into_owned());
                }
                Line::Other => {
                    seen.push("<other>".into());
                    break;
                }
                Line::End => break,
            }
        }
        let mut rest = Vec::new();
        lines.into_rest().read_to_end(&mut rest).unwrap();
        (seen, rest)
    }

    #[test]
    fn plain_lines_are_split_and_the_first_other_one_is_left_with_the_rest() {
        for capacity in [1, 2, 3, 5, 8, 64, 1 << 16] {
            let (lines, rest) = split(b"a,1\r\nb,2\n\nc", capacity);
            // At capacity 1 to 3 "a,1\r\n" does not fit: nothing is plain.
            if capacity >= 5 {
                assert_eq!(lines, ["a,1", "b,2", "", "c"], "capacity {capacity}");
                assert_eq!(rest, b"");
            } else {
                assert_eq!(lines, ["<other>"], "capacity {capacity}");
                assert_eq!(rest, b"a,1\r\nb,2\n\nc");
            }
            let (lines, rest) = split(b"x\ny,\"q\"\nz\n", capacity.max(3));
            assert_eq!(lines, ["x", "<other>"]);
            assert_eq!(rest, b"y,\"q\"\nz\n");
        }
        let (lines, rest) = split(b"x\ny\rz\n", 64);
        assert_eq!(
            (lines, rest),
            (vec!["x".into(), "<other>".into()], b"y\rz\n".to_vec())
        );
        let (lines, rest) = split(b"x\ny\r", 64);
        assert_eq!(
            (lines, rest),
            (vec!["x".into(), "<other>".into()], b"y\r".to_vec())
        );
        assert_eq!(split(b"", 4), (vec![], vec![]));
        let (lines, _) = split("1,\u{e9},,x\n\u{feff}2\n".as_bytes(), 64);
        assert_eq!(lines, ["1,\u{e9},,x", "\u{feff}2"]);
    }
}
