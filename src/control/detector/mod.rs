//! Burst detector (the paper's Fig. 2, blocks 8–10): one voltage sample per
//! tick in, bursts out.
//!
//! * A puff raises the voltage above the neutral, a sip lowers it. A breath
//!   starts when the signal passes its threshold and ends when it comes back
//!   past it by the hysteresis.
//! * Every change of state must last more than `glitch_ms` samples, so a
//!   spike or dropout of a few samples neither creates a burst nor splits one.
//!   Start and end are dated to the first sample of the confirming run, so
//!   durations are exact; the burst is emitted on the tick its end is
//!   confirmed (`glitch_ms` ticks after the signal crossed back).
//! * The neutral is tracked (exponential average, time constant
//!   `neutral_tracking_ms`) only while the signal is at rest, and the
//!   thresholds move with it by their configured offsets.
//! * A NaN, infinite or out-of-range sample is a sensor fault: any breath in
//!   progress is dropped (never turned into a burst) and detection resumes
//!   only after `fault_recovery_ms` of valid samples at rest.
//! * A tick more than `stale_ms` after the previous one is a stall of the
//!   process or machine: a fault, so nothing held across the gap counts.
//! * A breath longer than `max_hold_ms` is a stuck sensor (stuck at a
//!   level, grounded, saturated, or its offset shifted): a fault like the
//!   others. Besides the usual recovery at rest, the level it is stuck at
//!   becomes the new neutral once it has been steady for `rezero_ms` (see
//!   [`REZERO_WINDOW_MS`]) and leaves room for both thresholds in 0–5 V.

mod burst;
mod config;
mod fault;
mod rezero;
#[cfg(test)]
mod tests;

pub use burst::Burst;
pub use config::DetectorConfig;
pub use fault::FaultReason;
pub use rezero::{REZERO_STEADY_VOLTS, REZERO_TRIM, REZERO_WINDOW_MS};

use crate::control::Tick;
use crate::control::action::{Action, Breath};
use crate::control::mode::Held;
use crate::control::sample::Sample;
use crate::control::skip_count::SkipCount;
use config::Levels;
use rezero::Steadiness;

/// Something the detector reports on one tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DetectorEvent {
    /// A burst ended and was long enough to count.
    Burst(Burst),
    /// The sensor signal became invalid.
    Fault(FaultReason),
    /// The signal has been valid and at rest for `fault_recovery_ms`.
    Recovered,
    /// After a stuck fault, the stuck level was steady for `rezero_ms`: it
    /// is the new neutral (the thresholds moved with it) and detection
    /// resumes.
    Rezeroed {
        /// The new neutral, volts.
        neutral_volts: f64,
        /// The neutral before, volts.
        previous_volts: f64,
    },
}

/// The detector's output for one tick. `Copy`, RT-safe.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DetectorOutput {
    /// The breath held right now (confirmed, so glitches never show here).
    pub held: Held,
    /// A breath is held or may be starting (a crossing not yet confirmed):
    /// the matcher's timeout must not run out meanwhile.
    pub in_progress: bool,
    /// The sensor is in fault: nothing is detected.
    pub faulted: bool,
    /// At most one event per tick.
    pub event: Option<DetectorEvent>,
}

/// Which side of the thresholds a sample is on, given the current state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Zone {
    Rest,
    Breath(Breath),
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum State {
    Rest,
    Held {
        breath: Breath,
        start: Tick,
    },
    /// Sensor fault; `rest_since` is the first tick of the current run of
    /// valid samples at rest (glitches allowed), `away_since` the first of
    /// the current run of samples away from rest; `rezero` after a stuck
    /// fault (the stuck level may become the neutral).
    Faulted {
        rest_since: Option<Tick>,
        away_since: Option<Tick>,
        rezero: bool,
    },
}

/// How far behind the signal the neutral tracker reads. Longer than the
/// part of a breath's rise that stays below the threshold, so a sample is
/// used only once it is known not to be the start of a breath; after a
/// breath, tracking resumes this long after its end, past the fall.
pub const TRACKING_DELAY_MS: usize = 100;

/// The burst detector. Construct once; [`BurstDetector::step`] is RT-safe
/// (no allocation, no panic, O(1)).
#[derive(Debug, Clone)]
pub struct BurstDetector {
    config: DetectorConfig,
    /// Worked out once from `config`.
    levels: Levels,

    /// Tick of the last sample received.
    last_sample: Option<Tick>,
    /// The last tick stepped (sample or not): ticks must increase.
    last_tick: Option<Tick>,
    neutral: f64,
    /// The last [`TRACKING_DELAY_MS`] resting samples, indexed by tick.
    recent: [f64; TRACKING_DELAY_MS],
    /// Ticks at rest since the last confirmed breath (or fault) ended.
    quiet_ticks: u64,
    state: State,
    /// A zone differing from the state's, and the tick its run began.
    candidate: Option<(Zone, Tick)>,
    strength: f64,
    /// After a stuck fault: is the stuck level steady?
    steady: Steadiness,
    /// Every sample takes the whole step: the reference path the rest
    /// step is proven against.
    reference_path: bool,
    /// Samples that took [`BurstDetector::rest_step`].
    rest_steps: SkipCount,
}

