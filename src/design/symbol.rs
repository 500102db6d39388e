//! One element of a sequence as the designer counts it: one of the four
//! bursts, or one of the person's gestures by its place in their set. A
//! byte, so the search copies and compares sequences with gestures as
//! cheaply as sequences of bursts alone; the person
//! ([`Breathing`](crate::design::breathing::Breathing)) turns a library's
//! tokens into symbols and back.

use std::fmt;

use crate::control::action::Action;
use crate::control::inline_seq::{InlineSeq, SeqItem};

/// A burst (in [`Action::ALL`]'s order), or gesture `k` of the person's
/// set after them. Ordered so: the bursts as [`Action`] orders them, then
/// the gestures as the set lists them (the order the search keeps the
/// first of libraries of equal cost by).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Symbol(u8);

/// The bursts' symbols come first.
const BURSTS: usize = Action::ALL.len();

impl Symbol {
    /// The burst `a`.
    pub const fn burst(a: Action) -> Symbol {
        Symbol(a.index() as u8)
    }

    /// Gesture `k` of the person's set (`None` past what a byte holds).
    pub fn gesture(k: usize) -> Option<Symbol> {
        u8::try_from(BURSTS + k).ok().map(Symbol)
    }

    /// The burst, if this is one.
    pub fn action(self) -> Option<Action> {
        Action::ALL.get(usize::from(self.0)).copied()
    }

    /// Whether this is a burst.
    pub fn is_burst(self) -> bool {
        usize::from(self.0) < BURSTS
    }

    /// Its place in the person's alphabet: the bursts' [`Action::index`],
    /// then each gesture's place in the set after them.
    pub fn index(self) -> usize {
        usize::from(self.0)
    }

    /// The gesture's place in the person's set, if this is one.
    pub fn gesture_index(self) -> Option<usize> {
        usize::from(self.0).checked_sub(BURSTS)
    }
}

impl From<Action> for Symbol {
    fn from(a: Action) -> Symbol {
        Symbol::burst(a)
    }
}

impl SeqItem for Symbol {
    const FILLER: Symbol = Symbol(0);

    /// A burst by its paper code, a gesture by its place (`"gesture 1"`):
    /// only the person knows its name.
    fn write(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.action(), self.gesture_index()) {
            (Some(a), _) => write!(f, "{}", a.code()),
            (None, Some(k)) => write!(f, "\"gesture {}\"", k + 1),
            (None, None) => Ok(()),
        }
    }
}

/// A sequence of symbols, inline as [`ActionSeq`](crate::control::action::ActionSeq) is.
pub type SymbolSeq = InlineSeq<Symbol>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bursts_keep_their_order_and_gestures_come_after() {
        for (a, b) in Action::ALL.iter().zip(Action::ALL.iter().skip(1)) {
            assert_eq!(a.cmp(b), Symbol::burst(*a).cmp(&Symbol::burst(*b)));
        }
        let nod = Symbol::gesture(0).unwrap();
        assert!(Symbol::burst(Action::LongPuff) < nod);
        assert_eq!(nod.gesture_index(), Some(0));
        assert_eq!(nod.action(), None);
        assert_eq!(Symbol::burst(Action::ShortPuff).gesture_index(), None);
        let seq = SymbolSeq::from_slice(&[Symbol::burst(Action::ShortPuff), nod]).unwrap();
        assert_eq!(format!("{seq:?}"), r#"[-1, "gesture 1"]"#);
    }
}
