//! The guide of a live gesture recording (`gestures record` without
//! `--from`): fed the IMU's input one tick at a time, it asks the person
//! to hold still, then for each gesture in turn to make it now, five
//! times, then to move as they ordinarily do for a minute; it sees each
//! movement the front end cuts and labels it — the example asked for, a
//! movement out of turn, one too long to be a gesture — and says each
//! step once ([`Say`]).
//!
//! The front end is fitted to the opening rest and run over the session
//! exactly as [`record::record_guided`](super::record::record_guided)
//! runs it afterwards over the recording, so the movements labelled here
//! are the ones the set is made from. A person who answers slowly, or
//! moves out of turn, still gets a set: the labels say which movement was
//! which, not the protocol's timing.
//!
//! Pure: no clock, no I/O; time is the tick. It allocates (it keeps the
//! recording): it runs beside the session, never on the control thread.

use crate::control::Tick;
use crate::control::gesture::GestureConfig;
use crate::control::gesture::segmenter::{SegmentEnd, Segmenter};
use crate::control::imu::{ImuInput, ImuSample};
use crate::gestures::front_end;
use crate::gestures::protocol::{BETWEEN_GESTURES_MS, EXAMPLES, ORDINARY_MS, REST_MS, Span};

/// The opening rest, ms: the protocol's, and the margin the fit leaves
/// out of it.
pub const OPENING_MS: Tick = REST_MS + 500;
/// Rest after an example before the next is asked for, ms: the protocol's
/// least rest between examples.
pub const BETWEEN_EXAMPLES_MS: Tick = 1500;
/// No movement this long after a prompt: it is repeated, ms.
pub const ANSWER_MS: Tick = 8000;
/// Prompts for one example before the session stops.
pub const ASKS: u32 = 3;
/// Attempts at the opening rest before the session stops.
pub const REST_TRIES: u32 = 4;
/// The ordinary movement asked for, ms: the protocol's least, and a
/// second more.
pub const ORDINARY_ASKED_MS: Tick = ORDINARY_MS + 1000;

/// What the guide says, once, on the tick it happens.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Say {
    /// Hold the head still: its rest is measured for [`OPENING_MS`]
    /// (`again`: it moved, the rest starts over).
    HoldStill {
        /// The head moved during the rest.
        again: bool,
    },
    /// Make gesture `gesture` (its index in the names given) now: example
    /// `example` (1 to [`EXAMPLES`]).
    Make {
        /// The gesture's index.
        gesture: usize,
        /// The example, from 1.
        example: usize,
        /// The prompt is repeated: no movement came.
        again: bool,
    },
    /// The example was made, from `span.start` to `span.end`.
    Seen {
        /// The gesture's index.
        gesture: usize,
        /// The example, from 1.
        example: usize,
        /// The movement as the front end cut it.
        span: Span,
    },
    /// A movement before its prompt: not an example; wait for the prompt.
    OutOfTurn,
    /// The movement lasted longer than a gesture may (`max_ms`): it is
    /// asked for again.
    TooLong {
        /// The gesture's index.
        gesture: usize,
        /// The example, from 1.
        example: usize,
    },
    /// Move as you ordinarily do (look around, talk) for `ms`: nothing
    /// may trigger.
    Ordinary {
        /// How long, ms.
        ms: Tick,
    },
    /// The session is over: the set can be made.
    Done,
    /// The session stopped before its end.
    Stopped(Stop),
}

/// Why a session stopped before its end.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stop {
    /// No movement after [`ASKS`] prompts for this example.
    Silence {
        /// The gesture's index.
        gesture: usize,
        /// The example, from 1.
        example: usize,
    },
    /// The head did not hold still for the opening rest in
    /// [`REST_TRIES`] attempts.
    NoRest,
    /// The IMU went away.
    Lost,
}

