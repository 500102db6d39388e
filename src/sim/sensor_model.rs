//! Seeded synthetic sip-and-puff signals: a script of breaths, rests and
//! dropouts turned into one voltage sample per millisecond, with the
//! imperfections of a real sensor and a real user.
//!
//! Each breath rises and falls along a raised-cosine ramp of 30–80 ms
//! (drawn per breath), with tremor on the plateau. The ramps are placed so
//! that, without noise, the detector measures exactly the scripted
//! duration: the signal crosses the start threshold half a sample before
//! the breath's first tick and the end level (threshold minus hysteresis)
//! half a sample before its last tick + 1. On top: Gaussian noise, 50 or
//! 60 Hz hum, a person's tremor (at rest and on breaths, waxing and
//! waning), slow sinusoidal drift of the neutral, single-sample spikes to
//! the rails, clipping to the sensor's 0–5 V and a converter's rounding.
//!
//! The generator is an iterator that never allocates as it plays, so a
//! real-time loop may use it as its sensor (`sim::synthetic_sensor`). It
//! borrows or owns its script; a live generator owns a script its caller
//! extends as it plays (the study's simulated users). The scripts
//! themselves are in [`super::script`].

use std::borrow::Cow;
use std::f64::consts::PI;
use std::io::Write;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use crate::control::action::Breath;
use crate::control::detector::DetectorConfig;
use crate::control::mode::Direction;

/// One step of a script.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// A breath the detector should measure as exactly `ms` long.
    Breath {
        /// Sip or puff.
        breath: Breath,
        /// Time past the threshold, in ms.
        ms: u32,
    },
    /// Rest at the neutral.
    Rest {
        /// Length in ms.
        ms: u32,
    },
    /// The sensor returns NaN (e.g. an unplugged ADC).
    Dropout {
        /// Length in ms.
        ms: u32,
    },
}

/// Where the detector's levels are, relative to the neutral, in volts (all
/// positive): breaths are shaped to cross them at exact times.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Crossings {
    /// A puff starts above neutral + this.
    pub puff_on: f64,
    /// A puff ends below neutral + this.
    pub puff_off: f64,
    /// A sip starts below neutral − this.
    pub sip_on: f64,
    /// A sip ends above neutral − this.
    pub sip_off: f64,
}

impl Crossings {
    /// The levels of a detector configuration.
    pub fn of(d: &DetectorConfig) -> Self {
        let puff_on = d.puff_threshold_volts - d.neutral_volts;
        let sip_on = d.neutral_volts - d.sip_threshold_volts;
        Crossings {
            puff_on,
            puff_off: puff_on - d.hysteresis_of(Breath::Puff),
            sip_on,
            sip_off: sip_on - d.hysteresis_of(Breath::Sip),
        }
    }
}

/// A person's tremor: a sine on the whole signal, at rest and on every
/// breath, its amplitude waxing and waning.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Tremor {
    /// Largest amplitude, volts (0: none).
    pub volts: f64,
    /// Frequency, Hz.
    pub hz: f64,
    /// Period of the waxing and waning, ms: the amplitude swings between
    /// [`Tremor::WANING`] and 1 × `volts` (0: steady).
    pub waxing_ms: f64,
}

impl Tremor {
    /// No tremor.
    pub const NONE: Tremor = Tremor {
        volts: 0.0,
        hz: 6.0,
        waxing_ms: 0.0,
    };

    /// The smallest amplitude of a waxing and waning tremor, as a fraction
    /// of its largest.
    pub const WANING: f64 = 0.4;

    /// The tremor's volts at `t` ms.
    pub fn at(&self, t: f64) -> f64 {
        if self.volts == 0.0 {
            return 0.0;
        }
        let envelope = if self.waxing_ms > 0.0 {
            let swing = (1.0 - (2.0 * PI * t / self.waxing_ms).cos()) / 2.0;
            Self::WANING + (1.0 - Self::WANING) * swing
        } else {
            1.0
        };
        self.volts * envelope * (2.0 * PI * self.hz * t / 1000.0).sin()
    }
}

