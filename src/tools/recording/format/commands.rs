//! `commands.bin`: the 100 Hz arm commands the core produced ([the
//! format](super)).

use std::io::Read;

use crate::control::Tick;
use crate::control::motion::stream::ArmCommand;
use crate::tools::recording::format::{Bytes, FormatError, Stream, op};

const SEQ: u8 = 0x80;
const LOST_COMMANDS: u8 = 0x81;

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
        let mut bytes = Bytes::new(input);
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
                _ => {
                    let lost = self.bytes.loss_or_end(tag, LOST_COMMANDS)?;
                    self.ended = lost.is_none();
                    return Ok(lost.map(CommandItem::Lost));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
