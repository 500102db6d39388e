//! The head-worn IMU's part of the core, as the burst detector is the
//! breath sensor's: its faults (silent, frozen, gone, not finite), the
//! person's gestures (the [`Recognizer`]) and, in a command mode, which
//! way the head is tilted past a dead zone and how far.
//!
//! Tilt is measured against the head's rest when the command mode began:
//! a person who rests with their head to one side moves nothing until
//! they tilt it further. A tilt is held past the dead zone and let go
//! inside three quarters of it, so a head resting at its edge does not
//! start and stop the arm.

use serde::{Deserialize, Serialize};

use crate::control::Tick;
use crate::control::action::Breath;
use crate::control::detector::FaultReason;
use crate::control::gesture::config::GestureConfig;
use crate::control::gesture::features::norm3;
use crate::control::gesture::name::GestureName;
use crate::control::gesture::recognizer::{GestureEvent, Recognizer, RejectReason};
use crate::control::gesture::templates::{GestureId, GestureTemplates, MAX_GESTURES};
use crate::control::imu::{Channels, ImuInput, ImuSample};
use crate::control::mode::Held;

/// How the head's tilt is read in a command mode. Serialized by its name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TiltAxis {
    /// Chin down moves the positive way (as a puff), chin up the negative.
    #[default]
    Pitch,
    /// Left ear down moves the positive way, right ear down the negative.
    Roll,
    /// The head does not move the arm (a breath does).
    Off,
}

impl TiltAxis {
    /// The three choices.
    pub const ALL: [TiltAxis; 3] = [TiltAxis::Pitch, TiltAxis::Roll, TiltAxis::Off];

    /// `pitch`, `roll` or `off`.
    pub const fn name(self) -> &'static str {
        match self {
            TiltAxis::Pitch => "pitch",
            TiltAxis::Roll => "roll",
            TiltAxis::Off => "off",
        }
    }
}

/// The head's settings beyond the gesture set (`[gestures]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HeadConfig {
    /// No IMU sample for this long is a fault.
    pub stale_ms: u32,
    /// The same six values bit for bit for this long is a fault (a frozen
    /// sensor; a live one's noise always moves one of them).
    pub frozen_ms: u32,
    /// After a fault, valid and changing samples for this long end it.
    pub recover_ms: u32,
    /// Which tilt moves the arm in a command mode.
    pub tilt: TiltAxis,
    /// Tilts within this angle of the rest move nothing, degrees.
    pub dead_zone_deg: f64,
    /// At this angle the arm moves at full speed, degrees.
    pub full_scale_deg: f64,
}

impl Default for HeadConfig {
    fn default() -> Self {
        HeadConfig {
            stale_ms: 100,
            frozen_ms: 1000,
            recover_ms: 300,
            tilt: TiltAxis::Pitch,
            dead_zone_deg: 12.0,
            full_scale_deg: 30.0,
        }
    }
}

impl HeadConfig {
    /// Every bad value, by key.
    pub fn validate(&self) -> Result<(), Vec<String>> {
        let mut bad = Vec::new();
        if !(1..=10_000).contains(&self.stale_ms) {
            bad.push(format!("stale_ms: {} is not 1–10000 ms", self.stale_ms));
        }
        if !(100..=60_000).contains(&self.frozen_ms) {
            bad.push(format!("frozen_ms: {} is not 100–60000 ms", self.frozen_ms));
        }
        if self.recover_ms > 60_000 {
            bad.push(format!("recover_ms: {} is over 60000 ms", self.recover_ms));
        }
        let dead_zone_ok =
            self.dead_zone_deg.is_finite() && (2.0..=45.0).contains(&self.dead_zone_deg);
        if !dead_zone_ok {
            bad.push(format!(
                "dead_zone_deg: {} is not 2–45 degrees",
                self.dead_zone_deg
            ));
        } else if !(self.full_scale_deg.is_finite()
            && self.full_scale_deg > self.dead_zone_deg
            && self.full_scale_deg <= 80.0)
        {
            bad.push(format!(
                "full_scale_deg: {} is not above dead_zone_deg ({}) and at most 80 degrees",
                self.full_scale_deg, self.dead_zone_deg
            ));
        }
        if bad.is_empty() { Ok(()) } else { Err(bad) }
    }
}