/// Range of a breath's rise (and fall) time, in ms.
pub const DEFAULT_RAMP_MS: (f64, f64) = (30.0, 80.0);

/// Everything about the synthetic sensor and user except the script.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SignalParams {
    /// Seed of the random generator: same seed, same signal.
    pub seed: u64,
    /// Neutral (resting) voltage.
    pub neutral_volts: f64,
    /// Detector levels the breaths are shaped to cross exactly.
    pub crossings: Crossings,
    /// Mean plateau height of a breath above (puff) or below (sip) the
    /// neutral, in volts; of puffs only when `sip_volts` is set.
    pub breath_volts: f64,
    /// Mean plateau height of a sip below the neutral, in volts, when it
    /// differs from a puff's (a user who blows harder than they suck);
    /// `None`: `breath_volts`.
    pub sip_volts: Option<f64>,
    /// Each breath's height varies uniformly by ± this fraction.
    pub breath_jitter: f64,
    /// Ramp (rise and fall) time range, in ms.
    pub ramp_ms: (f64, f64),
    /// Tremor amplitude on the plateau, in volts (at 8 Hz).
    pub tremor_volts: f64,
    /// Slow wander of a held breath's plateau, in volts (a 0.5 Hz sine of
    /// random phase per breath): nobody holds a pressure perfectly level
    /// for seconds, and the detector's re-zeroing relies on it.
    pub wander_volts: f64,
    /// Standard deviation of white Gaussian noise, in volts.
    pub noise_volts: f64,
    /// Amplitude of mains hum, in volts.
    pub hum_volts: f64,
    /// Frequency of the mains hum, Hz (50 or 60).
    pub hum_hz: f64,
    /// The person's tremor, on the whole signal (rest and breaths).
    pub body_tremor: Tremor,
    /// The sensor's converter: samples are rounded to one of 2^bits levels
    /// over 0–5 V (0: not rounded).
    pub adc_bits: u32,
    /// Amplitude of the neutral's slow sinusoidal drift, in volts.
    pub drift_volts: f64,
    /// Period of the drift, in ms.
    pub drift_period_ms: f64,
    /// One sample every this many ms jumps to a rail (0 or 5 V,
    /// alternately); 0 = no spikes.
    pub spike_every_ms: u64,
}

impl SignalParams {
    /// A clean signal for a detector configuration: realistic ramps and
    /// tremor, no noise, hum, drift or spikes.
    pub fn clean(detector: &DetectorConfig, seed: u64) -> Self {
        SignalParams {
            seed,
            neutral_volts: detector.neutral_volts,
            crossings: Crossings::of(detector),
            breath_volts: 1.2,
            sip_volts: None,
            breath_jitter: 0.15,
            ramp_ms: DEFAULT_RAMP_MS,
            tremor_volts: 0.03,
            wander_volts: 0.0,
            noise_volts: 0.0,
            hum_volts: 0.0,
            hum_hz: 50.0,
            body_tremor: Tremor::NONE,
            adc_bits: 0,
            drift_volts: 0.0,
            drift_period_ms: 60_000.0,
            spike_every_ms: 0,
        }
    }
}

impl SignalParams {
    /// With white Gaussian noise of this standard deviation, volts.
    pub fn with_noise(self, noise_volts: f64) -> Self {
        SignalParams {
            noise_volts,
            ..self
        }
    }

    /// With held breaths wandering by this amplitude, volts (0.5 Hz).
    pub fn with_wander(self, wander_volts: f64) -> Self {
        SignalParams {
            wander_volts,
            ..self
        }
    }

    /// With sips of this mean height below the neutral, volts (puffs keep
    /// `breath_volts`).
    pub fn with_sip_volts(self, sip_volts: f64) -> Self {
        SignalParams {
            sip_volts: Some(sip_volts),
            ..self
        }
    }

