//! What the interface may read when a sequence is meant, and what the
//! matcher then does with it.
//!
//! A meant sequence is read as made, or with one thing wrong: one burst
//! at the other length (the detector's misreading or the person's own
//! mistake), one burst as the other breath, one burst missed, one burst
//! nobody breathed (noise), or one gesture taken for another or rejected
//! (the set's leave-one-out rates).
//! Two things wrong at once is left out: at the rates measured here
//! (under 1 % per burst) it is a hundredth of the one-item cases.
//!
//! The matcher's rules are the production matcher's, applied to whole
//! sequences: after each item, a library sequence nothing longer starts
//! with matches at once; one a longer sequence starts with matches at the
//! timeout; a proper prefix waits and resets at the timeout; anything
//! else resets at once and the next item starts afresh. The first match
//! ends the selection: later items are made in the matched mode.

use crate::control::action::{Action, Breath};
use crate::design::breathing::Breathing;
use crate::design::symbol::{Symbol, SymbolSeq};

/// How a meant sequence was read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Deviation {
    /// Read as made.
    None,
    /// Burst `i` read (or breathed) at the other length.
    Length(usize),
    /// Burst `i` read as the other breath (a sip as a puff).
    Swapped(usize),
    /// Item `i` not read: a burst missed, a gesture rejected.
    Missed(usize),
    /// A burst nobody breathed, read before item `i` (or after the last).
    Extra(usize),
    /// Gesture `i` taken for the gesture given.
    Taken(usize, Symbol),
}

/// One way of reading a meant sequence: what was read and its chance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SequenceReading {
    /// What went wrong.
    pub deviation: Deviation,
    /// The bursts and gestures the matcher receives.
    pub read: SymbolSeq,
    /// Chance of this reading.
    pub p: f64,
    /// The time the person spent on a gesture the reading does not show
    /// as made, ms: a rejected gesture's (and the gap after it), or a
    /// gesture taken for another's less the other's (which may be less
    /// than 0). 0 for bursts: the reading's items are timed as read.
    pub unseen_ms: f64,
    /// The unseen time counts once the matcher has read this many items
    /// (the person made the gesture before the next item).
    pub unseen_at: usize,
}

impl SequenceReading {
    /// The unseen time spent by the time the matcher has read `k` items.
    pub fn unseen_by(&self, k: usize) -> f64 {
        if k >= self.unseen_at {
            self.unseen_ms
        } else {
            0.0
        }
    }
}

/// What the matcher does with a reading.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Decision {
    /// Library entry `i` is selected after item `at` (counted in the
    /// reading), at once or after the timeout.
    Match {
        /// The entry.
        entry: usize,
        /// The last item it took.
        at: usize,
        /// The matcher waited the timeout (a longer sequence starts with it).
        waited: bool,
    },
    /// Nothing is selected; the last reset came at the timeout or not.
    Nothing {
        /// The reset came after the timeout.
        waited: bool,
    },
}

/// The same burst at the other length.
pub fn other_length(a: Action) -> Action {
    Action::new(a.breath(), !a.is_long())
}

/// The same length of the other breath.
pub fn other_breath(a: Action) -> Action {
    let breath = match a.breath() {
        Breath::Sip => Breath::Puff,
        Breath::Puff => Breath::Sip,
    };
    Action::new(breath, a.is_long())
}