/// What the core needs of a person's gesture set: their names (a library
/// entry's words) and the recognizer's settings and templates. The head's
/// own settings are the configuration's (`[gestures]`).
#[derive(Debug, Clone, PartialEq)]
pub struct GestureSetup {
    /// The gestures' names, by [`GestureId`].
    pub names: Vec<GestureName>,
    /// The recognizer's settings (fitted to the person's recording).
    pub recognizer: GestureConfig,
    /// The person's examples and thresholds.
    pub templates: GestureTemplates,
    /// The IMU channels the examples were recorded with: an IMU must give
    /// each of them.
    pub channels: Channels,
}

/// What a movement that ended was. `Copy`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HeadGesture {
    /// One of the person's gestures.
    Recognised {
        /// Its name.
        name: GestureName,
        /// The movement's first tick.
        start: Tick,
    },
    /// No gesture: never guessed.
    Rejected {
        /// The nearest gesture compared, if any.
        nearest: Option<GestureName>,
        /// Why.
        why: RejectReason,
    },
}

/// The IMU's health changed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HeadEvent {
    /// It went into fault.
    Fault(FaultReason),
    /// It is healthy again.
    Recovered,
}

/// What the head did on one tick. `Copy`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HeadOutput {
    /// A movement ended on this tick (outside a command mode).
    pub gesture: Option<HeadGesture>,
    /// A movement is under way: a sequence's timeout waits for it.
    pub in_motion: bool,
    /// In a command mode: the side the head is tilted to past the dead
    /// zone (`Puff` is the positive way), else nothing held.
    pub tilt: Held,
    /// How far past the dead zone, 0–1 of the way to full scale.
    pub speed_fraction: f64,
    /// The IMU is in fault: nothing is recognised, nothing moves.
    pub faulted: bool,
    /// Its health changed on this tick.
    pub event: Option<HeadEvent>,
}

/// The head as the display shows it: how far it is pitched and rolled
/// from its rest, and whether a movement is under way. `Copy`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HeadView {
    /// Chin down (+) or up (−), degrees from the rest: in a command mode
    /// the rest it began at (what the tilt that moves is measured from),
    /// else the rest the front end tracks.
    pub pitch_deg: f64,
    /// Left ear down (+) or right ear down (−), degrees, likewise.
    pub roll_deg: f64,
    /// A movement is under way (a gesture being made; never in a command
    /// mode, where the head's tilt moves the arm).
    pub moving: bool,
    /// In a command mode, the head is tilted past the dead zone: it moves
    /// the arm, and the mode stays.
    pub tilted: bool,
}

/// Ticks of the tilt's smoothing (an exponential average's time constant).
const TILT_SMOOTHING_TICKS: f64 = 80.0;

/// One tick of the tilt's smoothing: `smoothed` moves towards the
/// acceleration `a` (m/s²) with [`TILT_SMOOTHING_TICKS`]' time constant,
/// starting at `a`.
pub fn smooth_tilt(smoothed: &mut Option<[f64; 3]>, a: [f64; 3]) {
    let alpha = 1.0 - (-1.0 / TILT_SMOOTHING_TICKS).exp();
    let s = smoothed.get_or_insert(a);
    for (s, a) in s.iter_mut().zip(a) {
        *s += alpha * (a - *s);
    }
}

/// The head's pitch (chin down +) and roll (left ear down +), degrees,
/// from the gravity `reference` at rest to the acceleration `now` (each
/// m/s², sensor axes); none without a reference.
pub fn pitch_and_roll(reference: [f64; 3], now: [f64; 3]) -> Option<(f64, f64)> {
    let g = norm3(reference);
    if g <= 0.0 {
        return None;
    }
    // Chin down turns gravity towards -x; the left ear down towards -y.
    let angle = |i: usize| {
        let d = now.get(i).copied().unwrap_or(0.0) - reference.get(i).copied().unwrap_or(0.0);
        (-d / g).clamp(-1.0, 1.0).asin().to_degrees()
    };
    Some((angle(0), angle(1)))
}
/// A tilt is let go inside this fraction of the dead zone.
const RELEASE_FRACTION: f64 = 0.75;