    /// Mean plateau height of this breath, volts from the neutral.
    pub fn mean_volts(&self, breath: Breath) -> f64 {
        match breath {
            Breath::Puff => self.breath_volts,
            Breath::Sip => self.sip_volts.unwrap_or(self.breath_volts),
        }
    }

    /// With mains hum of this amplitude, volts (at `hum_hz`, 50 Hz unless
    /// changed).
    pub fn with_hum(self, hum_volts: f64) -> Self {
        SignalParams { hum_volts, ..self }
    }

    /// With the neutral drifting sinusoidally by this amplitude, volts
    /// (over `drift_period_ms`, one minute unless changed).
    pub fn with_drift(self, drift_volts: f64) -> Self {
        SignalParams {
            drift_volts,
            ..self
        }
    }

    /// With a one-sample spike to a rail every this many ms.
    pub fn with_spikes_every(self, spike_every_ms: u64) -> Self {
        SignalParams {
            spike_every_ms,
            ..self
        }
    }
}

/// The shape of the breath being played.
#[derive(Debug, Clone, Copy)]
struct Shape {
    /// +1 puff, −1 sip.
    sign: f64,
    height: f64,
    ramp: f64,
    plateau: f64,
    /// Time (ms, from the step's first sample) the rise begins.
    rise_at: f64,
    /// Samples in the step.
    len: u64,
    /// Index (in the step) of the first sample past the threshold.
    first: u64,
}

impl Shape {
    /// Places a breath so the detector sees exactly `ms` past the threshold.
    fn new(p: &SignalParams, breath: Breath, ms: u32, height: f64, ramp: f64) -> Shape {
        let (on, off) = match breath {
            Breath::Puff => (p.crossings.puff_on, p.crossings.puff_off),
            Breath::Sip => (p.crossings.sip_on, p.crossings.sip_off),
        };
        // Fractions of the ramp at which the rise crosses `on` and the fall
        // crosses `off`.
        let a_on = (1.0 - 2.0 * on / height).clamp(-1.0, 1.0).acos() / PI;
        let a_off = (2.0 * off / height - 1.0).clamp(-1.0, 1.0).acos() / PI;
        let d = f64::from(ms);
        let above_in_ramps = ramp * (1.0 - a_on + a_off);
        let (ramp, plateau) = if above_in_ramps <= d {
            (ramp, d - above_in_ramps)
        } else {
            (d / (1.0 - a_on + a_off), 0.0) // short breath: quicker ramps
        };
        let t_on = a_on * ramp;
        // First sample past `on` is `first`; the crossing is half a sample
        // before it.
        let first = (t_on + 0.5).ceil();
        let rise_at = first - 0.5 - t_on;
        let end = rise_at + 2.0 * ramp + plateau;
        Shape {
            sign: Direction::of(breath).sign(),
            height,
            ramp,
            plateau,
            rise_at,
            len: end.ceil() as u64 + 1,
            first: first as u64,
        }
    }

    /// Volts above the neutral (signed) at time `t` ms into the step, and
    /// whether `t` is on the plateau.
    fn at(&self, t: f64) -> (f64, bool) {
        let u = t - self.rise_at;
        let fraction = if u <= 0.0 {
            0.0
        } else if u < self.ramp {
            (1.0 - (PI * u / self.ramp).cos()) / 2.0
        } else if u <= self.ramp + self.plateau {
            return (self.sign * self.height, true);
        } else if u < 2.0 * self.ramp + self.plateau {
            (1.0 + (PI * (u - self.ramp - self.plateau) / self.ramp).cos()) / 2.0
        } else {
            0.0
        };
        (self.sign * self.height * fraction, false)
    }
}

/// A breath as the script places it: where the detector should see it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ScriptedBreath {
    /// Sip or puff.
    pub breath: Breath,
    /// First sample past the threshold (the burst's `start`).
    pub start: u64,
    /// Time past the threshold, in ms (the burst's `end − start`).
    pub ms: u32,
}

