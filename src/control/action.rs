//! The vocabulary of the breath interface: breaths, the four burst
//! actions of the paper and inline sequences of them.

use std::fmt;

use serde::{Serialize, Serializer};

use crate::control::inline_seq::{InlineSeq, SeqItem};
pub use crate::control::inline_seq::{MAX_SEQUENCE_LEN, SequenceFull};

/// Which way the user is breathing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Breath {
    /// Inhale: the sensor voltage falls below the neutral.
    Sip,
    /// Exhale: the sensor voltage rises above the neutral.
    Puff,
}

impl Breath {
    /// Plain words: "sip" or "puff".
    pub const fn word(self) -> &'static str {
        match self {
            Breath::Sip => "sip",
            Breath::Puff => "puff",
        }
    }
}

/// One detected burst, coded as in the paper: short sip = 1, long sip = 2,
/// short puff = −1, long puff = −2.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Action {
    /// Short inhale (code 1).
    ShortSip,
    /// Long inhale (code 2).
    LongSip,
    /// Short exhale (code −1).
    ShortPuff,
    /// Long exhale (code −2).
    LongPuff,
}

impl Action {
    /// All four actions.
    pub const ALL: [Action; 4] = [
        Action::ShortSip,
        Action::LongSip,
        Action::ShortPuff,
        Action::LongPuff,
    ];

    /// Where it sits in [`Action::ALL`].
    pub const fn index(self) -> usize {
        match self {
            Action::ShortSip => 0,
            Action::LongSip => 1,
            Action::ShortPuff => 2,
            Action::LongPuff => 3,
        }
    }

    /// The paper's integer code.
    pub const fn code(self) -> i8 {
        match self {
            Action::ShortSip => 1,
            Action::LongSip => 2,
            Action::ShortPuff => -1,
            Action::LongPuff => -2,
        }
    }

    /// The action for one of the paper's codes, or `None` for any other value.
    pub const fn from_code(code: i64) -> Option<Action> {
        match code {
            1 => Some(Action::ShortSip),
            2 => Some(Action::LongSip),
            -1 => Some(Action::ShortPuff),
            -2 => Some(Action::LongPuff),
            _ => None,
        }
    }

    /// The action for a burst of this breath and length.
    pub const fn new(breath: Breath, long: bool) -> Action {
        match (breath, long) {
            (Breath::Sip, false) => Action::ShortSip,
            (Breath::Sip, true) => Action::LongSip,
            (Breath::Puff, false) => Action::ShortPuff,
            (Breath::Puff, true) => Action::LongPuff,
        }
    }

    /// Sip or puff.
    pub const fn breath(self) -> Breath {
        match self {
            Action::ShortSip | Action::LongSip => Breath::Sip,
            Action::ShortPuff | Action::LongPuff => Breath::Puff,
        }
    }

    /// Whether this is a long burst.
    pub const fn is_long(self) -> bool {
        matches!(self, Action::LongSip | Action::LongPuff)
    }
}

/// An action is written as its paper code (events, config printing).
impl Serialize for Action {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_i8(self.code())
    }
}

impl fmt::Display for Action {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = match self {
            Action::ShortSip => "short sip",
            Action::LongSip => "long sip",
            Action::ShortPuff => "short puff",
            Action::LongPuff => "long puff",
        };
        f.write_str(name)
    }
}

/// A sequence of at most [`MAX_SEQUENCE_LEN`] actions, inline: what the
/// tools that play, design and fit breaths work with.
pub type ActionSeq = InlineSeq<Action>;

impl SeqItem for Action {
    const FILLER: Action = Action::ShortSip;

    /// Its paper code.
    fn write(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.code())
    }
}

impl InlineSeq<Action> {
    /// The paper's codes, e.g. `[1, 2, -1]`.
    pub fn codes(&self) -> impl Iterator<Item = i8> + '_ {
        self.as_slice().iter().map(|a| a.code())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_are_the_papers() {
        assert_eq!(Action::ShortSip.code(), 1);
        assert_eq!(Action::LongSip.code(), 2);
        assert_eq!(Action::ShortPuff.code(), -1);
        assert_eq!(Action::LongPuff.code(), -2);
        for action in Action::ALL {
            assert_eq!(Action::from_code(action.code().into()), Some(action));
            assert_eq!(Action::new(action.breath(), action.is_long()), action);
        }
        assert_eq!(Action::from_code(0), None);
        assert_eq!(Action::from_code(3), None);
    }

    #[test]
    fn sequence_is_bounded() {
        let mut seq = ActionSeq::EMPTY;
        for _ in 0..MAX_SEQUENCE_LEN {
            seq.try_push(Action::LongPuff).unwrap();
        }
        assert_eq!(
            seq.try_push(Action::ShortSip),
            Err(SequenceFull(Action::ShortSip))
        );
        assert_eq!(seq.len(), MAX_SEQUENCE_LEN);
        assert!(ActionSeq::from_slice(&[Action::ShortSip; MAX_SEQUENCE_LEN + 1]).is_none());
        seq.clear();
        assert!(seq.is_empty());
    }

    #[test]
    fn equality_ignores_what_was_cleared() {
        let mut reused = ActionSeq::from_slice(&[Action::LongPuff, Action::LongPuff]).unwrap();
        reused.clear();
        reused.try_push(Action::LongSip).unwrap();
        let fresh = ActionSeq::from_slice(&[Action::LongSip]).unwrap();
        assert_eq!(reused, fresh);
        use std::hash::BuildHasher;
        let state = std::hash::RandomState::new();
        assert_eq!(state.hash_one(reused), state.hash_one(fresh));
    }
}