/// The head stage. Built once (allocates); [`Head::step`] is RT-safe.
#[derive(Debug, Clone)]
pub struct Head {
    config: HeadConfig,
    recognizer: Recognizer,
    names: [Option<GestureName>; MAX_GESTURES],
    /// The last sample and the tick it came.
    last: Option<(Tick, ImuSample)>,
    /// The tick the values last changed.
    changed_at: Tick,
    faulted: bool,
    /// In fault: since when the samples have been good.
    good_since: Option<Tick>,
    /// The acceleration, smoothed over [`TILT_SMOOTHING_TICKS`].
    smoothed: Option<[f64; 3]>,
    /// In a command mode: the gravity at rest when it began.
    reference: Option<[f64; 3]>,
    tilted: Option<Breath>,
    /// The last tick was in a command mode.
    commanding: bool,
}

impl Head {
    /// The head stage for `setup` under `config`, or every bad setting.
    pub fn new(setup: &GestureSetup, config: &HeadConfig) -> Result<Head, Vec<String>> {
        config.validate()?;
        let recognizer = Recognizer::new(setup.recognizer, setup.templates.clone())?;
        let mut names = [None; MAX_GESTURES];
        for (slot, name) in names.iter_mut().zip(&setup.names) {
            *slot = Some(*name);
        }
        Ok(Head {
            config: *config,
            recognizer,
            names,
            last: None,
            changed_at: 0,
            faulted: false,
            good_since: None,
            smoothed: None,
            reference: None,
            tilted: None,
            commanding: false,
        })
    }

    /// The IMU is in fault.
    pub fn is_faulted(&self) -> bool {
        self.faulted
    }

    /// The head as the display shows it; none in fault or before a
    /// sample. RT-safe.
    pub fn view(&self) -> Option<HeadView> {
        if self.faulted {
            return None;
        }
        let reference = self.reference.unwrap_or(self.recognizer.rest().gravity);
        let (pitch_deg, roll_deg) = pitch_and_roll(reference, self.smoothed?)?;
        Some(HeadView {
            pitch_deg,
            roll_deg,
            moving: self.recognizer.in_motion() && !self.commanding,
            tilted: self.commanding && self.tilted.is_some(),
        })
    }

    /// Tick `now` with the IMU's input; `commanding`: the interface is in a
    /// command mode (the tilt moves, gestures are not read). RT-safe.
    pub fn step(&mut self, now: Tick, input: ImuInput, commanding: bool) -> HeadOutput {
        let mut out = HeadOutput::default();
        let (sample, problem) = self.check(now, input);
        out.event = self.health(now, problem);
        if self.faulted {
            out.faulted = true;
            return out;
        }
        if self.commanding && !commanding {
            // Driving tilted and turned the head for as long as it took:
            // what the front end made of it is no gesture, and the rest
            // it tracked may be a held tilt. Selection starts afresh from
            // the head's posture as it is (the gyro's bias is kept).
            self.recognizer.restart();
        }
        self.commanding = commanding;
        let verdict = self.recognizer.step(now, sample.as_ref());
        out.in_motion = self.recognizer.in_motion();
        if let Some((_, held)) = self.last {
            smooth_tilt(&mut self.smoothed, held.acceleration());
        }
        if commanding {
            (out.tilt, out.speed_fraction) = self.tilt();
        } else {
            self.reference = None;
            self.tilted = None;
            out.gesture = verdict.map(|v| self.named(v));
        }
        out
    }

