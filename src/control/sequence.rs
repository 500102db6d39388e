//! Inline sequences of tokens (breaths and gestures): what the user
//! enters, what a library entry holds, what an event reports.

use crate::control::action::ActionSeq;
use crate::control::inline_seq::InlineSeq;
use crate::control::token::Token;

/// At most [`MAX_SEQUENCE_LEN`](crate::control::inline_seq::MAX_SEQUENCE_LEN)
/// tokens, inline (under 300 bytes) so the control thread never
/// allocates. Written as in a library entry: `[1, -1]`, `["nod", -1]`.
pub type Sequence = InlineSeq<Token>;

impl InlineSeq<Token> {
    /// A sequence of `tokens`; `None` if there are too many.
    pub fn from_tokens(tokens: impl IntoIterator<Item = Token>) -> Option<Sequence> {
        let mut seq = Sequence::EMPTY;
        for token in tokens {
            seq.try_push(token).ok()?;
        }
        Some(seq)
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
}

impl From<ActionSeq> for Sequence {
    fn from(actions: ActionSeq) -> Sequence {
        Sequence::from_slice(actions.as_slice()).unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::action::Action;
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
