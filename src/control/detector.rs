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

use std::fmt;

use serde::{Serialize, Serializer};

use crate::control::Tick;
use crate::control::action::{Action, Breath};
use crate::control::mode::Held;
use crate::control::sample::Sample;
use crate::control::skip_count::SkipCount;

/// Burst detector settings (`[detector]` in the config file).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DetectorConfig {
    /// Sensor output at rest, in volts. The detector starts from it and then
    /// tracks slow drift.
    pub neutral_volts: f64,
    /// A puff starts above this voltage (relative to the tracked neutral, it
    /// moves with the neutral by the same offset).
    pub puff_threshold_volts: f64,
    /// A sip starts below this voltage (moves with the neutral likewise).
    pub sip_threshold_volts: f64,
    /// A burst ends when the signal is back past its threshold by this much.
    pub hysteresis_volts: f64,
    /// Bursts shorter than this are ignored.
    pub min_burst_ms: u32,
    /// Bursts at least this long are long; shorter ones are short.
    pub long_burst_ms: u32,
    /// Longest glitch (spike, dropout) ignored: a change of state must last
    /// longer than this to count.
    pub glitch_ms: u32,
    /// Time constant of the neutral tracker (exponential average of the
    /// resting signal, updated only while no breath is in progress).
    pub neutral_tracking_ms: u32,
    /// Samples further than this outside 0–5 V are sensor faults.
    pub fault_margin_volts: f64,
    /// After a fault, the signal must be valid and at rest this long before
    /// detection resumes.
    pub fault_recovery_ms: u32,
    /// No sample for this long is a sensor fault (stale sensor), and a
    /// tick more than this after the previous one is a stall (a fault).
    pub stale_ms: u32,
    /// A breath longer than this is a stuck sensor (a fault): the breath
    /// is dropped and command mode ends.
    pub max_hold_ms: u32,
    /// After a stuck fault, a level steady this long (and with room for
    /// both thresholds inside 0–5 V) becomes the new neutral.
    pub rezero_ms: u32,
}

impl Default for DetectorConfig {
    fn default() -> Self {
        DetectorConfig {
            neutral_volts: 2.5,
            puff_threshold_volts: 3.0,
            sip_threshold_volts: 2.0,
            hysteresis_volts: 0.1,
            min_burst_ms: 40,
            long_burst_ms: 500,
            glitch_ms: 5,
            neutral_tracking_ms: 1000,
            fault_margin_volts: 0.5,
            fault_recovery_ms: 250,
            stale_ms: 50,
            max_hold_ms: 6000,
            rezero_ms: 2000,
        }
    }
}

impl DetectorConfig {
    /// These settings around another neutral: the thresholds keep their
    /// distances from it (a re-zero at start measures the neutral).
    pub fn with_neutral(self, neutral_volts: f64) -> DetectorConfig {
        let shift = neutral_volts - self.neutral_volts;
        DetectorConfig {
            neutral_volts,
            puff_threshold_volts: self.puff_threshold_volts + shift,
            sip_threshold_volts: self.sip_threshold_volts + shift,
            ..self
        }
    }
}

/// A finished burst.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Burst {
    /// Short/long sip/puff.
    pub action: Action,
    /// First tick past the threshold.
    pub start: Tick,
    /// First tick back past the threshold by the hysteresis.
    pub end: Tick,
}

impl Burst {
    /// Length in ticks (ms).
    pub fn duration_ms(&self) -> u64 {
        self.end.saturating_sub(self.start)
    }
}

/// A burst is written as its paper code, first tick and length (the event
/// log's `action`, `start_tick`, `duration_ms`).
impl Serialize for Burst {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        #[derive(Serialize)]
        struct Fields {
            action: Action,
            start_tick: Tick,
            duration_ms: u64,
        }
        Fields {
            action: self.action,
            start_tick: self.start,
            duration_ms: self.duration_ms(),
        }
        .serialize(serializer)
    }
}