/// Where the session is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// The opening rest, measured since the recording's first sample
    /// (`settling`: the head moved, and the rest starts over once it is
    /// still).
    Opening { tries: u32, settling: bool },
    /// At rest until `until`, when the next example is asked for.
    Resting { until: Tick },
    /// The example was asked for at `at` (`asks` times so far).
    Asked { at: Tick, asks: u32 },
    /// The example asked for is being made.
    Making,
    /// A movement not asked for (or one too long) is under way: once it
    /// ends, the rest before the next prompt starts over.
    Waiting,
    /// Ordinary movement until `until`.
    Ordinary { until: Tick },
    /// Done or stopped.
    Over,
}

/// The guide of one live session.
#[derive(Debug, Clone)]
pub struct Guided {
    base: GestureConfig,
    /// The front end over the session: `base` during the opening rest,
    /// then fitted to it.
    segmenter: Segmenter,
    /// The recording, from the opening rest's first sample.
    samples: Vec<(Tick, ImuSample)>,
    /// The tick the segmenter has stepped up to (next to step).
    next: Option<Tick>,
    phase: Phase,
    /// The examples seen, per gesture.
    examples: Vec<Vec<Span>>,
    /// The front end as fitted to the opening rest.
    fitted: Option<GestureConfig>,
}

impl Guided {
    /// A guide for `gestures` gestures, the front end starting from
    /// `base`. The first tick it is given says [`Say::HoldStill`].
    pub fn new(gestures: usize, base: GestureConfig) -> Guided {
        Guided {
            base,
            segmenter: Segmenter::new(&base),
            samples: Vec::new(),
            next: None,
            phase: Phase::Opening {
                tries: 0,
                settling: false,
            },
            examples: vec![Vec::new(); gestures],
            fitted: None,
        }
    }

    /// The recording so far (from the last start of the opening rest).
    pub fn samples(&self) -> &[(Tick, ImuSample)] {
        &self.samples
    }

    /// The examples seen, per gesture (each [`EXAMPLES`] long once the
    /// session is done).
    pub fn examples(&self) -> &[Vec<Span>] {
        &self.examples
    }

    /// The front end fitted to the opening rest, once measured.
    pub fn fitted(&self) -> Option<&GestureConfig> {
        self.fitted.as_ref()
    }

    /// Whether the session is over (done or stopped).
    pub fn is_over(&self) -> bool {
        self.phase == Phase::Over
    }

    /// The next example to ask for, `(gesture, example)` from 0, or none.
    fn wanted(&self) -> Option<(usize, usize)> {
        self.examples
            .iter()
            .position(|seen| seen.len() < EXAMPLES)
            .map(|g| (g, self.examples.get(g).map_or(0, Vec::len)))
    }

    /// Tick `now` with the IMU's input on it; what to say, if anything.
    pub fn step(&mut self, now: Tick, input: ImuInput) -> Option<Say> {
        if self.phase == Phase::Over {
            return None;
        }
        let sample = match input {
            ImuInput::Sample(sample) if sample.is_finite() => Some(sample),
            ImuInput::Lost => {
                self.phase = Phase::Over;
                return Some(Say::Stopped(Stop::Lost));
            }
            ImuInput::Sample(_) | ImuInput::Missing => None,
        };
        if let Phase::Opening { tries, settling } = self.phase {
            return self.opening(now, sample, tries, settling);
        }
        if let Some(sample) = sample {
            self.samples.push((now, sample));
        }
        let ended = self.advance(now, sample.as_ref());
        self.after(now, ended)
    }

    /// Steps the segmenter to `now` (the ticks between held, as the
    /// offline cut holds them).
    fn advance(&mut self, now: Tick, sample: Option<&ImuSample>) -> Option<SegmentEnd> {
        let mut ended = None;
        let mut t = self.next.unwrap_or(now);
        while t < now {
            ended = self.segmenter.step(t, None).or(ended);
            t += 1;
        }
        self.next = Some(now + 1);
        self.segmenter.step(now, sample).or(ended)
    }