impl BurstDetector {
    /// Builds a detector from validated settings. Not RT-safe (call at
    /// start-up), though it does not allocate either.
    pub fn new(config: &DetectorConfig) -> Self {
        BurstDetector {
            config: *config,
            levels: Levels::of(config),
            last_sample: None,
            last_tick: None,
            neutral: config.neutral_volts,
            recent: [config.neutral_volts; TRACKING_DELAY_MS],
            quiet_ticks: 0,
            state: State::Rest,
            candidate: None,
            strength: 0.0,
            steady: Steadiness::new(),
            reference_path: false,
            rest_steps: SkipCount::default(),
        }
    }

    /// Every sample takes the whole step, never the rest step.
    #[cfg(any(test, feature = "testing"))]
    pub fn use_reference_path(&mut self) {
        self.reference_path = true;
    }

    /// Samples that took the rest step.
    #[cfg(any(test, feature = "testing"))]
    pub fn rest_steps(&self) -> u64 {
        self.rest_steps.get()
    }

    /// A gap between ticks longer than this (ms) is a stall: the runtime
    /// throws away what its sensor queued meanwhile.
    pub fn stale_ms(&self) -> u64 {
        self.config.stale_ms.into()
    }

    /// The neutral voltage as currently tracked.
    pub fn neutral_volts(&self) -> f64 {
        self.neutral
    }

    /// The breath held (confirmed) and the tick it began. RT-safe.
    pub fn held(&self) -> Option<(Breath, Tick)> {
        match self.state {
            State::Held { breath, start } => Some((breath, start)),
            _ => None,
        }
    }

    /// The sensor is in fault. RT-safe.
    pub fn is_faulted(&self) -> bool {
        matches!(self.state, State::Faulted { .. })
    }

    /// Takes tick `now`'s input. Ticks must increase: a tick that does not
    /// is a fault ([`FaultReason::TickNotIncreasing`]), never an overflow.
    /// A missing sample changes nothing until `stale_ms` have passed since
    /// the last one (or since start); a device gone is a fault at once.
    /// RT-safe.
    pub fn step(&mut self, now: Tick, sample: Sample) -> DetectorOutput {
        match sample {
            Sample::Volts(volts) if self.rest_step(now, volts) => DetectorOutput::default(),
            Sample::Volts(volts) => self.whole_step(now, volts),
            Sample::Missing => self.missing_step(now),
            Sample::Lost => self.lost_step(now),
        }
    }

    /// A tick with no sample: a fault once `stale_ms` have passed without
    /// one (the count then restarts, so recovery needs fresh samples).
    fn missing_step(&mut self, now: Tick) -> DetectorOutput {
        if let Err(reason) = self.advance_to(now) {
            let event = self.fault(reason);
            return self.output(event);
        }
        let since = self
            .last_sample
            .map_or(now.saturating_add(1), |t| now.saturating_sub(t));
        let event = if since >= u64::from(self.config.stale_ms) {
            self.fault(FaultReason::Stale { ms: since })
        } else {
            None
        };
        self.output(event)
    }

    /// A tick with the device gone: a fault at once (a device that is gone
    /// sends no sample to wait `stale_ms` for).
    fn lost_step(&mut self, now: Tick) -> DetectorOutput {
        let event = match self.advance_to(now) {
            Err(reason) => self.fault(reason),
            Ok(()) => self.fault(FaultReason::Disconnected),
        };
        self.output(event)
    }

    /// A sample through every stage: the time check, the range check,
    /// then recovery, or detection and the hold check.
    fn whole_step(&mut self, now: Tick, volts: f64) -> DetectorOutput {
        if let Err(reason) = self.advance_to(now) {
            let event = self.fault(reason);
            return self.output(event);
        }
        self.last_sample = Some(now);
        let event = match self.levels.check(volts) {
            Err(reason) => self.fault(reason),
            Ok(()) => match self.state {
                State::Faulted {
                    rest_since,
                    away_since,
                    rezero,
                } => self.recover(now, volts, rest_since, away_since, rezero),
                State::Rest | State::Held { .. } => match self.detect(now, volts) {
                    None => self.check_hold(now, volts),
                    event => event,
                },
            },
        };
        self.output(event)
    }