/// Plays a script as samples, one per ms. Never allocates.
pub struct SignalGenerator<'a> {
    params: SignalParams,
    script: Cow<'a, [Step]>,
    rng: ChaCha8Rng,
    noise: Option<Normal<f64>>,
    step: usize,
    /// Sample index within the current step.
    at: u64,
    shape: Option<Shape>,
    /// Global sample index.
    tick: u64,
    spikes: u64,
    /// The breath of the current step, if it is one.
    breath: Option<ScriptedBreath>,
    /// Phase of the current breath's wander, radians.
    wander_phase: f64,
}

impl<'a> SignalGenerator<'a> {
    /// A generator over `script`.
    pub fn new(params: SignalParams, script: &'a [Step]) -> Self {
        let noise = (params.noise_volts > 0.0)
            .then(|| Normal::new(0.0, params.noise_volts).ok())
            .flatten();
        let mut g = SignalGenerator {
            params,
            script: Cow::Borrowed(script),
            rng: ChaCha8Rng::seed_from_u64(params.seed),
            noise,
            step: 0,
            at: 0,
            shape: None,
            tick: 0,
            spikes: 0,
            breath: None,
            wander_phase: 0.0,
        };
        g.enter_step();
        g
    }

    fn enter_step(&mut self) {
        self.at = 0;
        self.shape = match self.script.get(self.step) {
            Some(&Step::Breath { breath, ms }) => {
                let p = &self.params;
                let jitter = self.rng.random_range(-1.0..=1.0) * p.breath_jitter;
                let height = p.mean_volts(breath) * (1.0 + jitter);
                let ramp = self.rng.random_range(p.ramp_ms.0..=p.ramp_ms.1);
                let shape = Shape::new(p, breath, ms, height, ramp);
                // Drawn only when used: a signal without wander draws the
                // same numbers for a seed as if the option did not exist.
                if p.wander_volts > 0.0 {
                    self.wander_phase = self.rng.random_range(0.0..2.0 * PI);
                }
                self.breath = Some(ScriptedBreath {
                    breath,
                    start: self.tick + shape.first,
                    ms,
                });
                Some(shape)
            }
            _ => None,
        };
    }

    /// A generator that owns its script.
    pub fn owned(params: SignalParams, script: Vec<Step>) -> SignalGenerator<'static> {
        let mut g = SignalGenerator::new(params, &[]).into_owned();
        g.script = Cow::Owned(script);
        g.rewind();
        g
    }

    /// A generator with an empty script that the caller extends as it
    /// plays: a simulated user who reacts to what the interface does.
    /// Adding steps allocates: not for the control thread.
    pub fn live(params: SignalParams) -> SignalGenerator<'static> {
        SignalGenerator::new(params, &[]).into_owned()
    }

    /// Starts the script again from its first sample, exactly as a new
    /// generator would play it. Allocates nothing: a real-time loop may
    /// repeat a script (`bench latency`).
    pub fn rewind(&mut self) {
        self.rng = ChaCha8Rng::seed_from_u64(self.params.seed);
        self.step = 0;
        self.at = 0;
        self.shape = None;
        self.tick = 0;
        self.spikes = 0;
        self.breath = None;
        self.enter_step();
    }

    fn into_owned(self) -> SignalGenerator<'static> {
        SignalGenerator {
            script: Cow::Owned(self.script.into_owned()),
            params: self.params,
            rng: self.rng,
            noise: self.noise,
            step: self.step,
            at: self.at,
            shape: self.shape,
            tick: self.tick,
            spikes: self.spikes,
            breath: self.breath,
            wander_phase: self.wander_phase,
        }
    }

    /// Appends a step; a generator that had run out plays it next.
    pub fn push(&mut self, step: Step) {
        let ran_out = self.step >= self.script.len();
        self.script.to_mut().push(step);
        if ran_out {
            self.enter_step();
        }
    }

    /// The script so far (for a live generator, every step pushed).
    pub fn script(&self) -> &[Step] {
        &self.script
    }

    /// Samples played so far.
    pub fn tick(&self) -> u64 {
        self.tick
    }

    /// The last breath the script has begun to play (its step may already
    /// be over): a scorer reads it after each sample to learn where every
    /// scripted burst lies.
    pub fn scripted_breath(&self) -> Option<ScriptedBreath> {
        self.breath
    }

    fn step_len(&self) -> u64 {
        match self.script.get(self.step) {
            Some(Step::Breath { .. }) => self.shape.map_or(0, |s| s.len),
            Some(Step::Rest { ms } | Step::Dropout { ms }) => (*ms).into(),
            None => 0,
        }
    }
}