    /// The sample to use and what is wrong with the input, if anything.
    fn check(&mut self, now: Tick, input: ImuInput) -> (Option<ImuSample>, Option<FaultReason>) {
        match input {
            ImuInput::Lost => (None, Some(FaultReason::ImuDisconnected)),
            ImuInput::Sample(s) if !s.is_finite() => (None, Some(FaultReason::ImuNotFinite)),
            ImuInput::Sample(s) => {
                let same = self.last.is_some_and(|(_, last)| last == s);
                if !same {
                    self.changed_at = now;
                }
                self.last = Some((now, s));
                let unchanged = now.saturating_sub(self.changed_at);
                if same && unchanged >= u64::from(self.config.frozen_ms) {
                    (None, Some(FaultReason::ImuFrozen { ms: unchanged }))
                } else {
                    (Some(s), None)
                }
            }
            ImuInput::Missing => {
                let since = self
                    .last
                    .map_or(now.saturating_add(1), |(t, _)| now.saturating_sub(t));
                if since >= u64::from(self.config.stale_ms) {
                    (None, Some(FaultReason::ImuStale { ms: since }))
                } else {
                    (None, None)
                }
            }
        }
    }

    /// Into and out of fault: into at once, out after `recover_ms` of
    /// good samples (the rest is learnt anew).
    fn health(&mut self, now: Tick, problem: Option<FaultReason>) -> Option<HeadEvent> {
        match (self.faulted, problem) {
            (false, Some(reason)) => {
                self.faulted = true;
                self.good_since = None;
                self.recognizer.reset();
                self.smoothed = None;
                self.reference = None;
                self.tilted = None;
                if let FaultReason::ImuStale { .. } = reason {
                    // Counted anew: recovery needs fresh samples.
                    self.last = None;
                }
                Some(HeadEvent::Fault(reason))
            }
            (true, Some(_)) => {
                self.good_since = None;
                None
            }
            (true, None) => {
                let since = *self.good_since.get_or_insert(now);
                if now.saturating_sub(since) >= u64::from(self.config.recover_ms) {
                    self.faulted = false;
                    self.good_since = None;
                    Some(HeadEvent::Recovered)
                } else {
                    None
                }
            }
            (false, None) => None,
        }
    }

    /// The tilt past the dead zone against the rest at the command mode's
    /// start: the side (with hysteresis) and the fraction of full scale.
    fn tilt(&mut self) -> (Held, f64) {
        let nothing = (Held::default(), 0.0);
        if self.config.tilt == TiltAxis::Off {
            return nothing;
        }
        let reference = *self.reference.get_or_insert(self.recognizer.rest().gravity);
        let (Some(now), g) = (self.smoothed, norm3(reference)) else {
            return nothing;
        };
        if g <= 0.0 {
            return nothing;
        }
        let d = |i: usize| {
            (now.get(i).copied().unwrap_or(0.0) - reference.get(i).copied().unwrap_or(0.0)) / g
        };
        // Chin down turns gravity towards -x; the left ear down towards -y.
        let sine = match self.config.tilt {
            TiltAxis::Pitch => -d(0),
            TiltAxis::Roll => -d(1),
            TiltAxis::Off => 0.0,
        };
        let angle = sine.clamp(-1.0, 1.0).asin().to_degrees();
        let dead = self.config.dead_zone_deg;
        let release = dead * RELEASE_FRACTION;
        self.tilted = match self.tilted {
            Some(Breath::Puff) if angle > release => Some(Breath::Puff),
            Some(Breath::Sip) if angle < -release => Some(Breath::Sip),
            _ if angle > dead => Some(Breath::Puff),
            _ if angle < -dead => Some(Breath::Sip),
            _ => None,
        };
        let Some(side) = self.tilted else {
            return nothing;
        };
        let fraction = ((angle.abs() - dead) / (self.config.full_scale_deg - dead)).clamp(0.0, 1.0);
        (
            Held {
                breath: Some(side),
                strength_volts: 0.0,
            },
            fraction,
        )
    }

