//! The line a row read by the `csv` crate is on, as an editor numbers it.
//!
//! The crate's own `Position::line` counts `\n`s only and stands where the
//! previous record ended: before the empty lines it skips, and on the `\n`
//! of a `\r\n` (it ends a record at the `\r`). So after a `\r\n` or an
//! empty line it names a line too early, and after lone `\r`s it stays on
//! one line. Its byte offsets are exact, though: [`LineBreaks`] sees every
//! byte on its way to the parser and turns a record's offset into the
//! line of its first byte. Line breaks are what the parser ends records
//! at: `\n`, `\r\n` and a lone `\r`.

use std::collections::VecDeque;

/// UTF-8's byte order mark (the parser drops one at the very start).
pub(super) const BOM: &[u8] = b"\xEF\xBB\xBF";

/// The line breaks in the bytes passed to the parser and not yet behind a
/// row it reported: at most the parser's buffer's worth.
pub(super) struct LineBreaks {
    /// Bytes seen so far.
    seen: u64,
    /// The breaks not yet behind a reported row: their first byte and the
    /// byte after them.
    ahead: VecDeque<(u64, u64)>,
    /// The line after the breaks already behind.
    line: u64,
    /// The last break is a `\r` (a `\n` right after makes it a `\r\n`).
    last_is_cr: bool,
    /// How many of the first bytes are a byte order mark so far; `None`
    /// once they are not (or the input is not the file's start).
    bom: Option<usize>,
}

impl LineBreaks {
    /// The breaks of input whose first byte is on line `first_line`;
    /// `file_start`: the input is the file from its first byte (a byte
    /// order mark there is not the first row's).
    pub(super) fn new(first_line: u64, file_start: bool) -> Self {
        LineBreaks {
            seen: 0,
            ahead: VecDeque::new(),
            line: first_line,
            last_is_cr: false,
            bom: file_start.then_some(0),
        }
    }

    /// The next bytes on their way to the parser.
    pub(super) fn see(&mut self, bytes: &[u8]) {
        for &byte in bytes {
            match self.bom {
                Some(matched) if matched < BOM.len() => {
                    self.bom = (BOM.get(matched) == Some(&byte)).then_some(matched + 1);
                }
                _ => break,
            }
        }
        for i in memchr::memchr2_iter(b'\r', b'\n', bytes) {
            let at = self.seen + i as u64;
            let is_cr = bytes.get(i) == Some(&b'\r');
            match self.ahead.back_mut() {
                // The `\n` of a `\r\n`: one break.
                Some((_, end)) if !is_cr && self.last_is_cr && *end == at => *end = at + 1,
                _ => self.ahead.push_back((at, at + 1)),
            }
            self.last_is_cr = is_cr;
        }
        self.seen += bytes.len() as u64;
    }

    /// The line of the row (or error) the parser places at `byte`: where
    /// the previous row ended, so past any line breaks there (empty lines,
    /// the `\n` of a `\r\n`) and, at the start, a byte order mark. Rows
    /// come in order: the breaks before this one are forgotten.
    pub(super) fn line_of(&mut self, byte: u64) -> u64 {
        let mut start = byte;
        if start == 0 && self.bom.is_some_and(|matched| matched >= BOM.len()) {
            start = BOM.len() as u64;
        }
        while let Some(&(first, end)) = self.ahead.front() {
            if first > start {
                break;
            }
            // A break before the row, or one it starts on (an empty line).
            start = start.max(end);
            self.line += 1;
            self.ahead.pop_front();
        }
        self.line
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `bytes` seen in pieces of `piece` bytes.
    fn breaks(bytes: &[u8], piece: usize, first_line: u64) -> LineBreaks {
        let mut breaks = LineBreaks::new(first_line, true);
        for chunk in bytes.chunks(piece) {
            breaks.see(chunk);
        }
        breaks
    }

    #[test]
    fn each_ending_is_one_break_however_the_bytes_come() {
        let text = b"a\r\nb\rc\n\r\n\nd";
        for piece in 1..=text.len() {
            let mut b = breaks(text, piece, 1);
            assert_eq!(b.line_of(0), 1);
            // Where the parser puts "b": on the `\n` of the `\r\n`.
            assert_eq!(b.line_of(2), 2, "pieces of {piece}");
            assert_eq!(b.line_of(5), 3);
            // "d" after two empty lines, placed at the end of "c".
            assert_eq!(b.line_of(7), 6);
        }
    }

    #[test]
    fn a_byte_order_mark_and_empty_lines_before_the_first_row() {
        let mut b = breaks(b"\xEF\xBB\xBF\n\nx\n", 2, 1);
        assert_eq!(b.line_of(0), 3);
        // Only at the file's start: mid-file, its first byte is data.
        let mut b = LineBreaks::new(7, false);
        b.see(b"\n\xEF\xBB\xBFx\n");
        assert_eq!(b.line_of(0), 8);
    }
}
