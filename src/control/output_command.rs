//! What the core asks of the outputs beyond the arm — the computer's
//! keyboard and pointer, the home — on one tick. The control thread only
//! decides; each output carries these out on its own thread.

use serde::Serialize;

use crate::control::Tick;
use crate::control::sequence::Sequence;
use crate::control::target::{Chord, Click, HomeEvent};

/// One command to the outputs. `Copy`, RT-safe.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[allow(
    clippy::large_enum_variant,
    reason = "inline (a home event carries its sequence) so the control thread never allocates"
)]
pub enum OutputCommand {
    /// Press the chord's keys in order, then release them in reverse.
    Key(Chord),
    /// Click.
    Click(Click),
    /// The left button goes down (a drag begins) or up (it ends).
    Button {
        /// Down (true) or up.
        down: bool,
    },
    /// The pointer moved over the last 10 ms.
    Pointer(PointerMove),
    /// A home event fired: the match that fired it.
    Home {
        /// The event.
        event: HomeEvent,
        /// The tick of the match.
        tick: Tick,
        /// The sequence matched.
        sequence: Sequence,
    },
    /// Let go of everything held: a fault or a stop.
    ReleaseAll,
}

impl OutputCommand {
    /// For the computer's keyboard and pointer (not the home).
    pub const fn is_for_computer(&self) -> bool {
        !matches!(self, OutputCommand::Home { .. })
    }

    /// For the home: its events (it holds nothing to let go of).
    pub const fn is_for_home(&self) -> bool {
        matches!(self, OutputCommand::Home { .. })
    }
}

/// Pointer motion in whole counts (uinput's `REL_X`, `REL_Y`,
/// `REL_WHEEL`): right, down and wheel-up are positive. The fractions are
/// carried to the next move, so the moves sum to the travel commanded.
/// A tick's move is `i32`; a sum of many (an output's report of what it
/// wrote) is `PointerMove<i64>`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct PointerMove<N = i32> {
    /// Right (+) or left (−), counts.
    pub dx: N,
    /// Down (+) or up (−), counts.
    pub dy: N,
    /// Wheel up (+) or down (−), detents.
    pub wheel: N,
}

impl PointerMove {
    /// No motion.
    pub const fn is_zero(&self) -> bool {
        self.dx == 0 && self.dy == 0 && self.wheel == 0
    }
}

/// Most output commands one tick can carry: a drag let go, the action a
/// match fires, a pointer move, and a release on a fault or stop.
pub const MAX_OUTPUT_COMMANDS: usize = 4;

/// The output commands of one tick, inline. `Copy`, RT-safe.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OutputCommands {
    items: [Option<OutputCommand>; MAX_OUTPUT_COMMANDS],
}

impl Default for OutputCommands {
    fn default() -> Self {
        OutputCommands {
            items: [None; MAX_OUTPUT_COMMANDS],
        }
    }
}

impl OutputCommands {
    /// Adds a command; hands it back if full (never with the core's
    /// commands: at most [`MAX_OUTPUT_COMMANDS`] a tick).
    #[allow(
        clippy::result_large_err,
        reason = "the command handed back is the inline value itself"
    )]
    pub fn push(&mut self, command: OutputCommand) -> Result<(), OutputCommand> {
        match self.items.iter_mut().find(|slot| slot.is_none()) {
            Some(slot) => {
                *slot = Some(command);
                Ok(())
            }
            None => Err(command),
        }
    }

    /// Empties the list. RT-safe.
    pub fn clear(&mut self) {
        self.items = [None; MAX_OUTPUT_COMMANDS];
    }

    /// The commands, in order.
    pub fn iter(&self) -> impl Iterator<Item = &OutputCommand> {
        self.items.iter().map_while(Option::as_ref)
    }
}