    /// A recognizer's verdict with the gestures' names.
    fn named(&self, verdict: GestureEvent) -> HeadGesture {
        let name = |id: GestureId| self.names.get(usize::from(id.0)).copied().flatten();
        match verdict {
            GestureEvent::Recognised { gesture, start, .. } => match name(gesture) {
                Some(name) => HeadGesture::Recognised { name, start },
                None => HeadGesture::Rejected {
                    nearest: None,
                    why: RejectReason::AboveThreshold,
                },
            },
            GestureEvent::Rejected { nearest, why, .. } => HeadGesture::Rejected {
                nearest: nearest.and_then(name),
                why,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::gesture::features::GRAVITY;

    fn head() -> Head {
        Head::new(
            &GestureSetup {
                names: vec![],
                recognizer: GestureConfig::default(),
                templates: GestureTemplates::new(),
                channels: Channels::ALL,
            },
            &HeadConfig::default(),
        )
        .unwrap()
    }

    /// A still head pitched `degrees` (chin down positive), with a sample
    /// that changes by a hair each tick (a live sensor's noise).
    fn pitched(degrees: f64, tick: Tick) -> ImuInput {
        let (s, c) = degrees.to_radians().sin_cos();
        let hair = if tick.is_multiple_of(2) { 0.0 } else { 1e-6 };
        ImuInput::Sample(ImuSample {
            values: [-GRAVITY * s, 0.0, GRAVITY * c, hair, 0.0, 0.0],
        })
    }

    /// Holds `degrees` from `from` for `ms`, commanding; the last output.
    fn hold(h: &mut Head, degrees: f64, from: Tick, ms: u64) -> HeadOutput {
        let mut out = HeadOutput::default();
        for t in from..from + ms {
            out = h.step(t, pitched(degrees, t), true);
        }
        out
    }

    /// The head pitched along a smooth move from `from` to `to` degrees
    /// over `ms` ticks starting at `start`, at tick `t`: gravity and the
    /// pitch rate as a worn IMU reads them.
    fn pitching(from: f64, to: f64, start: Tick, ms: u64, t: Tick) -> ImuInput {
        let tau = ((t.saturating_sub(start)) as f64 / ms as f64).clamp(0.0, 1.0);
        let shape = 0.5 - 0.5 * (std::f64::consts::PI * tau).cos();
        let degrees = from + (to - from) * shape;
        let rate = (to - from).to_radians()
            * 0.5
            * std::f64::consts::PI
            * (std::f64::consts::PI * tau).sin()
            / (ms as f64 / 1000.0);
        let ImuInput::Sample(mut s) = pitched(degrees, t) else {
            unreachable!()
        };
        s.values[4] = rate;
        ImuInput::Sample(s)
    }

    /// A person drives with their chin down for 6 s, brings the head back
    /// and rests until the mode ends; the front end then reads the next
    /// movement from the head's rest as it is, as when the session began:
    /// nothing under way when selection begins, and a nod made at once is
    /// a movement of its own length, not one too long.
    #[test]
    fn selection_after_driving_reads_movements_from_the_head_at_rest() {
        let mut t = 3000;
        let mut h = head();
        for t0 in 0..3000 {
            h.step(t0, pitched(0.0, t0), false);
        }
        for (from, to, ms) in [
            (0.0, 20.0, 400),
            (20.0, 20.0, 6000),
            (20.0, 0.0, 400),
            (0.0, 0.0, 2000),
        ] {
            let start = t;
            for _ in 0..ms {
                h.step(t, pitching(from, to, start, ms, t), true);
                t += 1;
            }
        }
        let out = h.step(t, pitched(0.0, t), false);
        assert!(!out.in_motion, "under way when selection begins, at {t}");
        // A nod at once: down 15° and back in 600 ms.
        let start = t + 1;
        let mut ended = None;
        for now in start..start + 2000 {
            let input = if now < start + 300 {
                pitching(0.0, 15.0, start, 300, now)
            } else {
                pitching(15.0, 0.0, start + 300, 300, now)
            };
            if let Some(g) = h.step(now, input, false).gesture {
                ended = Some((now, g));
                break;
            }
        }
        let (now, gesture) = ended.expect("the nod never ended");
        assert!(
            !matches!(
                gesture,
                HeadGesture::Rejected {
                    why: RejectReason::TooLong,
                    ..
                }
            ),
            "{gesture:?}"
        );
        assert!(
            now - start < 1200,
            "ended {} ms after it began",
            now - start
        );
    }

    #[test]
    fn a_tilt_moves_past_the_dead_zone_in_proportion_and_lets_go_inside_three_quarters() {
        let mut h = head();
        for t in 0..2000 {
            h.step(t, pitched(0.0, t), false);
        }
        // 10°: inside the 12° dead zone.
        assert_eq!(hold(&mut h, 10.0, 2000, 2000).tilt.breath, None);
        // 21°: half way from 12° to the 30° full scale.
        let out = hold(&mut h, 21.0, 4000, 2000);
        assert_eq!(out.tilt.breath, Some(Breath::Puff));
        assert!(
            (out.speed_fraction - 0.5).abs() < 1e-3,
            "{}",
            out.speed_fraction
        );
        // 10° after it: held still (let go below 9°), at no speed.
        let out = hold(&mut h, 10.0, 6000, 2000);
        assert_eq!(
            (out.tilt.breath, out.speed_fraction),
            (Some(Breath::Puff), 0.0)
        );
        assert_eq!(hold(&mut h, 8.0, 8000, 2000).tilt.breath, None);
        // Chin up past it, beyond full scale: the other way, capped.
        let out = hold(&mut h, -40.0, 10_000, 2000);
        assert_eq!(
            (out.tilt.breath, out.speed_fraction),
            (Some(Breath::Sip), 1.0)
        );
        // Out of the command mode: no tilt is read.
        assert_eq!(
            h.step(12_000, pitched(-40.0, 12_000), false).tilt,
            Held::default()
        );
    }

    #[test]
    fn the_imu_faults_when_silent_frozen_not_finite_or_gone_and_recovers_on_fresh_samples() {
        let mut h = head();
        for t in 0..1000 {
            h.step(t, pitched(0.0, t), false);
        }
        // Silent: the fault 100 ms after the last sample.
        for t in 1000..1099 {
            assert_eq!(h.step(t, ImuInput::Missing, false).event, None);
        }
        let out = h.step(1099, ImuInput::Missing, false);
        assert_eq!(
            out.event,
            Some(HeadEvent::Fault(FaultReason::ImuStale { ms: 100 }))
        );
        // Back 300 ms after fresh samples begin.
        for t in 1200..1500 {
            let out = h.step(t, pitched(0.0, t), false);
            assert!(out.faulted && out.event.is_none(), "{t}");
        }
        assert_eq!(
            h.step(1500, pitched(0.0, 1500), false).event,
            Some(HeadEvent::Recovered)
        );
        for t in 1501..2000 {
            h.step(t, pitched(0.0, t), false);
        }
        // Frozen: the same six values for 1000 ms.
        let still = pitched(0.0, 0);
        for t in 2000..3000 {
            assert_eq!(h.step(t, still, false).event, None, "{t}");
        }
        assert_eq!(
            h.step(3000, still, false).event,
            Some(HeadEvent::Fault(FaultReason::ImuFrozen { ms: 1000 }))
        );
        for t in 3001..=3301 {
            h.step(t, pitched(0.0, t), false);
        }
        assert!(!h.is_faulted());
        let nan = ImuInput::Sample(ImuSample {
            values: [f64::NAN; 6],
        });
        assert_eq!(
            h.step(3302, nan, false).event,
            Some(HeadEvent::Fault(FaultReason::ImuNotFinite))
        );
        for t in 3303..=3603 {
            h.step(t, pitched(0.0, t), false);
        }
        assert!(!h.is_faulted());
        assert_eq!(
            h.step(3604, ImuInput::Lost, false).event,
            Some(HeadEvent::Fault(FaultReason::ImuDisconnected))
        );
    }
}