/// Every reading of `meant` with one thing wrong at most, with its chance,
/// for this person. The chances sum to 1.
pub fn readings(meant: &[Symbol], who: &Breathing) -> Vec<SequenceReading> {
    let n = meant.len();
    let bursts = meant.iter().filter(|s| s.action().is_some()).count();
    let mut out = Vec::with_capacity(3 * n + 2);
    // The person's own mistake: one burst, chosen evenly, at the other
    // length (a sequence of gestures alone has none).
    let mistake = if bursts == 0 {
        0.0
    } else {
        who.error_rate / bursts as f64
    };
    // Noise: a false burst while the sequence is made, split evenly over
    // where it lands and which breath it is.
    let breathing_ms: f64 = meant.iter().map(|s| who.time_ms(*s)).sum::<f64>()
        + n.saturating_sub(1) as f64 * who.gap_ms;
    let extra = (who.false_per_hour * breathing_ms / 3_600_000.0).min(0.5);
    let mut rest = 1.0;
    let with = |i: usize, s: Symbol| {
        let mut read = meant.to_vec();
        read[i] = s;
        read
    };
    let without = |i: usize| {
        let mut read = meant.to_vec();
        read.remove(i);
        read
    };
    for (i, s) in meant.iter().enumerate() {
        let Some(a) = s.action() else {
            let Some(gesture) = who.gesture(*s) else {
                continue;
            };
            for taken in &gesture.taken_for {
                if let Some(h) = Symbol::gesture(taken.index) {
                    out.push(SequenceReading {
                        unseen_ms: who.time_ms(*s) - who.time_ms(h),
                        unseen_at: i + 1,
                        ..reading(Deviation::Taken(i, h), &with(i, h), taken.p)
                    });
                    rest -= taken.p;
                }
            }
            let gap = if n > 1 { who.gap_ms } else { 0.0 };
            out.push(SequenceReading {
                unseen_ms: who.time_ms(*s) + gap,
                unseen_at: i,
                ..reading(Deviation::Missed(i), &without(i), gesture.rejected)
            });
            rest -= gesture.rejected;
            continue;
        };
        let burst = who.burst(a);
        let p = mistake + burst.other_length;
        out.push(reading(
            Deviation::Length(i),
            &with(i, other_length(a).into()),
            p,
        ));
        if who.swap_rate > 0.0 {
            out.push(reading(
                Deviation::Swapped(i),
                &with(i, other_breath(a).into()),
                who.swap_rate,
            ));
            rest -= who.swap_rate;
        }
        out.push(reading(Deviation::Missed(i), &without(i), burst.missed));
        rest -= p + burst.missed;
    }
    if extra > 0.0 {
        for i in 0..=n {
            for breath in [Breath::Sip, Breath::Puff] {
                let mut read = meant.to_vec();
                read.insert(i, Action::new(breath, false).into());
                let p = extra / (2 * (n + 1)) as f64;
                out.push(reading(Deviation::Extra(i), &read, p));
                rest -= p;
            }
        }
    }
    out.push(reading(Deviation::None, meant, rest.max(0.0)));
    out.retain(|r| r.p > 0.0);
    out
}

fn reading(deviation: Deviation, read: &[Symbol], p: f64) -> SequenceReading {
    SequenceReading {
        deviation,
        // An item more than the longest sequence reads as nothing.
        read: SymbolSeq::from_slice(read).unwrap_or(SymbolSeq::EMPTY),
        p,
        unseen_ms: 0.0,
        unseen_at: 0,
    }
}