/// Why the sensor signal was rejected.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FaultReason {
    /// The sample is NaN (e.g. a dropped reading).
    NotANumber,
    /// The sample is ±infinity.
    Infinite,
    /// The sample is further outside 0–5 V than `fault_margin_volts`.
    OutOfRange {
        /// The offending sample.
        volts: f64,
    },
    /// No sample arrived for `stale_ms`.
    Stale {
        /// How long without a sample, ms.
        ms: u64,
    },
    /// A breath held longer than `max_hold_ms`: the sensor is stuck (at a
    /// level, grounded or saturated) or its offset shifted.
    Stuck {
        /// The sample on the tick the breath became too long.
        volts: f64,
        /// How long the breath had been held, ms.
        held_ms: u64,
    },
    /// The sensor's device went away (unplugged, unbound, its driver
    /// gone): no sample can come until it returns.
    Disconnected,
    /// The tick jumped by more than `stale_ms`: the process or the machine
    /// stalled (SIGSTOP, a VM pause). Whatever was held across the gap is
    /// dropped, never measured as a breath.
    Stalled {
        /// Time from the previous tick to this one, ms.
        ms: u64,
    },
    /// A tick no later than the previous one: time must increase, so the
    /// runtime feeding the core is broken. Everything stops.
    TickNotIncreasing {
        /// The tick given.
        tick: Tick,
        /// The tick before it.
        previous: Tick,
    },
}

/// The reason in plain words, as the event log and the report show it.
impl fmt::Display for FaultReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FaultReason::NotANumber => f.write_str("sensor sample is NaN"),
            FaultReason::Infinite => f.write_str("sensor sample is infinite"),
            FaultReason::OutOfRange { volts } => {
                write!(f, "sensor sample {volts:.3} V is outside the 0–5 V range")
            }
            FaultReason::Stale { ms } => write!(f, "no sensor sample for {ms} ms"),
            FaultReason::Disconnected => f.write_str("sensor disconnected — arm stopped"),
            FaultReason::Stuck { volts, held_ms } => write!(
                f,
                "breath held {held_ms} ms at {volts:.2} V: sensor stuck or offset shifted — arm stopped"
            ),
            FaultReason::Stalled { ms } => write!(
                f,
                "the control loop stalled for {ms} ms (process stopped or machine paused): samples of the gap discarded — arm stopped"
            ),
            FaultReason::TickNotIncreasing { tick, previous } => write!(
                f,
                "tick {tick} is not after the previous tick {previous}: the runtime's clock is broken"
            ),
        }
    }
}

/// Serialized as its plain words.
impl Serialize for FaultReason {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_str(self)
    }
}

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

/// Re-zeroing looks at the signal in windows of this many samples (100 ms:
/// five whole periods of 50 Hz hum and six of 60 Hz, so hum averages out).
pub const REZERO_WINDOW_MS: usize = 100;

/// Samples dropped from each end of a window before averaging it (a
/// trimmed mean): a spike or dropout to a rail lasts at most `glitch_ms`
/// samples, so up to ten of either never move a window's level.
pub const REZERO_TRIM: usize = 10;

/// A level is steady while the trimmed means of all its windows lie within
/// this band (highest − lowest). Noise of σ = 0.1 V moves a window's mean
/// by about 0.011 V and the fastest drift (0.5 V a minute) 0.017 V in 2 s;
/// a held breath wanders by more (the synthetic user's by ±0.1 V at
/// 0.5 Hz: 0.2 V in any 2 s).
pub const REZERO_STEADY_VOLTS: f64 = 0.1;

/// Whether the signal has held one level, window by window. RT-safe: a
/// fixed array, sorted in place once per window.
#[derive(Debug, Clone)]
struct Steadiness {
    window: [f64; REZERO_WINDOW_MS],
    filled: usize,
    /// Windows in the current steady run, their lowest and highest
    /// trimmed means and the sum of them.
    windows: u64,
    low: f64,
    high: f64,
    sum: f64,
}

impl Steadiness {
    fn new() -> Self {
        Steadiness {
            window: [0.0; REZERO_WINDOW_MS],
            filled: 0,
            windows: 0,
            low: 0.0,
            high: 0.0,
            sum: 0.0,
        }
    }

    fn reset(&mut self) {
        self.filled = 0;
        self.windows = 0;
    }

