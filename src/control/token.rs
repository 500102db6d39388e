//! One element of a sequence: a burst of breath (the paper's four
//! actions) or a gesture the person recorded. A library entry may hold
//! either or both, and the matcher compares them alike.

use std::fmt;

use serde::{Serialize, Serializer};

use crate::control::action::Action;
use crate::control::gesture::name::GestureName;
use crate::control::inline_seq::SeqItem;

/// A breath's action or a gesture. `Copy`, RT-safe.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Token {
    /// A short or long sip or puff.
    Breath(Action),
    /// A recognised head gesture, by its name in the gesture set.
    Gesture(GestureName),
}

impl Token {
    /// The breath's action, if this is one.
    pub const fn action(self) -> Option<Action> {
        match self {
            Token::Breath(action) => Some(action),
            Token::Gesture(_) => None,
        }
    }
}

impl SeqItem for Token {
    const FILLER: Token = Token::Breath(Action::ShortSip);

    /// A breath by its paper code, a gesture by its quoted name.
    fn write(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Token::Breath(action) => write!(f, "{}", action.code()),
            Token::Gesture(name) => write!(f, "{name:?}"),
        }
    }
}

impl From<Action> for Token {
    fn from(action: Action) -> Token {
        Token::Breath(action)
    }
}

impl From<GestureName> for Token {
    fn from(name: GestureName) -> Token {
        Token::Gesture(name)
    }
}

/// A breath is written as its paper code, a gesture as its name, as in
/// a library entry: `[-1, "nod"]`.
impl Serialize for Token {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        match self {
            Token::Breath(action) => action.serialize(serializer),
            Token::Gesture(name) => name.serialize(serializer),
        }
    }
}

impl fmt::Display for Token {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Token::Breath(action) => action.fmt(f),
            Token::Gesture(name) => name.fmt(f),
        }
    }
}
