//! The guide of a live calibration session (`sipnpuff fit` without
//! `--from`): fed the sensor's sample one tick at a time, it owns the
//! protocol's progress — the rest at the start, each prompt, the count,
//! the breath of the wrong kind, the breath before its prompt, the prompt
//! repeated after silence and the stop after more silence, the rests
//! between breaths and between blocks, the end — and says each step once
//! ([`Say`]), for the terminal and the page to show ([`View`]).
//!
//! Pure: no clock, no I/O; time is the tick. It runs on the telemetry
//! side of a run, never on the control thread; it allocates when the rest
//! is measured, once.
//!
//! How breaths are seen before any setting is fitted: the rest at the
//! start gives the level and its noise exactly as the offline fit finds
//! them ([`breaths::find`]); a [`BurstDetector`] with its thresholds at
//! the edge of that noise ([`live_detector`]) then reports each breath,
//! sip or puff, however short or long. Short and long are the fit's to
//! tell apart afterwards: here a breath of the right kind counts.

use crate::control::Tick;
use crate::control::action::Breath;
use crate::control::detector::{BurstDetector, DetectorConfig, DetectorEvent};
use crate::control::sample::Sample;
use crate::fit::breaths::{self, Found, MIN_BREATH_MS};
use crate::fit::protocol::{
    ANSWER_MS, Ask, BETWEEN_BLOCKS_MS, BETWEEN_BREATHS_MS, Block, Protocol, REST_MS,
};
use crate::fit::signal::Signal;

/// Attempts at the rest at the start (each [`REST_MS`]) before the
/// session stops: the signal never settled.
pub const REST_TRIES: u32 = 4;
/// The live detector's longest breath, ms: the holds are long, and a
/// stuck sensor is the fit's to find, not the guide's.
pub const LIVE_MAX_HOLD_MS: u32 = 60_000;
/// A pause before a prompt that never becomes the rest it needs within
/// this long stops the session, ms (the user keeps breathing, or the
/// signal is never valid).
pub const PAUSE_LIMIT_MS: u32 = 2 * ANSWER_MS;

/// Why a session stopped before its end.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Stop {
    /// No breath within [`ANSWER_MS`] of a prompt, and none within as
    /// long of it repeated.
    Silence {
        /// What was asked.
        ask: Ask,
    },
    /// The sensor's device went away.
    Lost {
        /// The tick it went.
        tick: Tick,
    },
    /// The signal did not stay at rest when it had to: at the start
    /// ([`REST_TRIES`] times [`REST_MS`]) or before a prompt
    /// ([`PAUSE_LIMIT_MS`]).
    NoRest,
}

impl Stop {
    /// What happened and what to check, in plain words.
    pub fn words(self) -> String {
        match self {
            Stop::Silence { ask } => format!(
                "no breath came within {} s of the prompt \"{}\", twice: the session stops. Check that the tube is on the mouthpiece and the sensor, not kinked, blocked or leaking, and that the sensor is plugged in; then start again",
                ANSWER_MS / 1000,
                ask.words()
            ),
            Stop::Lost { tick } => format!(
                "the sensor was lost {:.1} s into the session: the session stops. Check the sensor's cable and connection; then start again",
                tick as f64 / 1000.0
            ),
            Stop::NoRest => format!(
                "the signal did not stay at rest (no sip or puff) for the {} s the session needs: the session stops. Check that the mouthpiece is free, that the tube does not leak, and that the sensor's reading is steady; then start again",
                REST_MS / 1000
            ),
        }
    }
}

/// A prompt: what it asks for and where the session is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Prompt {
    /// What is asked for.
    pub ask: Ask,
    /// Which breath of its block, from 1.
    pub n: u32,
    /// Breaths in the block.
    pub of: u32,
    /// Which block, from 0.
    pub block: usize,
    /// Blocks in the session.
    pub blocks: usize,
}

impl Prompt {
    /// The prompt's words: "short puff — now".
    pub fn words(&self) -> String {
        format!("{} — now", self.ask.words())
    }