/// What the matcher makes of `read` with `library` (each entry's items).
pub fn outcome<'a, T: PartialEq + 'a>(
    read: &[T],
    library: impl Fn(usize) -> Option<&'a [T]>,
) -> Decision {
    let entries = || (0..).map_while(&library).enumerate();
    let mut start = 0;
    for end in 1..=read.len() {
        let cs = &read[start..end];
        let is_entry = entries().find(|(_, e)| *e == cs).map(|(i, _)| i);
        let extended = entries().any(|(_, e)| e.len() > cs.len() && e.starts_with(cs));
        match (is_entry, extended) {
            (Some(entry), false) => {
                return Decision::Match {
                    entry,
                    at: end,
                    waited: false,
                };
            }
            (_, true) => {}
            (None, false) => start = end,
        }
    }
    let cs = &read[start..];
    if cs.is_empty() {
        return Decision::Nothing { waited: false };
    }
    match entries().find(|(_, e)| *e == cs) {
        Some((entry, _)) => Decision::Match {
            entry,
            at: read.len(),
            waited: true,
        },
        None => Decision::Nothing { waited: true },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::action::Action::{LongPuff, LongSip, ShortPuff, ShortSip};
    use crate::control::action::ActionSeq;
    use crate::control::detector::Burst;
    use crate::control::mode::Mode;
    use crate::control::selection::SequenceEntry;
    use crate::control::selection::matcher::{MatchEvent, MatcherConfig, SequenceMatcher};
    use crate::control::sequence::Sequence;
    use crate::sim::user::UserModel;
    use proptest::prelude::*;

    fn lib<'a>(entries: &'a [&'a [Action]]) -> impl Fn(usize) -> Option<&'a [Action]> {
        move |i| entries.get(i).copied()
    }

    #[test]
    fn the_matcher_rules_on_whole_sequences() {
        let library: &[&[Action]] = &[&[ShortPuff], &[ShortPuff, ShortSip], &[LongPuff, LongSip]];
        // A prefix of a longer entry matches at the timeout.
        assert_eq!(
            outcome(&[ShortPuff], lib(library)),
            Decision::Match {
                entry: 0,
                at: 1,
                waited: true
            }
        );
        // Nothing longer starts with it: at once.
        assert_eq!(
            outcome(&[ShortPuff, ShortSip], lib(library)),
            Decision::Match {
                entry: 1,
                at: 2,
                waited: false
            }
        );
        // A prefix that is no entry resets at the timeout.
        assert_eq!(
            outcome(&[LongPuff], lib(library)),
            Decision::Nothing { waited: true }
        );
        // Neither resets at once, and the next burst starts afresh.
        assert_eq!(
            outcome(&[LongSip, ShortPuff, ShortSip], lib(library)),
            Decision::Match {
                entry: 1,
                at: 3,
                waited: false
            }
        );
    }

    #[test]
    fn readings_sum_to_one_and_a_mistake_flips_one_burst() {
        let who = Breathing::of_model(
            &UserModel::POPULATION,
            &crate::control::detector::DetectorConfig::default(),
            "x",
        );
        let r = readings(&[LongPuff.into(), ShortSip.into()], &who);
        let total: f64 = r.iter().map(|r| r.p).sum();
        assert!((total - 1.0).abs() < 1e-12);
        let flipped_first = r
            .iter()
            .find(|r| r.deviation == Deviation::Length(0))
            .unwrap();
        // Half the 5 % mistakes, plus Φ(−2.5) of long puffs read short.
        assert!((flipped_first.p - (0.025 + 0.00621)).abs() < 1e-4);
        assert_eq!(
            flipped_first.read.as_slice(),
            [Symbol::from(ShortPuff), ShortSip.into()]
        );
    }

    fn action() -> impl Strategy<Value = Action> {
        prop::sample::select(Action::ALL.to_vec())
    }

    proptest! {
        /// The whole-sequence rules agree with the production matcher fed
        /// the same bursts a gap apart, for any library and any reading.
        #[test]
        fn the_rules_are_the_production_matchers(
            entries in prop::collection::vec(prop::collection::vec(action(), 1..4), 1..8),
            read in prop::collection::vec(action(), 1..5),
        ) {
            let mut library: Vec<Vec<Action>> = Vec::new();
            for e in entries {
                if !library.contains(&e) {
                    library.push(e);
                }
            }
            let production: Vec<SequenceEntry> = library
                .iter()
                .map(|e| SequenceEntry::mode(ActionSeq::from_slice(e).unwrap(), Mode::TranslateX))
                .collect();
            let mut matcher = SequenceMatcher::new(&production, &MatcherConfig { sequence_timeout_ms: 1000 });
            let position = |sequence: Sequence| {
                library.iter().position(|e| Sequence::from_slice(e).unwrap() == sequence).unwrap()
            };
            let mut got = None;
            let mut tick = 0;
            for (i, a) in read.iter().enumerate() {
                tick += 300;
                let burst = Burst { action: *a, start: tick - 100, end: tick };
                if let Some(MatchEvent::Match { sequence, .. }) = matcher.on_burst(&burst) {
                    got = Some(Decision::Match { entry: position(sequence), at: i + 1, waited: false });
                    break;
                }
            }
            let got = got.unwrap_or_else(|| match matcher.on_tick(tick + 1000, false) {
                Some(MatchEvent::Match { sequence, .. }) => {
                    Decision::Match { entry: position(sequence), at: read.len(), waited: true }
                }
                Some(MatchEvent::Reset { .. }) => Decision::Nothing { waited: true },
                None => Decision::Nothing { waited: false },
            });
            let slices: Vec<&[Action]> = library.iter().map(Vec::as_slice).collect();
            prop_assert_eq!(outcome(&read, lib(&slices)), got);
        }
    }
}
