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
//! while a breath is in progress. The CS is compared with every UDS, as
//! the paper does: a library is a few short sequences, and a burst comes
//! at most every few tens of milliseconds.

use serde::Serialize;

use crate::control::Tick;
use crate::control::detector::Burst;
use crate::control::selection::SequenceEntry;
use crate::control::sequence::Sequence;
use crate::control::target::Target;
use crate::control::token::Token;

/// Sequence matcher settings (`[matcher]` in the config file).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MatcherConfig {
    /// How long the matcher waits for the next burst of a sequence that is a
    /// prefix of a longer one, counted from the end of the last burst.
    pub sequence_timeout_ms: u32,
}

impl Default for MatcherConfig {
    fn default() -> Self {
        MatcherConfig {
            sequence_timeout_ms: 1000,
        }
    }
}

/// Why the current sequence was dropped. Serialized by its name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ResetReason {
    /// The sequence is neither a UDS nor the start of one.
    NoMatch,
    /// The sequence was the start of a UDS, and no burst came in time.
    Timeout,
    /// A sensor fault interrupted the sequence.
    Fault,
    /// A breath in command mode moved the arm (with `motion_onset_ms`):
    /// the sequence begun before it is void.
    Moved,
}

/// What the matcher decided on one tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MatchEvent {
    /// The sequence matched a UDS.
    Match {
        /// The matched sequence.
        sequence: Sequence,
        /// What its entry selects or fires.
        target: Target,
    },
    /// The sequence was dropped.
    Reset {
        /// The dropped sequence.
        sequence: Sequence,
        /// Why.
        reason: ResetReason,
    },
}

/// The sequence matcher. Construct once at start-up; `on_burst`, `on_tick`
/// and `interrupt` are RT-safe (no allocation, no panic).
#[derive(Debug, Clone)]
pub struct SequenceMatcher {
    library: Box<[SequenceEntry]>,
    config: MatcherConfig,
    cs: Sequence,
    /// The CS equals this entry's sequence, but a longer one starts with it.
    pending: Option<Target>,
    last_end: Tick,
}

/// Where the CS stands in the library.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Standing {
    /// The target of the entry equal to the CS, if any (the last one, should
    /// a library hold a sequence twice; a validated one never does).
    exact: Option<Target>,
    /// Some longer entry starts with the CS.
    has_longer: bool,
}

impl SequenceMatcher {
    /// Builds the matcher over a validated library. Not RT-safe (allocates).
    pub fn new(library: &[SequenceEntry], config: &MatcherConfig) -> Self {
        SequenceMatcher {
            library: library.into(),
            config: *config,
            cs: Sequence::EMPTY,
            pending: None,
            last_end: 0,
        }
    }

    /// The CS compared with every entry of the library. RT-safe.
    fn standing(&self) -> Standing {
        let cs = self.cs.as_slice();
        let mut standing = Standing {
            exact: None,
            has_longer: false,
        };
        for entry in self.library.iter() {
            let sequence = entry.actions.as_slice();
            if sequence == cs {
                standing.exact = Some(entry.target);
            } else if sequence.starts_with(cs) {
                standing.has_longer = true;
            }
        }
        standing
    }

    /// The current sequence (what the user has entered so far).
    pub fn current(&self) -> &Sequence {
        &self.cs
    }

    /// When the current sequence is decided if nothing more is breathed
    /// (a breath in progress delays it); `None` with nothing entered.
    /// RT-safe.
    pub fn decides_at(&self) -> Option<Tick> {
        (!self.cs.is_empty()).then(|| {
            self.last_end
                .saturating_add(self.config.sequence_timeout_ms.into())
        })
    }

    /// What that decision selects (the sequence is complete and a
    /// longer one starts with it); `None`: it resets. RT-safe.
    pub fn pending(&self) -> Option<Target> {
        self.pending
    }

    /// Appends a finished burst to the current sequence. RT-safe.
    pub fn on_burst(&mut self, burst: &Burst) -> Option<MatchEvent> {
        self.on_token(Token::Breath(burst.action), burst.end)
    }

    /// Appends a token (a burst's action or a recognised gesture) that
    /// ended at `end` to the current sequence. RT-safe.
    pub fn on_token(&mut self, token: Token, end: Tick) -> Option<MatchEvent> {
        self.last_end = end;
        if self.cs.try_push(token).is_err() {
            // Unreachable with a validated library (a full CS is never a
            // proper prefix); kept total so the control thread cannot panic.
            return self.reset(ResetReason::NoMatch);
        }
        match self.standing() {
            Standing {
                exact: None,
                has_longer: false,
            } => self.reset(ResetReason::NoMatch),
            Standing {
                exact: Some(target),
                has_longer: false,
            } => self.matched(target),
            Standing { exact, .. } => {
                self.pending = exact;
                None
            }
        }
    }

    /// Runs the timeout: call every tick, after `on_burst`. RT-safe.
    pub fn on_tick(&mut self, now: Tick, breath_in_progress: bool) -> Option<MatchEvent> {
        let deadline = self
            .last_end
            .saturating_add(self.config.sequence_timeout_ms.into());
        if self.cs.is_empty() || breath_in_progress || now < deadline {
            return None;
        }
        match self.pending {
            Some(target) => self.matched(target),
            None => self.reset(ResetReason::Timeout),
        }
    }