    /// "3 of 8".
    pub fn count_words(&self) -> String {
        format!("{} of {}", self.n, self.of)
    }

    /// "block 2 of 4: 8 long puffs".
    pub fn block_words(&self) -> String {
        format!(
            "block {} of {}: {} {}s",
            self.block + 1,
            self.blocks,
            self.of,
            self.ask.words()
        )
    }
}

/// One thing the guide says, on the tick it happens. At most one a tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Say {
    /// Rest, please: the rest is measured (`again`: after a breath or an
    /// unsteady signal spoilt the last try).
    Rest {
        /// A try after the first.
        again: bool,
    },
    /// Breathe now.
    Prompt(Prompt),
    /// No breath within [`ANSWER_MS`]: the same prompt again.
    Repeat(Prompt),
    /// A breath of the other kind: not counted; the prompt comes again
    /// after the rest between breaths.
    WrongKind {
        /// The prompt answered.
        prompt: Prompt,
        /// What came.
        got: Breath,
    },
    /// A breath before its prompt: not counted.
    Early {
        /// What came.
        breath: Breath,
    },
    /// The breath asked for: counted.
    Counted {
        /// The prompt answered.
        prompt: Prompt,
        /// How long the guide saw it, ms (at the edge of the noise: the
        /// fit measures it at the proposed thresholds).
        ms: u64,
    },
    /// Every block is done, with the rest after the last breath.
    Finished,
    /// The session stopped before its end.
    Stopped(Stop),
}

impl Say {
    /// The terminal's line(s).
    pub fn line(&self) -> String {
        match self {
            Say::Prompt(p) if p.n == 1 => format!(
                "{}, one at each prompt\n{} ({})",
                p.block_words(),
                p.words(),
                p.count_words()
            ),
            Say::Prompt(p) => format!("{} ({})", p.words(), p.count_words()),
            Say::Repeat(p) => format!("{} — {} ({})", self.message(), p.words(), p.count_words()),
            Say::Counted { prompt, ms } => format!(
                "  counted: {} {} ({:.2} s at the rest's edge)",
                prompt.ask.words(),
                prompt.count_words(),
                *ms as f64 / 1000.0
            ),
            _ => self.message(),
        }
    }

    /// The page's message line for what was said (empty for a prompt:
    /// the prompt itself is shown large).
    pub fn message(&self) -> String {
        match self {
            Say::Rest { again: false } => format!(
                "rest, please: no sip or puff for {} s while the sensor at rest is measured",
                REST_MS / 1000
            ),
            Say::Rest { again: true } => format!(
                "that was not rest — rest again for {} s, please",
                REST_MS / 1000
            ),
            Say::Prompt(_) => String::new(),
            Say::Repeat(_) => format!("no breath in {} s — once more", ANSWER_MS / 1000),
            Say::WrongKind { prompt, got } => format!(
                "that was a {} — again, a {} please",
                got.word(),
                prompt.ask.breath().word()
            ),
            Say::Early { breath } => format!(
                "wait for the prompt — that {} was not counted",
                breath.word()
            ),
            Say::Counted { .. } => "got it".into(),
            Say::Finished => "done — thank you; fitting your settings".into(),
            Say::Stopped(stop) => stop.words(),
        }
    }
}

/// Where the session is, for the view.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// The rest at the start is measured.
    Rest,
    /// Resting before the next prompt (or the end).
    Pause,
    /// A prompt waits for its breath.
    Prompted,
    /// Every block is done.
    Finished,
    /// Stopped before the end.
    Stopped,
}

/// The rest's level and the band around it a breath must leave, volts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Band {
    /// The level at rest.
    pub level: f64,
    /// Distance from the level beyond which the signal is a breath.
    pub outside: f64,
}

/// What the page and the terminal show now.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    /// Where the session is.
    pub phase: Phase,
    /// The prompt shown (prompted), or the next one (pausing).
    pub prompt: Option<Prompt>,
    /// The last thing said other than a prompt (wrong kind, too early,
    /// repeated, counted, the rest, the end).
    pub message: Option<Say>,
    /// The rest, once measured.
    pub band: Option<Band>,
    /// The breath held now, as the guide sees it.
    pub held: Option<Breath>,
    /// Breaths counted so far.
    pub counted: u32,
    /// Breaths the session asks for.
    pub total: u32,
}