    /// The opening rest: a movement starts it over once the head is
    /// still again; once it has lasted [`OPENING_MS`], the front end is
    /// fitted to it and re-run over it.
    fn opening(
        &mut self,
        now: Tick,
        sample: Option<ImuSample>,
        tries: u32,
        settling: bool,
    ) -> Option<Say> {
        let sample = sample?;
        let first = self.samples.first().map(|(t, _)| *t);
        self.samples.push((now, sample));
        let _ = self.advance(now, Some(&sample));
        let moving = self.segmenter.in_motion();
        if settling {
            if !moving {
                self.samples.clear();
                self.segmenter = Segmenter::new(&self.base);
                self.next = None;
                self.phase = Phase::Opening {
                    tries,
                    settling: false,
                };
            }
            return None;
        }
        let Some(first) = first else {
            return (tries == 0).then_some(Say::HoldStill { again: false });
        };
        if moving {
            if tries + 1 >= REST_TRIES {
                self.phase = Phase::Over;
                return Some(Say::Stopped(Stop::NoRest));
            }
            self.phase = Phase::Opening {
                tries: tries + 1,
                settling: true,
            };
            return Some(Say::HoldStill { again: true });
        }
        if now < first + OPENING_MS {
            return None;
        }
        let config = front_end::rest(&self.base, &self.samples)
            .map_or(self.base, |rest| front_end::fit(&self.base, &rest));
        self.fitted = Some(config);
        self.segmenter = Segmenter::new(&config);
        self.next = None;
        let recorded = std::mem::take(&mut self.samples);
        for &(tick, s) in &recorded {
            let _ = self.advance(tick, Some(&s));
        }
        self.samples = recorded;
        self.phase = Phase::Resting { until: now };
        self.after(now, None)
    }

    /// The session's step once the front end is fitted, given the
    /// movement that ended on this tick, if any.
    fn after(&mut self, now: Tick, ended: Option<SegmentEnd>) -> Option<Say> {
        let moving = self.segmenter.in_motion();
        match self.phase {
            Phase::Opening { .. } | Phase::Over => None,
            Phase::Resting { until } => {
                if moving {
                    self.phase = Phase::Waiting;
                    return Some(Say::OutOfTurn);
                }
                if now < until {
                    return None;
                }
                match self.wanted() {
                    Some((gesture, example)) => {
                        self.phase = Phase::Asked { at: now, asks: 1 };
                        Some(Say::Make {
                            gesture,
                            example: example + 1,
                            again: false,
                        })
                    }
                    None => {
                        self.phase = Phase::Ordinary {
                            until: now + ORDINARY_ASKED_MS,
                        };
                        Some(Say::Ordinary {
                            ms: ORDINARY_ASKED_MS,
                        })
                    }
                }
            }
            Phase::Asked { at, asks } => {
                let (gesture, example) = self.wanted()?;
                if moving {
                    self.phase = Phase::Making;
                    return None;
                }
                if now < at + ANSWER_MS {
                    return None;
                }
                if asks >= ASKS {
                    self.phase = Phase::Over;
                    return Some(Say::Stopped(Stop::Silence {
                        gesture,
                        example: example + 1,
                    }));
                }
                self.phase = Phase::Asked {
                    at: now,
                    asks: asks + 1,
                };
                Some(Say::Make {
                    gesture,
                    example: example + 1,
                    again: true,
                })
            }
            Phase::Making => {
                let (gesture, example) = self.wanted()?;
                let Some(end) = ended else {
                    if !moving {
                        // Shorter than a gesture may be (`min_ms`): not
                        // one; the prompt still stands.
                        self.phase = Phase::Asked { at: now, asks: 1 };
                    }
                    return None;
                };
                if end.too_long {
                    self.phase = Phase::Waiting;
                    return Some(Say::TooLong {
                        gesture,
                        example: example + 1,
                    });
                }
                let span = Span {
                    start: end.start,
                    end: end.end,
                };
                if let Some(seen) = self.examples.get_mut(gesture) {
                    seen.push(span);
                }
                self.phase = Phase::Resting {
                    until: now + self.rest_before_next(),
                };
                Some(Say::Seen {
                    gesture,
                    example: example + 1,
                    span,
                })
            }
            Phase::Waiting => {
                if moving {
                    return None;
                }
                self.phase = Phase::Resting {
                    until: now + self.rest_before_next(),
                };
                None
            }
            Phase::Ordinary { until } => {
                if now < until {
                    return None;
                }
                self.phase = Phase::Over;
                Some(Say::Done)
            }
        }
    }