    /// The whole step on most of a day's samples, reduced to its effects
    /// and taken where it gives the same result: at rest, nothing pending,
    /// on the tick after the last, a valid sample between the thresholds.
    /// It records the tick and tracks the neutral; the output is the
    /// default one. Returns whether it took the step.
    fn rest_step(&mut self, now: Tick, volts: f64) -> bool {
        let next_tick = self
            .last_tick
            .is_some_and(|last| now > last && now - last <= u64::from(self.config.stale_ms));
        let at_rest = matches!(self.state, State::Rest) && self.candidate.is_none();
        if self.reference_path || !at_rest || !next_tick {
            return false;
        }
        let valid = self.levels.check(volts).is_ok();
        if !valid || self.zone(volts, None) != Zone::Rest {
            return false;
        }
        self.last_tick = Some(now);
        self.last_sample = Some(now);
        self.rest_steps.add();
        self.track_neutral(now, volts);
        true
    }

    /// Checks that `now` comes after the last tick, and records it. Time
    /// that went back is a fault; the new count is then followed (the
    /// sensor recovers on it, as after any fault). A jump of more than
    /// `stale_ms` is a stall of the process or machine: whatever the loop
    /// missed is gone, so nothing held across it can be measured.
    fn advance_to(&mut self, now: Tick) -> Result<(), FaultReason> {
        let previous = self.last_tick.replace(now);
        match previous {
            Some(previous) if now <= previous => Err(FaultReason::TickNotIncreasing {
                tick: now,
                previous,
            }),
            Some(previous) if now - previous > u64::from(self.config.stale_ms) => {
                Err(FaultReason::Stalled { ms: now - previous })
            }
            _ => Ok(()),
        }
    }

    /// A breath known to last longer than `max_hold_ms` is a stuck sensor.
    /// A change of state pending (maybe the end of the breath) caps what
    /// is known at its first tick, so a glitch delays the fault by its
    /// length and a breath of exactly `max_hold_ms` is still a burst.
    fn check_hold(&mut self, now: Tick, volts: f64) -> Option<DetectorEvent> {
        let State::Held { breath, start } = self.state else {
            return None;
        };
        let known_end = match self.candidate {
            Some((zone, since)) if zone != Zone::Breath(breath) => since,
            _ => now.saturating_add(1),
        };
        if known_end.saturating_sub(start) <= u64::from(self.config.max_hold_ms) {
            return None;
        }
        let event = self.fault(FaultReason::Stuck {
            volts,
            held_ms: now.saturating_sub(start),
        });
        self.steady.reset();
        self.state = State::Faulted {
            rest_since: None,
            away_since: None,
            rezero: true,
        };
        event
    }

    fn output(&self, event: Option<DetectorEvent>) -> DetectorOutput {
        let held = match self.state {
            State::Held { breath, .. } => Held {
                breath: Some(breath),
                strength_volts: self.strength,
            },
            _ => Held::default(),
        };
        let starting = matches!(self.candidate, Some((Zone::Breath(_), _)));
        DetectorOutput {
            held,
            in_progress: held.breath.is_some() || starting,
            faulted: matches!(self.state, State::Faulted { .. }),
            event,
        }
    }

    fn fault(&mut self, reason: FaultReason) -> Option<DetectorEvent> {
        let already = matches!(self.state, State::Faulted { .. });
        self.state = State::Faulted {
            rest_since: None,
            away_since: None,
            rezero: false,
        };
        self.quiet_ticks = 0;
        self.candidate = None;
        self.strength = 0.0;
        (!already).then_some(DetectorEvent::Fault(reason))
    }

    /// Counts valid samples at rest; a glitch (at most `glitch_ms` away from
    /// rest) does not break the count, a longer excursion restarts it.
    /// After a stuck fault, also watches for a steady level to re-zero on.
    fn recover(
        &mut self,
        now: Tick,
        volts: f64,
        rest_since: Option<Tick>,
        away_since: Option<Tick>,
        rezero: bool,
    ) -> Option<DetectorEvent> {
        if rezero && let Some(event) = self.rezero(volts) {
            return Some(event);
        }
        if self.zone(volts, None) != Zone::Rest {
            let away = away_since.unwrap_or(now);
            let glitch = run_length(away, now) <= u64::from(self.config.glitch_ms);
            self.state = State::Faulted {
                rest_since: rest_since.filter(|_| glitch),
                away_since: Some(away),
                rezero,
            };
            return None;
        }
        let since = rest_since.unwrap_or(now);
        if run_length(since, now) >= u64::from(self.config.fault_recovery_ms) {
            self.state = State::Rest;
            Some(DetectorEvent::Recovered)
        } else {
            self.state = State::Faulted {
                rest_since: Some(since),
                away_since: None,
                rezero,
            };
            None
        }
    }