impl Iterator for SignalGenerator<'_> {
    type Item = f64;

    fn next(&mut self) -> Option<f64> {
        while self.at >= self.step_len() {
            if self.step >= self.script.len() {
                return None;
            }
            self.step += 1;
            self.enter_step();
        }
        let p = self.params;
        let t = self.tick as f64;
        let dropout = matches!(self.script.get(self.step), Some(Step::Dropout { .. }));
        let (breath, on_plateau) = self.shape.map_or((0.0, false), |s| s.at(self.at as f64));
        self.at += 1;
        self.tick += 1;

        let tremor = if on_plateau {
            let sign = self.shape.map_or(0.0, |s| s.sign);
            let wander_t = 2.0 * PI * 0.5 * self.at as f64 / 1000.0 + self.wander_phase;
            p.tremor_volts * (2.0 * PI * 8.0 * t / 1000.0).sin()
                + sign * p.wander_volts * wander_t.sin()
        } else {
            0.0
        };
        let hum = p.hum_volts * (2.0 * PI * p.hum_hz * t / 1000.0).sin();
        let drift = p.drift_volts * (2.0 * PI * t / p.drift_period_ms).sin();
        let noise = self.noise.map_or(0.0, |n| n.sample(&mut self.rng));
        let mut volts =
            p.neutral_volts + drift + breath + tremor + hum + noise + p.body_tremor.at(t);
        if p.adc_bits > 0 {
            volts = quantised(volts, p.adc_bits);
        }
        if p.spike_every_ms > 0 && (self.tick - 1) % p.spike_every_ms == p.spike_every_ms / 2 {
            self.spikes += 1;
            volts = if self.spikes.is_multiple_of(2) {
                0.0
            } else {
                5.0
            };
        }
        Some(if dropout {
            f64::NAN
        } else {
            volts.clamp(0.0, 5.0)
        })
    }
}

/// `volts` as a converter of `bits` over 0–5 V reads it: the nearest of
/// its 2^bits levels.
fn quantised(volts: f64, bits: u32) -> f64 {
    let top = f64::from((1u32 << bits.min(24)) - 1);
    (volts.clamp(0.0, 5.0) / 5.0 * top).round() / top * 5.0
}

