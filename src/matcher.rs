//! Sequence matcher (the paper's Fig. 3): bursts in, matches and resets out.
//!
//! On each burst its action is appended to the current sequence (CS), then:
//!
//! | CS is …                                   | then                          |
//! |-------------------------------------------|-------------------------------|
//! | a UDS, and no longer UDS starts with it   | match now (the user never waits) |
//! | a UDS, and a longer UDS starts with it    | wait; on timeout, match it    |
//! | a proper prefix of a UDS, not a UDS       | wait; on timeout, reset       |
//! | neither a UDS nor a prefix of one         | reset now                     |
//!
//! The timeout runs from the end of the last burst and does not run out
//! while a breath is in progress.
//!
//! The library lives in a [`SequenceIndex`]. [`TrieIndex`] (O(1) per burst,
//! whatever the library size) is the production choice, picked by the
//! `matcher` criterion bench against [`ScanIndex`], the obvious linear scan,
//! which also serves as the reference in the property tests.

use crate::Tick;
use crate::action::{Action, ActionSeq};
use crate::config::SequenceEntry;
use crate::detector::Burst;
use crate::modes::Mode;

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

    /// Builds the index over a validated library (no duplicates, no empty
    /// sequence).
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
    /// Child per action ([`Action::index`]); 0 means none (the root is never
    /// a child).
    children: [u32; 4],
    /// Library index of the sequence ending here, or [`NO_ENTRY`].
    entry: u32,
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
        let empty = TrieNode {
            children: [0; 4],
            entry: NO_ENTRY,
        };
        let mut nodes = vec![empty];
        for (i, entry) in library.iter().enumerate() {
            let mut at = 0usize;
            for action in entry.actions.as_slice() {
                let child = nodes[at].children[action.index()];
                at = if child == 0 {
                    nodes.push(empty);
                    let new = nodes.len() - 1;
                    nodes[at].children[action.index()] = new as u32;
                    new
                } else {
                    child as usize
                };
            }
            nodes[at].entry = i as u32;
        }
        TrieIndex {
            nodes: nodes.into_boxed_slice(),
        }
    }

    fn root(&self) -> u32 {
        0
    }

    fn advance(&self, cursor: u32, _cs: &ActionSeq, action: Action) -> Option<Lookup<u32>> {
        let child = self.nodes.get(cursor as usize)?.children[action.index()];
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

/// Why the current sequence was dropped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ResetReason {
    /// The sequence is neither a UDS nor the start of one.
    NoMatch,
    /// The sequence was the start of a UDS, and no burst came in time.
    Timeout,
    /// A sensor fault interrupted the sequence.
    Fault,
}

impl ResetReason {
    /// Name used in the event log.
    pub const fn name(self) -> &'static str {
        match self {
            ResetReason::NoMatch => "no_match",
            ResetReason::Timeout => "timeout",
            ResetReason::Fault => "fault",
        }
    }
}

/// What the matcher decided on one tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MatchEvent {
    /// The sequence matched a UDS.
    Match {
        /// The matched sequence.
        sequence: ActionSeq,
        /// Its mode.
        mode: Mode,
    },
    /// The sequence was dropped.
    Reset {
        /// The dropped sequence.
        sequence: ActionSeq,
        /// Why.
        reason: ResetReason,
    },
}

/// The sequence matcher. Construct once at start-up; `on_burst`, `on_tick`
/// and `interrupt` are RT-safe (no allocation, no panic).
#[derive(Debug, Clone)]
pub struct SequenceMatcher<I: SequenceIndex = TrieIndex> {
    index: I,
    modes: Box<[Mode]>,
    timeout: u64,
    cs: ActionSeq,
    cursor: I::Cursor,
    /// The CS equals this entry but a longer one starts with it.
    pending: Option<usize>,
    last_end: Tick,
}