    /// Rest before the next prompt: between examples, or, before a new
    /// gesture's first, between gestures.
    fn rest_before_next(&self) -> Tick {
        match self.wanted() {
            Some((_, 0)) => BETWEEN_GESTURES_MS,
            _ => BETWEEN_EXAMPLES_MS,
        }
    }
}

/// What `say` tells the person at the terminal, for gestures named
/// `names` (in the guide's order); `max_ms` is the front end's longest
/// gesture.
pub fn words(say: &Say, names: &[String], max_ms: u32) -> String {
    let name = |g: usize| names.get(g).map_or("?", String::as_str);
    let s = |ms: Tick| format!("{:.1} s", ms as f64 / 1000.0);
    match *say {
        Say::HoldStill { again: false } => {
            format!("hold your head still, as you rest, for {}", s(OPENING_MS))
        }
        Say::HoldStill { again: true } => format!(
            "the head moved: hold it still again, for {}, once it is at rest",
            s(OPENING_MS)
        ),
        Say::Make {
            gesture,
            example,
            again,
        } => format!(
            "{} — now ({example} of {EXAMPLES}){}",
            name(gesture),
            if again { "; no movement seen yet" } else { "" }
        ),
        Say::Seen { span, .. } => format!("  seen ({})", s(span.end - span.start)),
        Say::OutOfTurn => {
            "  a movement before the prompt: not counted; rest, and wait for it".into()
        }
        Say::TooLong { gesture, .. } => format!(
            "  longer than a gesture may last ({}): rest, then make {} again, quicker",
            s(Tick::from(max_ms)),
            name(gesture)
        ),
        Say::Ordinary { ms } => format!(
            "now move as you ordinarily do for {} (look around, talk), making none of the gestures",
            s(ms)
        ),
        Say::Done => "done: the recording is over".into(),
        Say::Stopped(Stop::Silence { gesture, example }) => format!(
            "no movement after {ASKS} prompts for {} ({example} of {EXAMPLES}): the session stops",
            name(gesture)
        ),
        Say::Stopped(Stop::NoRest) => format!(
            "the head did not hold still for {} in {REST_TRIES} tries: the session stops (record with the head supported, the wheelchair still)",
            s(OPENING_MS)
        ),
        Say::Stopped(Stop::Lost) => "the IMU went away: the session stops".into(),
    }
}

/// What the page shows for `say`: a large headline and a line of news,
/// with how the news is drawn (`info`, `again`: asked again or not
/// counted, `fault`: the session stopped). Words as [`words`]'s.
pub fn page_words(say: &Say, names: &[String], max_ms: u32) -> (String, String, &'static str) {
    let name = |g: usize| names.get(g).map_or("?", String::as_str).replace('_', " ");
    match *say {
        Say::HoldStill { again } => (
            "hold your head still".into(),
            if again {
                "the head moved: the rest starts again".into()
            } else {
                String::new()
            },
            if again { "again" } else { "info" },
        ),
        Say::Make { gesture, again, .. } => (
            format!("{} — now", name(gesture)),
            if again {
                "no movement seen yet".into()
            } else {
                String::new()
            },
            if again { "again" } else { "info" },
        ),
        Say::Seen { span, .. } => (
            "rest".into(),
            format!("seen ({:.1} s)", (span.end - span.start) as f64 / 1000.0),
            "info",
        ),
        Say::OutOfTurn => (
            "rest — wait for the prompt".into(),
            "a movement before the prompt: not counted".into(),
            "again",
        ),
        Say::TooLong { gesture, .. } => (
            "rest".into(),
            format!(
                "longer than a gesture may last ({:.1} s): {} again, quicker",
                f64::from(max_ms) / 1000.0,
                name(gesture)
            ),
            "again",
        ),
        Say::Ordinary { .. } => (
            "move as you ordinarily do".into(),
            "look around, talk — make none of the gestures".into(),
            "info",
        ),
        Say::Done => ("done".into(), "the recording is over".into(), "info"),
        Say::Stopped(_) => ("stopped".into(), words(say, names, max_ms), "fault"),
    }
}