/// Writes samples as CSV with a `tick,volts` header (volts to 0.1 mV).
pub fn write_csv(out: &mut impl Write, samples: impl Iterator<Item = f64>) -> std::io::Result<u64> {
    writeln!(out, "tick,volts")?;
    let mut n = 0;
    for (tick, volts) in samples.enumerate() {
        if volts.is_nan() {
            writeln!(out, "{tick},NaN")?;
        } else {
            writeln!(out, "{tick},{volts:.4}")?;
        }
        n += 1;
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::detector::{BurstDetector, DetectorEvent};
    use crate::control::sample::Sample;

    fn bursts(params: SignalParams, script: &[Step]) -> Vec<(Breath, u64, u64)> {
        let mut d = BurstDetector::new(&DetectorConfig::default());
        SignalGenerator::new(params, script)
            .enumerate()
            .filter_map(|(t, v)| match d.step(t as u64, Sample::Volts(v)).event {
                Some(DetectorEvent::Burst(b)) => {
                    Some((b.action.breath(), b.start, b.duration_ms()))
                }
                _ => None,
            })
            .collect()
    }

    #[test]
    fn clean_breaths_measure_exactly_as_scripted() {
        let c = DetectorConfig::default();
        for seed in 0..20 {
            for ms in [40, 41, 45, 60, 150, 499, 500, 501, 2000] {
                for breath in [Breath::Puff, Breath::Sip] {
                    let script = [
                        Step::Rest { ms: 100 },
                        Step::Breath { breath, ms },
                        Step::Rest { ms: 100 },
                    ];
                    let found = bursts(SignalParams::clean(&c, seed), &script);
                    assert_eq!(found.len(), 1, "seed {seed}, {ms} ms {breath:?}");
                    assert_eq!(found[0].0, breath);
                    assert_eq!(found[0].2, u64::from(ms), "seed {seed} {breath:?}");
                }
            }
        }
    }

    #[test]
    fn same_seed_same_signal() {
        let c = DetectorConfig::default();
        let mut p = SignalParams::clean(&c, 7);
        p.noise_volts = 0.05;
        p.hum_volts = 0.1;
        p.spike_every_ms = 100;
        let script = [
            Step::Breath {
                breath: Breath::Puff,
                ms: 800,
            },
            Step::Rest { ms: 300 },
            Step::Breath {
                breath: Breath::Sip,
                ms: 150,
            },
            Step::Rest { ms: 300 },
        ];
        let a: Vec<f64> = SignalGenerator::new(p, &script).collect();
        let b: Vec<f64> = SignalGenerator::new(p, &script).collect();
        assert_eq!(a, b);
        // An owned generator, and one rewound after playing, are the same.
        let mut owned = SignalGenerator::owned(p, script.to_vec());
        assert_eq!(owned.by_ref().collect::<Vec<_>>(), a);
        owned.rewind();
        assert_eq!(owned.collect::<Vec<_>>(), a);
        p.seed = 8;
        let c: Vec<f64> = SignalGenerator::new(p, &script).collect();
        assert_ne!(a, c);
        assert!(a.iter().all(|v| (0.0..=5.0).contains(v)));
    }

    #[test]
    fn sips_may_have_their_own_height_and_nothing_else_changes() {
        let c = DetectorConfig::default();
        let script = [
            Step::Rest { ms: 50 },
            Step::Breath {
                breath: Breath::Puff,
                ms: 300,
            },
            Step::Rest { ms: 100 },
            Step::Breath {
                breath: Breath::Sip,
                ms: 300,
            },
            Step::Rest { ms: 100 },
        ];
        let p = SignalParams::clean(&c, 4).with_noise(0.01);
        let same: Vec<f64> = SignalGenerator::new(p, &script).collect();
        let explicit: Vec<f64> =
            SignalGenerator::new(p.with_sip_volts(p.breath_volts), &script).collect();
        assert_eq!(same, explicit);
        let weak_sips: Vec<f64> = SignalGenerator::new(p.with_sip_volts(0.8), &script).collect();
        // Puffs (and the random draws) as before: the sip starts after
        // 50 + 300 + 100 samples at the earliest. Sips shallower by a third.
        assert_eq!(weak_sips[..450], same[..450]);
        let depth = |s: &[f64]| s.iter().fold(0.0_f64, |m, v| m.max(2.5 - v));
        let ratio = depth(&weak_sips) / depth(&same);
        assert!((ratio - 2.0 / 3.0).abs() < 0.05, "{ratio}");
        assert_eq!(bursts(p.with_sip_volts(0.8), &script).len(), 2);
    }

    #[test]
    fn dropouts_are_nan_and_spikes_hit_the_rails() {
        let c = DetectorConfig::default();
        let mut p = SignalParams::clean(&c, 1);
        p.spike_every_ms = 100;
        let script = [Step::Rest { ms: 300 }, Step::Dropout { ms: 5 }];
        let s: Vec<f64> = SignalGenerator::new(p, &script).collect();
        assert_eq!(s.len(), 305);
        assert_eq!((s[50], s[150], s[250]), (5.0, 0.0, 5.0));
        assert!(s[300..].iter().all(|v| v.is_nan()));
    }
}