impl View {
    /// The large words: "rest, please", "short puff — now", "wait…",
    /// "done", "stopped".
    pub fn headline(&self) -> String {
        match (self.phase, self.prompt) {
            (Phase::Rest, _) => "rest, please".into(),
            (Phase::Prompted, Some(p)) => p.words(),
            (Phase::Pause, _) | (Phase::Prompted, None) => "rest — wait for the prompt".into(),
            (Phase::Finished, _) => "done — thank you".into(),
            (Phase::Stopped, _) => "stopped".into(),
        }
    }
}

/// What follows a pause.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Next {
    Prompt,
    Finish,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum State {
    /// Before the first tick.
    Start,
    /// Measuring the rest from `since`: try `tries`.
    Rest {
        since: Tick,
        tries: u32,
    },
    /// Waiting for `need` ms of rest since the last breath, from `since`.
    Pause {
        need: u32,
        next: Next,
        since: Tick,
    },
    /// Prompted at `at` (again after silence: `repeated`).
    Prompted {
        at: Tick,
        repeated: bool,
    },
    Finished,
    Stopped(Stop),
}

/// The guide of one session. Not RT-safe (the telemetry side).
#[derive(Debug, Clone)]
pub struct Prompter {
    blocks: Vec<Block>,
    total: u32,
    state: State,
    /// The block asked now, and the breaths counted in it.
    block: usize,
    counted_in_block: u32,
    counted: u32,
    /// The samples of the rest being measured.
    rest: Vec<Sample>,
    detector: Option<BurstDetector>,
    band: Option<Band>,
    /// First tick of the current run of ticks at rest (no breath held or
    /// starting, no fault).
    quiet_since: Option<Tick>,
    held: Option<Breath>,
    message: Option<Say>,
}

/// No narrower band than this counts breaths live, volts: a level that
/// wanders while a long breath holds the neutral still comes back this
/// far from it, and the weakest breath a sensor reads stands well clear.
const LIVE_MIN_BAND_VOLTS: f64 = 0.1;

/// The live detector for a session whose rest was `found`: thresholds at
/// the edge of the rest's noise ([`Found::outside`], as the offline fit
/// finds breaths, and at least [`LIVE_MIN_BAND_VOLTS`]), the off level
/// halfway back, breaths from [`MIN_BREATH_MS`] to [`LIVE_MAX_HOLD_MS`].
pub fn live_detector(found: &Found) -> DetectorConfig {
    let level = found.rest.level;
    let on = found.outside.max(LIVE_MIN_BAND_VOLTS);
    DetectorConfig {
        neutral_volts: level,
        puff_threshold_volts: level + on,
        sip_threshold_volts: level - on,
        hysteresis_volts: on / 2.0,
        min_burst_ms: MIN_BREATH_MS as u32,
        max_hold_ms: LIVE_MAX_HOLD_MS,
        ..DetectorConfig::default()
    }
}

impl Prompter {
    /// The guide of a session following `protocol`.
    pub fn new(protocol: &Protocol) -> Prompter {
        let blocks: Vec<Block> = protocol
            .blocks
            .iter()
            .copied()
            .filter(|b| b.count > 0)
            .collect();
        Prompter {
            total: blocks.iter().map(|b| b.count).sum(),
            blocks,
            state: State::Start,
            block: 0,
            counted_in_block: 0,
            counted: 0,
            rest: Vec::with_capacity(REST_MS as usize),
            detector: None,
            band: None,
            quiet_since: None,
            held: None,
            message: None,
        }
    }

    /// Whether the session is over: finished or stopped.
    pub fn is_over(&self) -> bool {
        matches!(self.state, State::Finished | State::Stopped(_))
    }

    /// Whether every block was breathed.
    pub fn is_finished(&self) -> bool {
        self.state == State::Finished
    }

