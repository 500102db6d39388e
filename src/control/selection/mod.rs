//! Selection: how the user picks a mode (or fires an action) in
//! detection mode.
//!
//! * ASP, the paper's interface: bursts form sequences matched against the
//!   user's library ([`matcher`]).
//! * BSP, the paper's baseline (Kinova's classic sip-and-puff): the modes
//!   scroll on their own and a puff enters the highlighted one
//!   ([`scanning`]).

pub mod matcher;
pub mod scanning;

use serde::Serialize;

use crate::control::action::{Action, ActionSeq};
use crate::control::mode::Mode;
use crate::control::sequence::Sequence;
use crate::control::target::Target;

/// One user-defined sequence and what it selects or fires. Written in a
/// file as `actions` and one of `mode`, `key`, `click` or `event`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct SequenceEntry {
    /// The breaths and gestures, non-empty, at most
    /// [`MAX_SEQUENCE_LEN`](crate::control::action::MAX_SEQUENCE_LEN).
    pub actions: Sequence,
    /// What it selects or fires.
    #[serde(flatten)]
    pub target: Target,
}

impl SequenceEntry {
    /// The entry for `actions` selecting `mode`.
    pub fn mode(actions: impl Into<Sequence>, mode: Mode) -> SequenceEntry {
        SequenceEntry {
            actions: actions.into(),
            target: Target::Mode(mode),
        }
    }

    /// Its breaths, if it holds no gesture: what the tools that play,
    /// design or fit breaths work with.
    pub fn breaths(&self) -> Option<ActionSeq> {
        self.actions.actions()
    }
}

/// The built-in library: prefix-free (no selection ever waits for the
/// timeout), two bursts each so a single cough or sigh never changes mode.
/// Two short bursts select the most used modes (translations, fingers); a
/// long puff first selects a rotation; a long sip first a saved point.
pub const DEFAULT_LIBRARY: [(&[Action], Mode); 9] = {
    use Action::{LongPuff, LongSip, ShortPuff, ShortSip};
    [
        (&[ShortPuff, ShortPuff], Mode::TranslateX),
        (&[ShortPuff, ShortSip], Mode::TranslateY),
        (&[ShortSip, ShortSip], Mode::TranslateZ),
        (&[ShortSip, ShortPuff], Mode::Fingers),
        (&[LongPuff, ShortPuff], Mode::RotateX),
        (&[LongPuff, ShortSip], Mode::RotateY),
        (&[LongPuff, LongPuff], Mode::RotateZ),
        (&[LongSip, ShortPuff], Mode::SavePoint),
        (&[LongSip, ShortSip], Mode::GotoPoint),
    ]
};

/// How the user selects a mode (`[interface] kind`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Interface {
    /// Advanced sip-and-puff: sequences matched against the library (the
    /// paper's interface).
    #[default]
    Asp,
    /// Basic sip-and-puff: the modes scroll on their own and a puff enters
    /// the highlighted one (Kinova's classic interface, the paper's
    /// baseline).
    Bsp,
}

impl Interface {
    /// Both interfaces.
    pub const ALL: [Interface; 2] = [Interface::Asp, Interface::Bsp];

    /// `asp` or `bsp`.
    pub const fn name(self) -> &'static str {
        match self {
            Interface::Asp => "asp",
            Interface::Bsp => "bsp",
        }
    }

    /// Parses `asp` or `bsp`.
    pub fn from_name(name: &str) -> Option<Interface> {
        Interface::ALL.into_iter().find(|i| i.name() == name)
    }
}