    /// Feeds the steadiness check; a level steady for `rezero_ms` that
    /// leaves room for both thresholds (and their hysteresis) inside
    /// 0–5 V becomes the neutral. A rail never can.
    fn rezero(&mut self, volts: f64) -> Option<DetectorEvent> {
        let (windows, level) = self.steady.push(volts)?;
        let room = level + self.levels.puff_offset + self.config.hysteresis_of(Breath::Puff) < 5.0
            && level + self.levels.sip_offset - self.config.hysteresis_of(Breath::Sip) > 0.0;
        let needed = u64::from(self.config.rezero_ms).div_ceil(REZERO_WINDOW_MS as u64);
        if windows < needed || !room {
            return None;
        }
        let previous = self.neutral;
        self.neutral = level;
        self.recent = [level; TRACKING_DELAY_MS];
        self.quiet_ticks = 0;
        self.candidate = None;
        self.strength = 0.0;
        self.state = State::Rest;
        Some(DetectorEvent::Rezeroed {
            neutral_volts: level,
            previous_volts: previous,
        })
    }

    /// Classifies a sample; `held` selects the hysteresis side.
    fn zone(&self, volts: f64, held: Option<Breath>) -> Zone {
        let puff_on = self.neutral + self.levels.puff_offset;
        let sip_on = self.neutral + self.levels.sip_offset;
        let (puff_off, sip_off) = match held {
            Some(Breath::Puff) => (puff_on - self.config.hysteresis_of(Breath::Puff), sip_on),
            Some(Breath::Sip) => (puff_on, sip_on + self.config.hysteresis_of(Breath::Sip)),
            None => (puff_on, sip_on),
        };
        if volts > puff_off {
            Zone::Breath(Breath::Puff)
        } else if volts < sip_off {
            Zone::Breath(Breath::Sip)
        } else {
            Zone::Rest
        }
    }

    fn detect(&mut self, now: Tick, volts: f64) -> Option<DetectorEvent> {
        let held = match self.state {
            State::Held { breath, .. } => Some(breath),
            _ => None,
        };
        let current = held.map_or(Zone::Rest, Zone::Breath);
        let zone = self.zone(volts, held);

        if zone == current {
            self.candidate = None;
            match held {
                Some(breath) => self.strength = self.past_threshold(breath, volts),
                None => self.track_neutral(now, volts),
            }
            return None;
        }
        if held.is_none() {
            // A crossing not yet confirmed (maybe a glitch): keep the delay
            // line going with the current estimate, which moves nothing.
            self.track_neutral(now, self.neutral);
        }

        let since = match self.candidate {
            Some((z, since)) if z == zone => since,
            _ => now,
        };
        self.candidate = Some((zone, since));
        if run_length(since, now) <= u64::from(self.config.glitch_ms) {
            return None; // not (yet) longer than a glitch
        }
        self.candidate = None;

        let finished = match self.state {
            State::Held { breath, start } => self.finish(breath, start, since),
            _ => None,
        };
        self.quiet_ticks = 0;
        self.state = match zone {
            Zone::Breath(breath) => {
                self.strength = self.past_threshold(breath, volts);
                State::Held {
                    breath,
                    start: since,
                }
            }
            Zone::Rest => {
                self.strength = 0.0;
                State::Rest
            }
        };
        finished.map(DetectorEvent::Burst)
    }

    fn finish(&self, breath: Breath, start: Tick, end: Tick) -> Option<Burst> {
        let duration = end.saturating_sub(start);
        (duration >= u64::from(self.config.min_burst_ms)).then(|| Burst {
            action: Action::new(breath, duration >= u64::from(self.config.long_burst_ms)),
            start,
            end,
        })
    }

    fn past_threshold(&self, breath: Breath, volts: f64) -> f64 {
        let past = match breath {
            Breath::Puff => volts - (self.neutral + self.levels.puff_offset),
            Breath::Sip => (self.neutral + self.levels.sip_offset) - volts,
        };
        past.max(0.0)
    }

    /// Feeds the neutral tracker a sample at rest (between the thresholds):
    /// every such sample is ambient pressure (a narrower band would let
    /// the estimate fall outside it in fast drift and stop tracking for
    /// good). Samples pass a delay line of [`TRACKING_DELAY_MS`]; one moves
    /// the estimate once the signal has been at rest a whole delay before
    /// and after it.
    fn track_neutral(&mut self, now: Tick, volts: f64) {
        let slot = (now % TRACKING_DELAY_MS as u64) as usize;
        self.quiet_ticks += 1;
        let Some(recent) = self.recent.get_mut(slot) else {
            return; // unreachable: the slot is taken modulo the length
        };
        if self.quiet_ticks > 2 * TRACKING_DELAY_MS as u64 {
            self.neutral += (*recent - self.neutral) * self.levels.tracking_alpha;
        }
        *recent = volts;
    }
}

/// Samples in the run from `since` to `now`, both included.
fn run_length(since: Tick, now: Tick) -> u64 {
    now.saturating_add(1).saturating_sub(since)
}