    /// Why the session stopped, if it did.
    pub fn stopped(&self) -> Option<Stop> {
        match self.state {
            State::Stopped(stop) => Some(stop),
            _ => None,
        }
    }

    /// The rest, once measured.
    pub fn band(&self) -> Option<Band> {
        self.band
    }

    /// What to show now.
    pub fn view(&self) -> View {
        let (phase, prompt) = match self.state {
            State::Start | State::Rest { .. } => (Phase::Rest, None),
            State::Pause {
                next: Next::Prompt, ..
            } => (Phase::Pause, Some(self.prompt())),
            State::Pause { .. } => (Phase::Pause, None),
            State::Prompted { .. } => (Phase::Prompted, Some(self.prompt())),
            State::Finished => (Phase::Finished, None),
            State::Stopped(_) => (Phase::Stopped, None),
        };
        View {
            phase,
            prompt,
            message: self.message,
            band: self.band,
            held: self.held,
            counted: self.counted,
            total: self.total,
        }
    }

    /// The prompt of the breath asked for now.
    fn prompt(&self) -> Prompt {
        let block = self.blocks.get(self.block).copied().unwrap_or(Block {
            ask: Ask::Hold(Breath::Puff),
            count: 0,
        });
        Prompt {
            ask: block.ask,
            n: self.counted_in_block + 1,
            of: block.count,
            block: self.block,
            blocks: self.blocks.len(),
        }
    }

    /// Takes tick `tick`'s sample; returns what to say now, if anything.
    /// Ticks must increase (a gap is filled as missing samples).
    pub fn step(&mut self, tick: Tick, sample: Sample) -> Option<Say> {
        let say = self.advance(tick, sample);
        match say {
            // The rest is over: its words with it. Other news stays up
            // with the prompt ("that was a sip — again, a puff please").
            Some(Say::Prompt(_)) => {
                if let Some(Say::Rest { .. }) = self.message {
                    self.message = None;
                }
            }
            Some(say) => self.message = Some(say),
            None => {}
        }
        say
    }

    fn advance(&mut self, tick: Tick, sample: Sample) -> Option<Say> {
        if self.is_over() {
            return None;
        }
        if sample == Sample::Lost {
            return Some(self.stop(Stop::Lost { tick }));
        }
        match self.state {
            State::Start => {
                self.start_rest(tick, 1);
                self.rest_sample(tick, tick, sample);
                Some(Say::Rest { again: false })
            }
            State::Rest { since, tries } => self.resting(tick, sample, since, tries),
            State::Pause { need, next, since } => {
                let burst = self.detect(tick, sample);
                if let Some(breath) = burst.map(|(breath, _, _)| breath) {
                    return Some(Say::Early { breath });
                }
                if self.quiet_ms(tick) >= u64::from(need) {
                    return Some(match next {
                        Next::Prompt => {
                            self.state = State::Prompted {
                                at: tick,
                                repeated: false,
                            };
                            Say::Prompt(self.prompt())
                        }
                        Next::Finish => {
                            self.state = State::Finished;
                            Say::Finished
                        }
                    });
                }
                if tick.saturating_sub(since) >= u64::from(PAUSE_LIMIT_MS) {
                    return Some(self.stop(Stop::NoRest));
                }
                None
            }
            State::Prompted { at, repeated } => {
                let burst = self.detect(tick, sample);
                if let Some((breath, start, ms)) = burst {
                    return Some(self.answer(tick, at, breath, start, ms));
                }
                let breathing = self.held.is_some();
                if breathing || tick.saturating_sub(at) < u64::from(ANSWER_MS) {
                    return None;
                }
                if repeated {
                    let ask = self.prompt().ask;
                    return Some(self.stop(Stop::Silence { ask }));
                }
                self.state = State::Prompted {
                    at: tick,
                    repeated: true,
                };
                Some(Say::Repeat(self.prompt()))
            }
            State::Finished | State::Stopped(_) => None,
        }
    }

    fn stop(&mut self, stop: Stop) -> Say {
        self.state = State::Stopped(stop);
        self.held = None;
        Say::Stopped(stop)
    }