impl<I: SequenceIndex> SequenceMatcher<I> {
    /// Builds the matcher over a validated library. Not RT-safe (allocates).
    pub fn new(library: &[SequenceEntry], sequence_timeout_ms: u32) -> Self {
        let index = I::build(library);
        let cursor = index.root();
        SequenceMatcher {
            index,
            modes: library.iter().map(|e| e.mode).collect(),
            timeout: sequence_timeout_ms.into(),
            cs: ActionSeq::EMPTY,
            cursor,
            pending: None,
            last_end: 0,
        }
    }

    /// The current sequence (what the user has entered so far).
    pub fn current(&self) -> &ActionSeq {
        &self.cs
    }

    /// Appends a finished burst to the current sequence. RT-safe.
    pub fn on_burst(&mut self, burst: &Burst) -> Option<MatchEvent> {
        self.last_end = burst.end;
        if self.cs.try_push(burst.action).is_err() {
            // Unreachable with a validated library (a full CS is never a
            // proper prefix); kept total so the control thread cannot panic.
            return self.reset(ResetReason::NoMatch);
        }
        match self.index.advance(self.cursor, &self.cs, burst.action) {
            None => self.reset(ResetReason::NoMatch),
            Some(Lookup {
                exact: Some(entry),
                has_longer: false,
                ..
            }) => self.matched(entry),
            Some(lookup) => {
                self.cursor = lookup.cursor;
                self.pending = lookup.exact;
                None
            }
        }
    }

    /// Runs the timeout: call every tick, after `on_burst`. RT-safe.
    pub fn on_tick(&mut self, now: Tick, breath_in_progress: bool) -> Option<MatchEvent> {
        if self.cs.is_empty() || breath_in_progress || now < self.last_end + self.timeout {
            return None;
        }
        match self.pending {
            Some(entry) => self.matched(entry),
            None => self.reset(ResetReason::Timeout),
        }
    }

    /// Drops the current sequence after a sensor fault. RT-safe.
    pub fn interrupt(&mut self) -> Option<MatchEvent> {
        if self.cs.is_empty() {
            None
        } else {
            self.reset(ResetReason::Fault)
        }
    }

    fn matched(&mut self, entry: usize) -> Option<MatchEvent> {
        let sequence = self.cs;
        let mode = *self.modes.get(entry)?;
        self.clear();
        Some(MatchEvent::Match { sequence, mode })
    }

    fn reset(&mut self, reason: ResetReason) -> Option<MatchEvent> {
        let sequence = self.cs;
        self.clear();
        Some(MatchEvent::Reset { sequence, reason })
    }

