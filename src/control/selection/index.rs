//! The library of sequences, walked one action at a time.
//!
//! [`TrieIndex`] (O(1) per burst, whatever the library size) is the
//! production choice, picked by the `matcher` criterion bench against
//! [`ScanIndex`], the obvious linear scan, which also serves as the
//! reference in the property tests.

use crate::control::action::{Action, ActionSeq};
use crate::control::selection::SequenceEntry;

/// Where the current sequence stands in the library after one more action.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Lookup<C> {
    /// Cursor for the extended sequence.
    pub cursor: C,
    /// Index (in library order) of the entry equal to the sequence, if any.
    pub exact: Option<usize>,
    /// Some longer entry starts with the sequence.
    pub has_longer: bool,
}

/// A library of sequences that can be walked one action at a time.
/// Built once (may allocate); [`SequenceIndex::advance`] is RT-safe.
pub trait SequenceIndex {
    /// Position of the current sequence in the index.
    type Cursor: Copy + std::fmt::Debug;

    /// Builds the index over a library. A duplicate sequence keeps its last
    /// entry; an empty one is never matched (a validated library has
    /// neither).
    fn build(library: &[SequenceEntry]) -> Self;

    /// Cursor of the empty sequence.
    fn root(&self) -> Self::Cursor;

    /// Extends `cursor` (the position of `cs` without its last action) by
    /// `action` (`cs`'s last action). `None` if no entry starts with `cs`.
    fn advance(
        &self,
        cursor: Self::Cursor,
        cs: &ActionSeq,
        action: Action,
    ) -> Option<Lookup<Self::Cursor>>;
}

const NO_ENTRY: u32 = u32::MAX;

#[derive(Debug, Clone, Copy)]
struct TrieNode {
    /// Child per action (in the order of [`Action::ALL`]); 0 means none
    /// (the root is never a child).
    children: [u32; 4],
    /// Library index of the sequence ending here, or [`NO_ENTRY`].
    entry: u32,
}

impl TrieNode {
    const EMPTY: TrieNode = TrieNode {
        children: [0; 4],
        entry: NO_ENTRY,
    };

    /// The child slot for `action`.
    fn child_mut(&mut self, action: Action) -> &mut u32 {
        let [short_sip, long_sip, short_puff, long_puff] = &mut self.children;
        match action {
            Action::ShortSip => short_sip,
            Action::LongSip => long_sip,
            Action::ShortPuff => short_puff,
            Action::LongPuff => long_puff,
        }
    }

    /// The child for `action`; 0 if none.
    fn child(mut self, action: Action) -> u32 {
        *self.child_mut(action)
    }
}

/// A trie over the four actions. Nodes are allocated once, at build time, in
/// one boxed slice; walking it is one array read per burst.
#[derive(Debug, Clone)]
pub struct TrieIndex {
    nodes: Box<[TrieNode]>,
}

impl SequenceIndex for TrieIndex {
    type Cursor = u32;

    fn build(library: &[SequenceEntry]) -> Self {
        let mut nodes = vec![TrieNode::EMPTY];
        for (i, entry) in library.iter().enumerate() {
            let mut at = 0usize;
            for &action in entry.actions.as_slice() {
                let existing = nodes.get(at).map_or(0, |n| n.child(action));
                at = if existing == 0 {
                    let new = nodes.len();
                    nodes.push(TrieNode::EMPTY);
                    if let Some(node) = nodes.get_mut(at) {
                        *node.child_mut(action) = new as u32;
                    }
                    new
                } else {
                    existing as usize
                };
            }
            if at != 0
                && let Some(node) = nodes.get_mut(at)
            {
                node.entry = i as u32;
            }
        }
        TrieIndex {
            nodes: nodes.into_boxed_slice(),
        }
    }

    fn root(&self) -> u32 {
        0
    }

    fn advance(&self, cursor: u32, _cs: &ActionSeq, action: Action) -> Option<Lookup<u32>> {
        let child = self.nodes.get(cursor as usize)?.child(action);
        if child == 0 {
            return None;
        }
        let node = self.nodes.get(child as usize)?;
        Some(Lookup {
            cursor: child,
            exact: (node.entry != NO_ENTRY).then_some(node.entry as usize),
            has_longer: node.children.iter().any(|&c| c != 0),
        })
    }
}

/// The reference index: compares the whole sequence with every entry.
#[derive(Debug, Clone)]
pub struct ScanIndex {
    entries: Box<[ActionSeq]>,
}

impl SequenceIndex for ScanIndex {
    type Cursor = ();

    fn build(library: &[SequenceEntry]) -> Self {
        ScanIndex {
            entries: library.iter().map(|e| e.actions).collect(),
        }
    }

    fn root(&self) {}

    fn advance(&self, _: (), cs: &ActionSeq, _action: Action) -> Option<Lookup<()>> {
        let cs = cs.as_slice();
        let mut exact = None;
        let mut has_longer = false;
        for (i, entry) in self.entries.iter().enumerate() {
            let entry = entry.as_slice();
            if entry == cs {
                exact = Some(i);
            } else if entry.len() > cs.len() && entry.starts_with(cs) {
                has_longer = true;
            }
        }
        (exact.is_some() || has_longer).then_some(Lookup {
            cursor: (),
            exact,
            has_longer,
        })
    }
}
