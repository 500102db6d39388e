//! Fixed-capacity sequences of tokens (breaths and gestures): what the
//! user enters, what a library entry holds, what an event reports.

use std::fmt;

use serde::{Serialize, Serializer};

use crate::control::action::{Action, ActionSeq, MAX_SEQUENCE_LEN};
use crate::control::token::Token;

/// A sequence of at most [`MAX_SEQUENCE_LEN`] tokens, stored inline so it
/// is `Copy` and never touches the heap. RT-safe. Equality and hashing look
/// only at the tokens held, never at the unused tail of the array.
#[derive(Clone, Copy)]
pub struct Sequence {
    tokens: [Token; MAX_SEQUENCE_LEN],
    len: u8,
}

/// Returned by [`Sequence::try_push`] when the sequence is full; hands the
/// token back.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SequenceFull(pub Token);

impl Sequence {
    /// The empty sequence.
    pub const EMPTY: Sequence = Sequence {
        tokens: [Token::Breath(Action::ShortSip); MAX_SEQUENCE_LEN],
        len: 0,
    };

    /// A sequence of breaths; `None` if longer than [`MAX_SEQUENCE_LEN`].
    pub fn from_slice(actions: &[Action]) -> Option<Sequence> {
        Sequence::from_tokens(actions.iter().map(|&a| Token::Breath(a)))
    }

    /// A sequence of `tokens`; `None` if longer than [`MAX_SEQUENCE_LEN`].
    pub fn from_tokens(tokens: impl IntoIterator<Item = Token>) -> Option<Sequence> {
        let mut seq = Sequence::EMPTY;
        for token in tokens {
            seq.try_push(token).ok()?;
        }
        Some(seq)
    }

    /// Appends a breath's action or a gesture. RT-safe.
    pub fn try_push(&mut self, token: impl Into<Token>) -> Result<(), SequenceFull> {
        let token = token.into();
        let slot = self
            .tokens
            .get_mut(usize::from(self.len))
            .ok_or(SequenceFull(token))?;
        *slot = token;
        self.len += 1;
        Ok(())
    }

    /// The tokens, oldest first.
    pub fn as_slice(&self) -> &[Token] {
        // `len` never exceeds the capacity (`try_push` checks).
        self.tokens.get(..usize::from(self.len)).unwrap_or(&[])
    }

    /// The breaths' actions, if the sequence holds no gesture: what the
    /// tools that play, design or fit breaths work with. RT-safe.
    pub fn actions(&self) -> Option<ActionSeq> {
        let mut actions = ActionSeq::EMPTY;
        for token in self.as_slice() {
            actions.try_push(token.action()?).ok()?;
        }
        Some(actions)
    }

    /// Whether any token is a gesture.
    pub fn has_gesture(&self) -> bool {
        self.as_slice()
            .iter()
            .any(|t| matches!(t, Token::Gesture(_)))
    }

    /// Number of tokens.
    pub fn len(&self) -> usize {
        usize::from(self.len)
    }

    /// Whether the sequence holds no token.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Empties the sequence. RT-safe.
    pub fn clear(&mut self) {
        self.len = 0;
    }
}

impl From<ActionSeq> for Sequence {
    fn from(actions: ActionSeq) -> Sequence {
        Sequence::from_tokens(actions.as_slice().iter().map(|&a| Token::Breath(a)))
            .unwrap_or_default()
    }
}

impl PartialEq for Sequence {
    fn eq(&self, other: &Self) -> bool {
        self.as_slice() == other.as_slice()
    }
}

impl Eq for Sequence {}

impl std::hash::Hash for Sequence {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.as_slice().hash(state);
    }
}

impl Default for Sequence {
    fn default() -> Self {
        Sequence::EMPTY
    }
}

/// A sequence is written as its list of tokens: paper codes for breaths,
/// names for gestures, e.g. `[1, 2, -1]` or `["nod", -1]`.
impl Serialize for Sequence {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_seq(self.as_slice())
    }
}

/// As written: `[1, -1]`, `["nod", -1]`.
impl fmt::Debug for Sequence {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        struct Written(Token);
        impl fmt::Debug for Written {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                match self.0 {
                    Token::Breath(action) => write!(f, "{}", action.code()),
                    Token::Gesture(name) => write!(f, "{name:?}"),
                }
            }
        }
        f.debug_list()
            .entries(self.as_slice().iter().map(|&t| Written(t)))
            .finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::gesture::name::GestureName;

    #[test]
    fn breaths_are_codes_and_gestures_names() {
        let nod = GestureName::new("nod").unwrap();
        let mixed =
            Sequence::from_tokens([Token::Gesture(nod), Token::Breath(Action::ShortPuff)]).unwrap();
        assert_eq!(serde_json::to_string(&mixed).unwrap(), r#"["nod",-1]"#);
        assert_eq!(format!("{mixed:?}"), r#"["nod", -1]"#);
        assert_eq!(mixed.actions(), None);
        assert!(mixed.has_gesture());
        let breaths = Sequence::from_slice(&[Action::LongSip, Action::ShortPuff]).unwrap();
        assert_eq!(serde_json::to_string(&breaths).unwrap(), "[2,-1]");
        assert_eq!(
            breaths.actions(),
            ActionSeq::from_slice(&[Action::LongSip, Action::ShortPuff])
        );
        assert_eq!(Sequence::from(breaths.actions().unwrap()), breaths);
    }
}