    fn clear(&mut self) {
        self.cs.clear();
        self.cursor = self.index.root();
        self.pending = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use Action::{LongPuff, LongSip, ShortPuff, ShortSip};

    fn entry(actions: &[Action], mode: Mode) -> SequenceEntry {
        SequenceEntry {
            actions: ActionSeq::from_slice(actions).unwrap(),
            mode,
        }
    }

    /// The paper's example: S1 = ⟨1, 2, −1⟩, S2 = ⟨1, 2⟩, S3 = ⟨2, 1⟩.
    fn paper<I: SequenceIndex>() -> SequenceMatcher<I> {
        SequenceMatcher::new(
            &[
                entry(&[ShortSip, LongSip, ShortPuff], Mode::TranslateX),
                entry(&[ShortSip, LongSip], Mode::TranslateY),
                entry(&[LongSip, ShortSip], Mode::TranslateZ),
            ],
            1000,
        )
    }

    fn b(action: Action, end: Tick) -> Burst {
        Burst {
            action,
            start: end - 100,
            end,
        }
    }

    fn matched(actions: &[Action], mode: Mode) -> Option<MatchEvent> {
        Some(MatchEvent::Match {
            sequence: ActionSeq::from_slice(actions).unwrap(),
            mode,
        })
    }

    fn reset(actions: &[Action], reason: ResetReason) -> Option<MatchEvent> {
        Some(MatchEvent::Reset {
            sequence: ActionSeq::from_slice(actions).unwrap(),
            reason,
        })
    }

    /// Every case of the paper's worked example, for both indexes.
    fn paper_cases<I: SequenceIndex>() {
        // ⟨2⟩: no confusion, wait for a 1 to match S3 (16-17-19-22) …
        let mut m = paper::<I>();
        assert_eq!(m.on_burst(&b(LongSip, 1000)), None);
        assert_eq!(m.on_tick(1999, false), None);
        // … which matches on the very tick it arrives (16-17-18-21).
        assert_eq!(
            m.on_burst(&b(ShortSip, 1500)),
            matched(&[LongSip, ShortSip], Mode::TranslateZ)
        );
        assert!(m.current().is_empty());

        // ⟨2⟩ and the user takes too long: reset (16-20-23), exactly 1000 ms
        // after the end of the burst.
        let mut m = paper::<I>();
        m.on_burst(&b(LongSip, 1000));
        assert_eq!(m.on_tick(1999, false), None);
        assert_eq!(
            m.on_tick(2000, false),
            reset(&[LongSip], ResetReason::Timeout)
        );

        // ⟨1, 2⟩: confusion between S1 and S2, wait (16-17-18-22) …
        let mut m = paper::<I>();
        assert_eq!(m.on_burst(&b(ShortSip, 1000)), None);
        assert_eq!(m.on_burst(&b(LongSip, 1800)), None);
        // … a −1 matches S1 (16-17-18-21).
        assert_eq!(
            m.on_burst(&b(ShortPuff, 2500)),
            matched(&[ShortSip, LongSip, ShortPuff], Mode::TranslateX)
        );

        // ⟨1, 2⟩ then a peak that is not −1: reset (16-17-19-23).
        let mut m = paper::<I>();
        m.on_burst(&b(ShortSip, 1000));
        m.on_burst(&b(LongSip, 1800));
        assert_eq!(
            m.on_burst(&b(ShortSip, 2500)),
            reset(&[ShortSip, LongSip, ShortSip], ResetReason::NoMatch)
        );

        // ⟨1, 2⟩ and no new peak: S2 is matched at the timeout (16-20-21).
        let mut m = paper::<I>();
        m.on_burst(&b(ShortSip, 1000));
        m.on_burst(&b(LongSip, 1800));
        assert_eq!(m.on_tick(2799, false), None);
        assert_eq!(
            m.on_tick(2800, false),
            matched(&[ShortSip, LongSip], Mode::TranslateY)
        );
        assert_eq!(m.on_tick(5000, false), None, "matched once");

        // A first action that starts no UDS: reset on this tick.
        let mut m = paper::<I>();
        assert_eq!(
            m.on_burst(&b(LongPuff, 1000)),
            reset(&[LongPuff], ResetReason::NoMatch)
        );

        // A breath in progress holds the timeout off.
        let mut m = paper::<I>();
        m.on_burst(&b(ShortSip, 1000));
        m.on_burst(&b(LongSip, 1800));
        assert_eq!(m.on_tick(2800, true), None);
        assert_eq!(m.on_tick(3500, true), None);
        assert_eq!(
            m.on_tick(3501, false),
            matched(&[ShortSip, LongSip], Mode::TranslateY),
            "a breath too short to count does not cancel the pending match"
        );

        // A fault drops the sequence.
        let mut m = paper::<I>();
        m.on_burst(&b(ShortSip, 1000));
        assert_eq!(m.interrupt(), reset(&[ShortSip], ResetReason::Fault));
        assert_eq!(m.interrupt(), None);
    }

    #[test]
    fn paper_example_trie() {
        paper_cases::<TrieIndex>();
    }

    #[test]
    fn paper_example_scan() {
        paper_cases::<ScanIndex>();
    }

    #[test]
    fn a_full_length_sequence_matches() {
        let long = [ShortPuff; crate::action::MAX_SEQUENCE_LEN];
        let mut m: SequenceMatcher = SequenceMatcher::new(&[entry(&long, Mode::Fingers)], 1000);
        for (i, &a) in long.iter().enumerate() {
            let event = m.on_burst(&b(a, 1000 + 200 * i as Tick));
            if i + 1 < long.len() {
                assert_eq!(event, None);
            } else {
                assert_eq!(event, matched(&long, Mode::Fingers));
            }
        }
    }
}