    fn start_rest(&mut self, since: Tick, tries: u32) {
        self.state = State::Rest { since, tries };
        self.rest.clear();
    }

    /// Keeps a sample of the rest at its place (a gap as missing).
    fn rest_sample(&mut self, since: Tick, tick: Tick, sample: Sample) {
        let at = usize::try_from(tick.saturating_sub(since)).unwrap_or(usize::MAX);
        let at = at.min(REST_MS as usize);
        if self.rest.len() < at {
            self.rest.resize(at, Sample::Missing);
        }
        if self.rest.len() < REST_MS as usize {
            self.rest.push(sample);
        }
    }

    /// The rest at the start: once [`REST_MS`] long, measured as the
    /// offline fit measures it; a rest with a breath in it, or too
    /// unsteady to measure, is tried again.
    fn resting(&mut self, tick: Tick, sample: Sample, since: Tick, tries: u32) -> Option<Say> {
        self.rest_sample(since, tick, sample);
        if self.rest.len() < REST_MS as usize {
            return None;
        }
        let signal = Signal {
            samples: std::mem::take(&mut self.rest),
        };
        let found = breaths::find(&signal);
        // The buffer is kept for another try.
        self.rest = signal.samples;
        match found {
            Ok(found) if found.regions.is_empty() => {
                self.band = Some(Band {
                    level: found.rest.level,
                    outside: found.outside,
                });
                self.detector = Some(BurstDetector::new(&live_detector(&found)));
                self.quiet_since = None;
                self.state = State::Prompted {
                    at: tick,
                    repeated: false,
                };
                Some(Say::Prompt(self.prompt()))
            }
            _ if tries >= REST_TRIES => Some(self.stop(Stop::NoRest)),
            _ => {
                self.start_rest(tick + 1, tries + 1);
                Some(Say::Rest { again: true })
            }
        }
    }

    /// Steps the live detector: the breath held, the rest since when, and
    /// a breath that ended (sip or puff, its first tick, its length).
    fn detect(&mut self, tick: Tick, sample: Sample) -> Option<(Breath, Tick, u64)> {
        let detector = self.detector.as_mut()?;
        let out = detector.step(tick, sample);
        self.held = if out.faulted {
            None
        } else {
            detector.held().map(|(breath, _)| breath)
        };
        // A crossing that never lasts (a spike) does not end the rest.
        if out.held.breath.is_some() || out.faulted {
            self.quiet_since = None;
        } else if self.quiet_since.is_none() {
            self.quiet_since = Some(tick);
        }
        match out.event {
            Some(DetectorEvent::Burst(b)) => Some((b.action.breath(), b.start, b.duration_ms())),
            _ => None,
        }
    }

    /// Ticks at rest before this one.
    fn quiet_ms(&self, tick: Tick) -> u64 {
        self.quiet_since.map_or(0, |since| tick - since)
    }

    /// A breath that ended while prompted at `at`.
    fn answer(&mut self, tick: Tick, at: Tick, breath: Breath, start: Tick, ms: u64) -> Say {
        let prompt = self.prompt();
        let pause = |need, next| State::Pause {
            need,
            next,
            since: tick,
        };
        if start < at {
            self.state = pause(BETWEEN_BREATHS_MS, Next::Prompt);
            return Say::Early { breath };
        }
        if breath != prompt.ask.breath() {
            self.state = pause(BETWEEN_BREATHS_MS, Next::Prompt);
            return Say::WrongKind {
                prompt,
                got: breath,
            };
        }
        self.counted += 1;
        self.counted_in_block += 1;
        self.state = if self.counted_in_block < prompt.of {
            pause(BETWEEN_BREATHS_MS, Next::Prompt)
        } else {
            self.block += 1;
            self.counted_in_block = 0;
            if self.block < self.blocks.len() {
                pause(BETWEEN_BLOCKS_MS, Next::Prompt)
            } else {
                pause(BETWEEN_BREATHS_MS, Next::Finish)
            }
        };
        Say::Counted { prompt, ms }
    }
}