    /// Adds a valid sample; when a window completes, returns how many
    /// windows the steady run now spans and its mean level.
    fn push(&mut self, volts: f64) -> Option<(u64, f64)> {
        let slot = self.window.get_mut(self.filled)?;
        *slot = volts;
        self.filled += 1;
        if self.filled < REZERO_WINDOW_MS {
            return None;
        }
        self.filled = 0;
        self.window.sort_unstable_by(f64::total_cmp);
        let kept = REZERO_WINDOW_MS - 2 * REZERO_TRIM;
        let mean = self.window.iter().skip(REZERO_TRIM).take(kept).sum::<f64>() / kept as f64;
        let (low, high) = (self.low.min(mean), self.high.max(mean));
        if self.windows > 0 && high - low <= REZERO_STEADY_VOLTS {
            self.windows += 1;
            (self.low, self.high) = (low, high);
            self.sum += mean;
        } else {
            // The level moved: a new run starts with this window.
            self.windows = 1;
            (self.low, self.high, self.sum) = (mean, mean, mean);
        }
        Some((self.windows, self.sum / self.windows as f64))
    }
}

/// The burst detector. Construct once; [`BurstDetector::step`] is RT-safe
/// (no allocation, no panic, O(1)).
#[derive(Debug, Clone)]
pub struct BurstDetector {
    puff_offset: f64,
    sip_offset: f64,
    hysteresis: f64,
    min_burst: u64,
    long_burst: u64,
    glitch: u64,
    tracking_alpha: f64,
    low_limit: f64,
    high_limit: f64,
    recovery: u64,
    stale: u64,
    max_hold: u64,
    /// Windows a level must be steady to become the neutral.
    rezero_windows: u64,

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
        let puff_offset = config.puff_threshold_volts - config.neutral_volts;
        let sip_offset = config.sip_threshold_volts - config.neutral_volts;
        BurstDetector {
            puff_offset,
            sip_offset,
            hysteresis: config.hysteresis_volts,
            min_burst: config.min_burst_ms.into(),
            long_burst: config.long_burst_ms.into(),
            glitch: config.glitch_ms.into(),
            tracking_alpha: 1.0 / f64::from(config.neutral_tracking_ms),
            low_limit: -config.fault_margin_volts,
            high_limit: 5.0 + config.fault_margin_volts,
            recovery: config.fault_recovery_ms.into(),
            stale: config.stale_ms.into(),
            max_hold: config.max_hold_ms.into(),
            rezero_windows: u64::from(config.rezero_ms).div_ceil(REZERO_WINDOW_MS as u64),
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
        self.stale
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
        let event = if since >= self.stale {
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
        let event = match Self::check(volts, self.low_limit, self.high_limit) {
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
            .is_some_and(|last| now > last && now - last <= self.stale);
        let at_rest = matches!(self.state, State::Rest) && self.candidate.is_none();
        if self.reference_path || !at_rest || !next_tick {
            return false;
        }
        let valid = Self::check(volts, self.low_limit, self.high_limit).is_ok();
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
            Some(previous) if now - previous > self.stale => {
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
        if known_end.saturating_sub(start) <= self.max_hold {
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

    fn check(volts: f64, low: f64, high: f64) -> Result<(), FaultReason> {
        if volts.is_nan() {
            Err(FaultReason::NotANumber)
        } else if volts.is_infinite() {
            Err(FaultReason::Infinite)
        } else if volts < low || volts > high {
            Err(FaultReason::OutOfRange { volts })
        } else {
            Ok(())
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
            let glitch = run_length(away, now) <= self.glitch;
            self.state = State::Faulted {
                rest_since: rest_since.filter(|_| glitch),
                away_since: Some(away),
                rezero,
            };
            return None;
        }
        let since = rest_since.unwrap_or(now);
        if run_length(since, now) >= self.recovery {
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
        let room = level + self.puff_offset + self.hysteresis < 5.0
            && level + self.sip_offset - self.hysteresis > 0.0;
        if windows < self.rezero_windows || !room {
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
        let puff_on = self.neutral + self.puff_offset;
        let sip_on = self.neutral + self.sip_offset;
        let (puff_off, sip_off) = match held {
            Some(Breath::Puff) => (puff_on - self.hysteresis, sip_on),
            Some(Breath::Sip) => (puff_on, sip_on + self.hysteresis),
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
        if run_length(since, now) <= self.glitch {
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
        (duration >= self.min_burst).then(|| Burst {
            action: Action::new(breath, duration >= self.long_burst),
            start,
            end,
        })
    }

    fn past_threshold(&self, breath: Breath, volts: f64) -> f64 {
        let past = match breath {
            Breath::Puff => volts - (self.neutral + self.puff_offset),
            Breath::Sip => (self.neutral + self.sip_offset) - volts,
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
            self.neutral += (*recent - self.neutral) * self.tracking_alpha;
        }
        *recent = volts;
    }
}

/// Samples in the run from `since` to `now`, both included.
fn run_length(since: Tick, now: Tick) -> u64 {
    now.saturating_add(1).saturating_sub(since)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::sample::Sample::{Lost, Missing, Volts};

    /// Everything a detector holds but the rest step's switch and count.
    fn state(d: &BurstDetector) -> String {
        let mut d = d.clone();
        d.reference_path = false;
        d.rest_steps = SkipCount::default();
        format!("{d:?}")
    }

    /// A detector that takes the rest step and one that never does.
    fn with_and_without_rest_step(config: &DetectorConfig) -> (BurstDetector, BurstDetector) {
        let mut whole = BurstDetector::new(config);
        whole.use_reference_path();
        (BurstDetector::new(config), whole)
    }

    proptest::proptest! {
        /// The rest step is the whole step: a detector that takes it and
        /// one that never does give the same output every tick and the
        /// same state (by `Debug`: the delay line and `-0.0` included),
        /// over runs of samples near the neutral, breaths, exact thresholds
        /// and range limits, NaN and infinities, on ticks that follow,
        /// repeat, skip and stall, with missing samples and a device gone.
        #[test]
        fn the_rest_step_is_the_whole_step(
            runs in proptest::collection::vec((
                proptest::prop_oneof![8 => proptest::strategy::Just(1u64), 1 => proptest::strategy::Just(0u64), 1 => 2u64..80],
                proptest::prop_oneof![
                    6 => 2.2f64..2.8,
                    2 => proptest::sample::select(vec![
                        3.0, 2.0, 2.9, 2.1, 3.8, 1.2, -0.5, 5.5, -0.6, 5.6, 0.0, -0.0, 5.0,
                        f64::NAN, f64::INFINITY, f64::NEG_INFINITY,
                    ]),
                    1 => -1.0f64..6.0,
                ],
                proptest::prop_oneof![3 => 1usize..4, 1 => 4usize..400],
                proptest::prop_oneof![
                    10 => proptest::strategy::Just(None),
                    1 => proptest::strategy::Just(Some(Missing)),
                    1 => proptest::strategy::Just(Some(Lost)),
                ],
            ), 1..120),
            fast_tracking in proptest::bool::ANY,
        ) {
            let mut config = DetectorConfig::default();
            if fast_tracking {
                // The neutral follows closely: the thresholds move a lot.
                config.neutral_tracking_ms = 20;
                config.glitch_ms = 0;
            }
            let (mut fast, mut whole) = with_and_without_rest_step(&config);
            let mut tick = 0u64;
            for (delta, volts, repeat, no_sample) in runs {
                tick += delta;
                let sample = no_sample.unwrap_or(Volts(volts));
                for _ in 0..repeat {
                    let (a, b) = (fast.step(tick, sample), whole.step(tick, sample));
                    proptest::prop_assert_eq!(format!("{a:?}"), format!("{b:?}"), "tick {}", tick);
                    tick += 1;
                }
                proptest::prop_assert_eq!(state(&fast), state(&whole));
            }
            proptest::prop_assert_eq!(whole.rest_steps(), 0);
        }
    }

    #[test]
    fn a_day_at_rest_takes_the_rest_step() {
        let (mut fast, mut whole) = with_and_without_rest_step(&DetectorConfig::default());
        for t in 0..10_000 {
            // Noise about the neutral, inside the thresholds.
            let volts = 2.5 + 0.2 * ((t as f64) * 0.37).sin();
            assert_eq!(fast.step(t, Volts(volts)), whole.step(t, Volts(volts)));
        }
        assert_eq!(state(&fast), state(&whole));
        // All but the first sample (no tick before it).
        assert_eq!(fast.rest_steps(), 9_999);
    }

    /// Runs a detector over samples, returning (tick, event) pairs.
    fn run(config: &DetectorConfig, samples: &[f64]) -> Vec<(Tick, DetectorEvent)> {
        let mut d = BurstDetector::new(config);
        samples
            .iter()
            .enumerate()
            .filter_map(|(t, &v)| d.step(t as Tick, Volts(v)).event.map(|e| (t as Tick, e)))
            .collect()
    }

    /// `rest` ms at 2.5 V, `len` ms at `level`, `after` ms at 2.5 V.
    fn square(rest: usize, level: f64, len: usize, after: usize) -> Vec<f64> {
        let mut s = vec![2.5; rest];
        s.extend(std::iter::repeat_n(level, len));
        s.extend(std::iter::repeat_n(2.5, after));
        s
    }

    fn burst(action: Action, start: Tick, end: Tick) -> DetectorEvent {
        DetectorEvent::Burst(Burst { action, start, end })
    }

    #[test]
    fn short_and_long_with_exact_durations() {
        let c = DetectorConfig::default(); // min 40, long 500, glitch 5
        // A 100 ms puff from tick 10: ends at 110, confirmed at 115.
        assert_eq!(
            run(&c, &square(10, 4.0, 100, 50)),
            [(115, burst(Action::ShortPuff, 10, 110))]
        );
        assert_eq!(
            run(&c, &square(10, 1.0, 500, 50)),
            [(515, burst(Action::LongSip, 10, 510))]
        );
        assert_eq!(
            run(&c, &square(10, 1.0, 499, 50)),
            [(514, burst(Action::ShortSip, 10, 509))]
        );
        assert_eq!(
            run(&c, &square(0, 4.0, 40, 50)),
            [(45, burst(Action::ShortPuff, 0, 40))]
        );
        assert_eq!(run(&c, &square(0, 4.0, 39, 50)), []);
    }

    #[test]
    fn threshold_and_hysteresis() {
        let c = DetectorConfig::default(); // puff 3.0, hysteresis 0.1
        // Exactly at the threshold is not past it.
        assert_eq!(run(&c, &square(5, 3.0, 200, 50)), []);
        // Dropping to 2.95 is inside the hysteresis band: the puff goes on.
        let mut s = square(5, 3.5, 100, 0);
        s.extend(std::iter::repeat_n(2.95, 100));
        s.extend(std::iter::repeat_n(2.5, 50));
        assert_eq!(run(&c, &s), [(210, burst(Action::ShortPuff, 5, 205))]);
    }

    #[test]
    fn glitches_neither_create_nor_split_bursts() {
        let c = DetectorConfig::default();
        // Spikes of 1..=5 samples to both rails at rest: nothing.
        for len in 1..=5 {
            for level in [0.0, 5.0] {
                assert_eq!(run(&c, &square(20, level, len, 50)), [], "{len} at {level}");
            }
        }
        // The same spikes inside a long puff, and a dropout to 0 V: one burst.
        for len in 1..=5 {
            let mut s = square(10, 4.0, 300, 0);
            s[150..150 + len].fill(0.0);
            s[250..250 + len].fill(5.0);
            s.extend(std::iter::repeat_n(2.5, 50));
            assert_eq!(
                run(&c, &s),
                [(315, burst(Action::ShortPuff, 10, 310))],
                "{len}"
            );
        }
        // Six samples is longer than a glitch: the puff is split.
        let mut s = square(10, 4.0, 300, 0);
        s[150..156].fill(2.5);
        s.extend(std::iter::repeat_n(2.5, 50));
        assert_eq!(run(&c, &s).len(), 2);
    }

    #[test]
    fn direct_reversal_ends_one_burst_and_starts_the_other() {
        let c = DetectorConfig::default();
        let mut s = square(10, 4.0, 100, 0);
        s.extend(std::iter::repeat_n(1.0, 100));
        s.extend(std::iter::repeat_n(2.5, 20));
        assert_eq!(
            run(&c, &s),
            [
                (115, burst(Action::ShortPuff, 10, 110)),
                (215, burst(Action::ShortSip, 110, 210)),
            ]
        );
    }

    #[test]
    fn held_and_strength_follow_the_breath() {
        let c = DetectorConfig::default();
        let mut d = BurstDetector::new(&c);
        for t in 0..10 {
            assert_eq!(d.step(t, Volts(2.5)).held, Held::default());
        }
        let mut out = DetectorOutput::default();
        for t in 10..20 {
            out = d.step(t, Volts(3.7));
        }
        assert_eq!(out.held.breath, Some(Breath::Puff));
        assert!((out.held.strength_volts - 0.7).abs() < 1e-12);
        // A one-sample spike keeps the held state and its strength.
        let spike = d.step(20, Volts(0.0));
        assert_eq!(spike.held, out.held);
        assert!(spike.in_progress);
    }

    #[test]
    fn slow_drift_neither_creates_nor_loses_bursts() {
        let c = DetectorConfig::default();
        let mut d = BurstDetector::new(&c);
        let mut bursts = 0;
        // +0.3 V over one minute, with a 150 ms puff of 0.9 V every 2 s.
        for t in 0..60_000u64 {
            let neutral = 2.5 + 0.3 * t as f64 / 60_000.0;
            let phase = t % 2000;
            let v = if (1000..1150).contains(&phase) {
                neutral + 0.9
            } else {
                neutral
            };
            if let Some(DetectorEvent::Burst(b)) = d.step(t, Volts(v)).event {
                assert_eq!(b.action, Action::ShortPuff);
                assert_eq!(b.duration_ms(), 150);
                bursts += 1;
            }
        }
        assert_eq!(bursts, 30);
        // An exponential tracker lags a ramp by rate × (τ + delay) =
        // 0.005 V/s × 1.1 s, a little more for the pauses during breaths.
        let lag = 2.8 - d.neutral_volts();
        assert!((0.005..0.008).contains(&lag), "lag {lag}");
        // Then back down −0.3 V below the start with sips.
        for t in 60_000..180_000u64 {
            let neutral = 2.8 - 0.6 * (t - 60_000) as f64 / 120_000.0;
            let phase = t % 2000;
            let v = if (1000..1150).contains(&phase) {
                neutral - 0.9
            } else {
                neutral
            };
            if let Some(DetectorEvent::Burst(b)) = d.step(t, Volts(v)).event {
                assert_eq!(b.action, Action::ShortSip);
                bursts += 1;
            }
        }
        assert_eq!(bursts, 90);
    }

    #[test]
    fn neutral_is_tracked_at_rest_only() {
        let c = DetectorConfig::default();
        let mut d = BurstDetector::new(&c);
        // A 5 s breath, then a one-sample spike and the start of another
        // breath (crossings pending): none of it moves the neutral.
        for t in 0..5_000 {
            d.step(t, Volts(4.0));
        }
        for t in 5_000..5_100 {
            d.step(t, Volts(2.5));
        }
        assert_eq!(d.neutral_volts(), 2.5);
        d.step(5_100, Volts(0.0));
        for t in 5_101..5_104 {
            d.step(t, Volts(4.0));
        }
        assert_eq!(d.neutral_volts(), 2.5);
        // A resting level that moved by 0.2 V is followed with the
        // configured time constant: 1 − e⁻¹ of the way after 1 s.
        // Tracking starts once the signal has been at rest for twice the
        // delay; each tick then consumes the sample one delay old.
        let mut d = BurstDetector::new(&c);
        let start = 2 * TRACKING_DELAY_MS as u64;
        for t in 0..start + 1000 {
            d.step(t, Volts(2.7));
        }
        let followed = (d.neutral_volts() - 2.5) / 0.2;
        let expected = 1.0 - (1.0 - 1.0 / 1000.0f64).powi(1000);
        assert!((followed - expected).abs() < 1e-9, "{followed}");
    }

    #[test]
    fn faults_are_never_bursts_and_recover_at_rest() {
        let c = DetectorConfig::default(); // recovery 250 ms, margin 0.5 V
        let mut s = square(10, 4.0, 100, 0); // puff in progress …
        s.push(f64::NAN); // … dropped by a fault
        s.extend(std::iter::repeat_n(4.0, 100));
        s.extend(std::iter::repeat_n(2.5, 300));
        let events = run(&c, &s);
        assert_eq!(
            events,
            [
                (110, DetectorEvent::Fault(FaultReason::NotANumber)),
                // At rest from 211; 250 samples later.
                (460, DetectorEvent::Recovered),
            ]
        );
        assert_eq!(
            run(&c, &[2.5, f64::INFINITY])[0].1,
            DetectorEvent::Fault(FaultReason::Infinite)
        );
        assert_eq!(
            run(&c, &[2.5, 5.6])[0].1,
            DetectorEvent::Fault(FaultReason::OutOfRange { volts: 5.6 })
        );
        assert_eq!(run(&c, &[5.5, -0.5, 0.0, 5.0]), []); // within the margin
    }

    #[test]
    fn recovery_ignores_glitches_but_not_breaths() {
        let c = DetectorConfig::default(); // recovery 250 ms, glitch 5 ms
        // Spikes to the rails every 100 ms do not hold recovery off.
        let mut s = vec![f64::NAN];
        s.extend(std::iter::repeat_n(2.5, 400));
        for i in (60..400).step_by(100) {
            s[i] = 5.0;
        }
        assert_eq!(run(&c, &s)[1], (250, DetectorEvent::Recovered));
        // A breath (longer than a glitch) restarts the count.
        let mut s = vec![f64::NAN];
        s.extend(std::iter::repeat_n(2.5, 100));
        s.extend(std::iter::repeat_n(4.0, 6));
        s.extend(std::iter::repeat_n(2.5, 400));
        assert_eq!(run(&c, &s)[1], (356, DetectorEvent::Recovered));
    }

    #[test]
    fn a_stale_sensor_faults_and_a_fresh_one_recovers() {
        let c = DetectorConfig::default(); // stale 50 ms, recovery 250 ms
        let mut d = BurstDetector::new(&c);
        for t in 0..100 {
            d.step(t, Volts(3.8)); // puff held …
        }
        for t in 100..149 {
            let out = d.step(t, Missing); // … then the sensor goes quiet
            assert_eq!(out.held.breath, Some(Breath::Puff), "held until stale");
            assert!(out.event.is_none());
        }
        let out = d.step(149, Missing);
        assert_eq!(
            out.event,
            Some(DetectorEvent::Fault(FaultReason::Stale { ms: 50 }))
        );
        assert!(out.faulted);
        assert_eq!(out.held, Held::default());
        assert_eq!(d.step(500, Missing).event, None, "one event per fault");
        let events: Vec<_> = (501..800)
            .filter_map(|t| d.step(t, Volts(2.5)).event)
            .collect();
        assert_eq!(events, [DetectorEvent::Recovered]);
        // Never a sample from start: stale too.
        let mut d = BurstDetector::new(&c);
        assert!(d.step(48, Missing).event.is_none());
        assert!(d.step(49, Missing).event.is_some());
    }

    #[test]
    fn output_reports_fault_state() {
        let c = DetectorConfig::default();
        let mut d = BurstDetector::new(&c);
        let out = d.step(0, Volts(f64::NEG_INFINITY));
        assert!(out.faulted);
        assert_eq!(out.held, Held::default());
        assert!(
            d.step(1, Volts(f64::NAN)).event.is_none(),
            "one event per fault"
        );
    }

    #[test]
    fn a_tick_that_does_not_increase_is_a_fault_not_an_overflow() {
        let c = DetectorConfig::default();
        let mut d = BurstDetector::new(&c);
        for t in 1000..1100 {
            d.step(t, Volts(3.8)); // a puff held
        }
        let out = d.step(5, Volts(3.8)); // time went back
        assert_eq!(
            out.event,
            Some(DetectorEvent::Fault(FaultReason::TickNotIncreasing {
                tick: 5,
                previous: 1099
            }))
        );
        assert!(out.faulted && out.held == Held::default());
        // The same tick again, and a missing sample at an earlier one: still
        // one fault (the sensor is in fault already), no panic.
        assert_eq!(d.step(5, Volts(2.5)).event, None);
        assert_eq!(d.step(3, Missing).event, None);
        // Time goes on from there: valid samples at rest recover.
        let recovered: Vec<_> = (6..400)
            .filter_map(|t| d.step(t, Volts(2.5)).event)
            .collect();
        assert_eq!(recovered, [DetectorEvent::Recovered]);
        assert_eq!(
            FaultReason::TickNotIncreasing {
                tick: 5,
                previous: 1099
            }
            .to_string(),
            "tick 5 is not after the previous tick 1099: the runtime's clock is broken"
        );
    }

    #[test]
    fn a_breath_longer_than_max_hold_is_a_stuck_fault() {
        let c = DetectorConfig::default(); // max hold 6000 ms, re-zero 2000 ms
        // Held to the limit and one less: long bursts.
        assert_eq!(
            run(&c, &square(10, 4.0, 5999, 50)),
            [(6014, burst(Action::LongPuff, 10, 6009))]
        );
        assert_eq!(
            run(&c, &square(10, 4.0, 6000, 50)),
            [(6015, burst(Action::LongPuff, 10, 6010))]
        );
        // One more: stuck, on the tick it became longer, and no burst.
        let reason = FaultReason::Stuck {
            volts: 4.0,
            held_ms: 6000,
        };
        let stuck = DetectorEvent::Fault(reason);
        assert_eq!(
            run(&c, &square(10, 4.0, 6001, 500)),
            [(6010, stuck), (6011 + 249, DetectorEvent::Recovered)]
        );
        // A glitch pending at the limit delays the verdict by its length.
        let mut s = square(10, 4.0, 7000, 0);
        s[6010..6013].fill(2.5);
        assert_eq!(
            run(&c, &s)[0],
            (
                6013,
                DetectorEvent::Fault(FaultReason::Stuck {
                    volts: 4.0,
                    held_ms: 6003
                })
            )
        );
        assert_eq!(
            reason.to_string(),
            "breath held 6000 ms at 4.00 V: sensor stuck or offset shifted — arm stopped"
        );
    }

    #[test]
    fn a_steady_stuck_level_becomes_the_neutral_but_never_a_rail() {
        let c = DetectorConfig::default();
        // Stuck at 4.0 V: faulted at 6010; steady for 2000 ms after it,
        // and 4.0 + 0.5 + 0.1 < 5 V: the new neutral on tick 8010.
        let events = run(&c, &square(10, 4.0, 60_000, 0));
        assert_eq!(events.len(), 2, "{events:?}");
        assert_eq!(events[1].0, 8010);
        let DetectorEvent::Rezeroed {
            neutral_volts,
            previous_volts,
        } = events[1].1
        else {
            panic!("{events:?}")
        };
        assert!((neutral_volts - 4.0).abs() < 1e-12 && previous_volts == 2.5);
        // At a rail there is no room for a threshold: faulted for good.
        for rail in [5.0, 0.0] {
            let events = run(&c, &square(10, rail, 60_000, 0));
            assert_eq!(events.len(), 1, "{rail} V: {events:?}");
            assert!(matches!(
                events[0],
                (6010, DetectorEvent::Fault(FaultReason::Stuck { .. }))
            ));
        }
        // A level that wanders (±0.1 V at 0.5 Hz) is a breath, not an
        // offset: never re-zeroed; released, it recovers.
        let mut s = vec![2.5; 10];
        s.extend((0..20_000).map(|t| 4.0 + 0.1 * (std::f64::consts::PI * t as f64 / 1000.0).sin()));
        s.extend(std::iter::repeat_n(2.5, 300));
        let events = run(&c, &s);
        assert_eq!(events.len(), 2, "{events:?}");
        assert!(matches!(
            events[0].1,
            DetectorEvent::Fault(FaultReason::Stuck { .. })
        ));
        assert_eq!(events[1], (20_010 + 249, DetectorEvent::Recovered));
        // Another fault while waiting ends the chance to re-zero (the arm
        // stays stopped; rest recovers as after any fault).
        let mut s = square(10, 4.0, 7000, 0);
        s[7000] = f64::NAN;
        s.extend(std::iter::repeat_n(4.0, 10_000));
        assert_eq!(run(&c, &s).len(), 1);
    }

    #[test]
    fn a_tick_jump_longer_than_stale_is_a_stall() {
        let c = DetectorConfig::default(); // stale 50 ms
        let mut d = BurstDetector::new(&c);
        for t in 0..600 {
            d.step(t, Volts(3.8)); // a puff held
        }
        // A gap of 50 ms (49 ticks missed) is not a stall; 51 ms is.
        assert_eq!(d.step(649, Volts(3.8)).event, None);
        let out = d.step(700, Volts(3.8));
        assert_eq!(
            out.event,
            Some(DetectorEvent::Fault(FaultReason::Stalled { ms: 51 }))
        );
        assert!(out.faulted && out.held == Held::default());
        // Seen on a tick without a sample too; then rest recovers.
        let mut d = BurstDetector::new(&c);
        d.step(0, Volts(2.5));
        assert_eq!(
            d.step(2000, Missing).event,
            Some(DetectorEvent::Fault(FaultReason::Stalled { ms: 2000 }))
        );
        let events: Vec<_> = (2001..2300)
            .filter_map(|t| d.step(t, Volts(2.5)).event)
            .collect();
        assert_eq!(events, [DetectorEvent::Recovered]);
        assert_eq!(
            FaultReason::Stalled { ms: 2000 }.to_string(),
            "the control loop stalled for 2000 ms (process stopped or machine paused): samples of the gap discarded — arm stopped"
        );
    }
}