    /// Drops the current sequence after a sensor fault. RT-safe.
    pub fn interrupt(&mut self) -> Option<MatchEvent> {
        self.void(ResetReason::Fault)
    }

    /// Drops the current sequence, if any, for `reason`. RT-safe.
    pub fn void(&mut self, reason: ResetReason) -> Option<MatchEvent> {
        if self.cs.is_empty() {
            None
        } else {
            self.reset(reason)
        }
    }

    fn matched(&mut self, target: Target) -> Option<MatchEvent> {
        let sequence = self.cs;
        self.clear();
        Some(MatchEvent::Match { sequence, target })
    }

    fn reset(&mut self, reason: ResetReason) -> Option<MatchEvent> {
        let sequence = self.cs;
        self.clear();
        Some(MatchEvent::Reset { sequence, reason })
    }

    fn clear(&mut self) {
        self.cs.clear();
        self.pending = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::action::Action;
    use crate::control::mode::Mode;
    use Action::{LongPuff, LongSip, ShortPuff, ShortSip};

    fn entry(actions: &[Action], mode: Mode) -> SequenceEntry {
        SequenceEntry {
            actions: Sequence::from_slice(actions).unwrap(),
            target: Target::Mode(mode),
        }
    }

    /// The paper's example: S1 = ⟨1, 2, −1⟩, S2 = ⟨1, 2⟩, S3 = ⟨2, 1⟩.
    fn paper() -> SequenceMatcher {
        SequenceMatcher::new(
            &[
                entry(&[ShortSip, LongSip, ShortPuff], Mode::TranslateX),
                entry(&[ShortSip, LongSip], Mode::TranslateY),
                entry(&[LongSip, ShortSip], Mode::TranslateZ),
            ],
            &MatcherConfig {
                sequence_timeout_ms: 1000,
            },
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
            sequence: Sequence::from_slice(actions).unwrap(),
            target: Target::Mode(mode),
        })
    }

    fn reset(actions: &[Action], reason: ResetReason) -> Option<MatchEvent> {
        Some(MatchEvent::Reset {
            sequence: Sequence::from_slice(actions).unwrap(),
            reason,
        })
    }

    /// Every case of the paper's worked example.
    #[test]
    fn paper_example() {
        // ⟨2⟩: no confusion, wait for a 1 to match S3 (16-17-19-22) …
        let mut m = paper();
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
        let mut m = paper();
        m.on_burst(&b(LongSip, 1000));
        assert_eq!(m.on_tick(1999, false), None);
        assert_eq!(
            m.on_tick(2000, false),
            reset(&[LongSip], ResetReason::Timeout)
        );

        // ⟨1, 2⟩: confusion between S1 and S2, wait (16-17-18-22) …
        let mut m = paper();
        assert_eq!(m.on_burst(&b(ShortSip, 1000)), None);
        assert_eq!(m.on_burst(&b(LongSip, 1800)), None);
        // … a −1 matches S1 (16-17-18-21).
        assert_eq!(
            m.on_burst(&b(ShortPuff, 2500)),
            matched(&[ShortSip, LongSip, ShortPuff], Mode::TranslateX)
        );

        // ⟨1, 2⟩ then a peak that is not −1: reset (16-17-19-23).
        let mut m = paper();
        m.on_burst(&b(ShortSip, 1000));
        m.on_burst(&b(LongSip, 1800));
        assert_eq!(
            m.on_burst(&b(ShortSip, 2500)),
            reset(&[ShortSip, LongSip, ShortSip], ResetReason::NoMatch)
        );

        // ⟨1, 2⟩ and no new peak: S2 is matched at the timeout (16-20-21).
        let mut m = paper();
        m.on_burst(&b(ShortSip, 1000));
        m.on_burst(&b(LongSip, 1800));
        assert_eq!(m.on_tick(2799, false), None);
        assert_eq!(
            m.on_tick(2800, false),
            matched(&[ShortSip, LongSip], Mode::TranslateY)
        );
        assert_eq!(m.on_tick(5000, false), None, "matched once");

        // A first action that starts no UDS: reset on this tick.
        let mut m = paper();
        assert_eq!(
            m.on_burst(&b(LongPuff, 1000)),
            reset(&[LongPuff], ResetReason::NoMatch)
        );

        // A breath in progress holds the timeout off.
        let mut m = paper();
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
        let mut m = paper();
        m.on_burst(&b(ShortSip, 1000));
        assert_eq!(m.interrupt(), reset(&[ShortSip], ResetReason::Fault));
        assert_eq!(m.interrupt(), None);
    }

    #[test]
    fn a_full_length_sequence_matches() {
        let long = [ShortPuff; crate::control::action::MAX_SEQUENCE_LEN];
        let mut m = SequenceMatcher::new(
            &[entry(&long, Mode::Fingers)],
            &MatcherConfig {
                sequence_timeout_ms: 1000,
            },
        );
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
