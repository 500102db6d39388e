//! A sequence stored inline: at most [`MAX_SEQUENCE_LEN`] items and a
//! length, `Copy`, never on the heap. The breath tools' sequences of
//! actions ([`ActionSeq`](crate::control::action::ActionSeq)) and the
//! core's sequences of tokens ([`Sequence`](crate::control::sequence::Sequence))
//! are both this type.

use std::fmt;

use serde::{Serialize, Serializer};

/// Longest sequence the matcher accepts: room for large personal
/// libraries, each sequence a small `Copy` value.
pub const MAX_SEQUENCE_LEN: usize = 16;

/// What a sequence may hold: a `Copy` value, a filler for the unused
/// slots, and how it is written in a file (`-1`, `"nod"`).
pub trait SeqItem: Copy + PartialEq + std::hash::Hash {
    /// Fills the slots not in use (never read).
    const FILLER: Self;

    /// The item as a file writes it.
    fn write(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result;
}

/// At most [`MAX_SEQUENCE_LEN`] items, inline. RT-safe. Equality and
/// hashing look only at the items held, never at the unused tail.
#[derive(Clone, Copy)]
pub struct InlineSeq<T: SeqItem> {
    items: [T; MAX_SEQUENCE_LEN],
    len: u8,
}

/// Returned by [`InlineSeq::try_push`] when the sequence is full; hands
/// the item back.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SequenceFull<T>(pub T);

impl<T: SeqItem> InlineSeq<T> {
    /// The empty sequence.
    pub const EMPTY: InlineSeq<T> = InlineSeq {
        items: [T::FILLER; MAX_SEQUENCE_LEN],
        len: 0,
    };

    /// The items of `items`, each turned into `T`; `None` if there are more
    /// than [`MAX_SEQUENCE_LEN`].
    pub fn from_slice<U: Copy + Into<T>>(items: &[U]) -> Option<InlineSeq<T>> {
        let mut seq = InlineSeq::EMPTY;
        for &item in items {
            seq.try_push(item).ok()?;
        }
        Some(seq)
    }

    /// Appends an item. RT-safe.
    pub fn try_push(&mut self, item: impl Into<T>) -> Result<(), SequenceFull<T>> {
        let item = item.into();
        let slot = self
            .items
            .get_mut(usize::from(self.len))
            .ok_or(SequenceFull(item))?;
        *slot = item;
        self.len += 1;
        Ok(())
    }

    /// The items, oldest first.
    pub fn as_slice(&self) -> &[T] {
        // `len` never exceeds the capacity (`try_push` checks).
        self.items.get(..usize::from(self.len)).unwrap_or(&[])
    }

    /// Number of items.
    pub fn len(&self) -> usize {
        usize::from(self.len)
    }

    /// Whether the sequence holds nothing.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Empties the sequence. RT-safe.
    pub fn clear(&mut self) {
        self.len = 0;
    }
}

impl<T: SeqItem> PartialEq for InlineSeq<T> {
    fn eq(&self, other: &Self) -> bool {
        self.as_slice() == other.as_slice()
    }
}

impl<T: SeqItem + Eq> Eq for InlineSeq<T> {}

impl<T: SeqItem> std::hash::Hash for InlineSeq<T> {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.as_slice().hash(state);
    }
}

impl<T: SeqItem> Default for InlineSeq<T> {
    fn default() -> Self {
        InlineSeq::EMPTY
    }
}

/// Written as its list of items, e.g. `[1, 2, -1]` or `["nod", -1]`.
impl<T: SeqItem + Serialize> Serialize for InlineSeq<T> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_seq(self.as_slice())
    }
}

/// As a file writes it: `[1, -1]`, `["nod", -1]`.
impl<T: SeqItem> fmt::Debug for InlineSeq<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        struct Written<T>(T);
        impl<T: SeqItem> fmt::Debug for Written<T> {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                self.0.write(f)
            }
        }
        f.debug_list()
            .entries(self.as_slice().iter().map(|&t| Written(t)))
            .finish()
    }
}
