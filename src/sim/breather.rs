//! Simulated people with known breathing, for calibration: each
//! [`Breather`] has true parameters (rest level, noise, tremor, drift, how
//! hard and how long they puff and sip), breathes the calibration protocol
//! or ordinary use through the synthetic sensor, and says exactly where
//! every breath lies, so a fit can be scored on how well it recovers them.
//!
//! The length of a breath is measured where the user means it, not where
//! some detector happens to be set: a breath starts when it passes
//! [`ON_FRACTION`] of its kind's mean height and ends when it falls back
//! past that level by [`HYSTERESIS_FRACTION`] of the weaker kind's mean
//! height (one hysteresis for both kinds, as a detector has). For a user
//! whose puffs and sips are equally strong that is on at 0.4× and off at
//! 0.3× the height. The sensor model shapes each breath to cross those
//! levels at exactly its scripted length ([`Breather::crossings`]).

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Serialize, Serializer};

use crate::control::action::{Action, ActionSeq, Breath};
use crate::control::detector::DetectorConfig;
use crate::control::mode::Mode;
use crate::control::selection::SequenceEntry;
use crate::control::target::Target;
use crate::fit::protocol::{Ask, BETWEEN_BLOCKS_MS, BETWEEN_BREATHS_MS, Protocol, REST_MS};
use crate::sim::sensor_model::{
    Crossings, DEFAULT_RAMP_MS, ScriptedBreath, SignalGenerator, SignalParams, Step, Tremor,
};

/// Each breath's length and strength vary uniformly by ± this fraction of
/// the breather's mean; so do the gaps within a sequence.
pub const VARIATION: f64 = 0.3;
/// Each longest comfortable hold varies uniformly by ± this fraction of
/// the breather's [`Breather::hold_ms`].
pub const HOLD_VARIATION: f64 = 0.1;
/// A breath truly starts where it passes this fraction of its kind's mean
/// height.
pub const ON_FRACTION: f64 = 0.4;
/// A breath truly ends where it falls back past its start level by this
/// fraction of the smaller of the two mean heights.
pub const HYSTERESIS_FRACTION: f64 = 0.1;

/// A protocol session's first rest, ms: at least the protocol's.
pub const PROTOCOL_START_MS: (u32, u32) = (REST_MS, REST_MS + 1000);
/// Rest between the breaths of a protocol block, ms.
pub const PROTOCOL_BREATH_GAP_MS: (u32, u32) = (BETWEEN_BREATHS_MS, 2 * BETWEEN_BREATHS_MS);
/// Rest between protocol blocks, ms.
pub const PROTOCOL_BLOCK_GAP_MS: (u32, u32) = (BETWEEN_BLOCKS_MS, BETWEEN_BLOCKS_MS + 1000);
/// Rest after a protocol session's last breath, ms.
pub const PROTOCOL_END_MS: u32 = 2000;
/// A practice session's first rest, ms.
pub const PRACTICE_START_MS: u32 = 2000;
/// Rest between the sequences of a practice session, ms.
pub const PRACTICE_SEQUENCE_GAP_MS: (u32, u32) = (1500, 3000);

/// A simulated person's breathing: the truth a calibration should
/// recover. Volts are at the sensor; times in ms.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Breather {
    /// Name of a built-in breather (`generate --breather`).
    pub name: &'static str,
    /// The sensor's level at rest.
    pub rest_volts: f64,
    /// Standard deviation of the white noise on the signal, at rest and
    /// during breaths.
    pub noise_volts: f64,
    /// Amplitude of the 8 Hz tremor on a breath's plateau.
    pub tremor_volts: f64,
    /// Amplitude of the rest level's slow sinusoidal drift.
    pub drift_volts: f64,
    /// Period of that drift.
    pub drift_period_ms: f64,
    /// Mean plateau height of a puff above the rest level.
    pub puff_volts: f64,
    /// Mean plateau height of a sip below the rest level.
    pub sip_volts: f64,
    /// Each breath's strength varies uniformly by ± this fraction of the
    /// mean.
    pub strength_spread: f64,
    /// A tremor on the whole signal, at rest and on every breath.
    pub body_tremor: Tremor,
    /// Amplitude of mains hum picked up by the sensor's wiring.
    pub hum_volts: f64,
    /// Its frequency, Hz.
    pub hum_hz: f64,
    /// The sensor's converter rounds to 2^bits levels over 0–5 V (0: not
    /// rounded).
    pub adc_bits: u32,
    /// One sample every this many ms jumps to a rail (0: never).
    pub spike_every_ms: u64,
    /// Mean length of a short breath (past the true start level).
    pub short_ms: u32,
    /// Mean length of a long breath.
    pub long_ms: u32,
    /// Mean rest between the breaths of a sequence.
    pub gap_ms: u32,
    /// Longest comfortable hold, the mean of the protocol's holds.
    pub hold_ms: u32,
}

/// Healthy and practised: the sensor model's usual user.
const TYPICAL: Breather = Breather {
    name: "typical",
    rest_volts: 2.5,
    noise_volts: 0.01,
    tremor_volts: 0.03,
    drift_volts: 0.02,
    drift_period_ms: 60_000.0,
    puff_volts: 1.2,
    sip_volts: 1.2,
    strength_spread: VARIATION,
    body_tremor: Tremor::NONE,
    hum_volts: 0.0,
    hum_hz: 50.0,
    adc_bits: 0,
    spike_every_ms: 0,
    short_ms: 150,
    long_ms: 800,
    gap_ms: 300,
    hold_ms: 4000,
};

/// A breath with a tremor (Parkinson's, MS, ALS, a weak diaphragm): the
/// oscillation is on the rest and rides on every breath; breaths of
/// 0.6–0.9 V.
const TREMBLING: Breather = Breather {
    name: "tremor_4hz",
    rest_volts: 2.45,
    noise_volts: 0.01,
    tremor_volts: 0.0,
    drift_volts: 0.01,
    puff_volts: 0.75,
    sip_volts: 0.75,
    strength_spread: 0.2,
    body_tremor: Tremor {
        volts: 0.25,
        hz: 4.0,
        waxing_ms: 9000.0,
    },
    ..TYPICAL
};

/// The built-in breathers, [`Breather::all`].
const BREATHERS: [Breather; 15] = [
    TYPICAL,
    // Little pressure either way.
    Breather {
        name: "weak",
        rest_volts: 2.35,
        drift_volts: 0.01,
        puff_volts: 0.4,
        sip_volts: 0.4,
        ..TYPICAL
    },
    // Little lung capacity: no breath over 800 ms (a long one at most
    // 600 ms × 1.3 = 780 ms, a hold 720 ms × 1.1 = 792 ms).
    Breather {
        name: "short_capacity",
        rest_volts: 2.65,
        short_ms: 200,
        long_ms: 600,
        hold_ms: 720,
        ..TYPICAL
    },
    // Everything takes longer: breaths and the gaps between them.
    Breather {
        name: "slow",
        rest_volts: 2.4,
        drift_volts: 0.03,
        drift_period_ms: 90_000.0,
        short_ms: 400,
        long_ms: 1500,
        gap_ms: 700,
        ..TYPICAL
    },
    // A shaky signal at rest and a trembling breath.
    Breather {
        name: "tremulous",
        rest_volts: 2.75,
        noise_volts: 0.08,
        tremor_volts: 0.1,
        drift_volts: 0.05,
        drift_period_ms: 45_000.0,
        ..TYPICAL
    },
    // Blows hard, sucks feebly.
    Breather {
        name: "asymmetric",
        rest_volts: 2.15,
        puff_volts: 1.8,
        sip_volts: 0.35,
        ..TYPICAL
    },
    // The rest shapes that real people and sensors give.
    // A strong 4 Hz tremor, ±0.25 V at its height.
    TREMBLING,
    // A 6 Hz tremor, ±0.18 V at its height.
    Breather {
        name: "tremor_6hz",
        rest_volts: 2.55,
        body_tremor: Tremor {
            volts: 0.18,
            hz: 6.0,
            waxing_ms: 6000.0,
        },
        ..TREMBLING
    },
    // A 9 Hz tremor, ±0.12 V at its height.
    Breather {
        name: "tremor_9hz",
        rest_volts: 2.6,
        body_tremor: Tremor {
            volts: 0.12,
            hz: 9.0,
            waxing_ms: 5000.0,
        },
        ..TREMBLING
    },
    // Mains hum in the sensor's wiring, 50 Hz (Europe).
    Breather {
        name: "hum_50hz",
        rest_volts: 2.3,
        hum_volts: 0.15,
        hum_hz: 50.0,
        ..TYPICAL
    },
    // Mains hum, 60 Hz (the Americas).
    Breather {
        name: "hum_60hz",
        rest_volts: 2.7,
        hum_volts: 0.15,
        hum_hz: 60.0,
        ..TYPICAL
    },
    // A cheap 8-bit converter: 19.6 mV steps, weak breaths.
    Breather {
        name: "adc_8bit",
        rest_volts: 2.2,
        noise_volts: 0.004,
        puff_volts: 0.6,
        sip_volts: 0.6,
        adc_bits: 8,
        ..TYPICAL
    },
    // A 10-bit converter (an Arduino's): 4.9 mV steps, weak breaths.
    Breather {
        name: "adc_10bit",
        rest_volts: 2.8,
        noise_volts: 0.004,
        puff_volts: 0.6,
        sip_volts: 0.6,
        adc_bits: 10,
        ..TYPICAL
    },
    // A rest that wanders ±0.1 V over 40 s (a sensor warming, a tube
    // shifting).
    Breather {
        name: "wandering",
        rest_volts: 2.25,
        drift_volts: 0.1,
        drift_period_ms: 40_000.0,
        ..TYPICAL
    },
    // Isolated one-sample spikes to the rails, one every 2.5 s (a loose
    // connector).
    Breather {
        name: "spiky",
        rest_volts: 2.85,
        spike_every_ms: 2500,
        ..TYPICAL
    },
];

impl Breather {
    /// Every built-in breather: `typical`, `weak`, `short_capacity`,
    /// `slow`, `tremulous`, `asymmetric`, and the rest shapes
    /// `tremor_4hz`, `tremor_6hz`, `tremor_9hz`, `hum_50hz`, `hum_60hz`,
    /// `adc_8bit`, `adc_10bit`, `wandering`, `spiky`.
    pub fn all() -> &'static [Breather] {
        &BREATHERS
    }

    /// The built-in breather of this name.
    pub fn named(name: &str) -> Option<Breather> {
        BREATHERS.iter().find(|b| b.name == name).copied()
    }

    /// The same person without rest noise, drift, body tremor, hum,
    /// rounding or spikes (the plateau's tremor stays: it is far from the
    /// start and end levels), so a detector at the true crossings measures
    /// every breath exactly.
    pub fn noise_free(self) -> Breather {
        Breather {
            noise_volts: 0.0,
            drift_volts: 0.0,
            body_tremor: Tremor::NONE,
            hum_volts: 0.0,
            adc_bits: 0,
            spike_every_ms: 0,
            ..self
        }
    }

    /// The largest swing of the periodic parts at rest (body tremor and
    /// hum), volts.
    pub fn rest_swing_volts(&self) -> f64 {
        self.body_tremor.volts + self.hum_volts
    }

    /// Mean plateau height of this breath, volts from the rest level.
    pub fn mean_volts(&self, breath: Breath) -> f64 {
        match breath {
            Breath::Puff => self.puff_volts,
            Breath::Sip => self.sip_volts,
        }
    }

    /// Mean length of what a prompt asks for, ms.
    pub fn mean_ms(&self, ask: Ask) -> u32 {
        match ask {
            Ask::Breath(action) if action.is_long() => self.long_ms,
            Ask::Breath(_) => self.short_ms,
            Ask::Hold(_) => self.hold_ms,
        }
    }

    /// Where each breath truly starts and ends, volts from the rest level
    /// (see the module's documentation).
    pub fn crossings(&self) -> Crossings {
        let hysteresis = HYSTERESIS_FRACTION * self.puff_volts.min(self.sip_volts);
        let puff_on = ON_FRACTION * self.puff_volts;
        let sip_on = ON_FRACTION * self.sip_volts;
        Crossings {
            puff_on,
            puff_off: puff_on - hysteresis,
            sip_on,
            sip_off: sip_on - hysteresis,
        }
    }

    /// A detector set at the true crossings around the rest level: it
    /// measures every breath of a noise-free session at its true length.
    /// Its long-burst boundary is halfway between the longest short breath
    /// and the shortest long one, and its longest breath past every hold,
    /// so it also reads every breath's class right: one right answer, not
    /// necessarily the one a fit should find. Other settings are the
    /// defaults.
    pub fn true_detector(&self) -> DetectorConfig {
        let c = self.crossings();
        let longest_short = f64::from(self.short_ms) * (1.0 + VARIATION);
        let shortest_long = f64::from(self.long_ms) * (1.0 - VARIATION);
        let longest = f64::from(self.hold_ms.max(self.long_ms)) * (1.0 + VARIATION);
        let default = DetectorConfig::default();
        DetectorConfig {
            neutral_volts: self.rest_volts,
            puff_threshold_volts: self.rest_volts + c.puff_on,
            sip_threshold_volts: self.rest_volts - c.sip_on,
            hysteresis_volts: c.puff_on - c.puff_off,
            long_burst_ms: ((longest_short + shortest_long) / 2.0).round() as u32,
            max_hold_ms: default.max_hold_ms.max(longest.ceil() as u32 + 1000),
            ..default
        }
    }

    /// The sensor model playing this person: their rest level, noise,
    /// tremors, drift, hum, converter, spikes and heights (each breath's
    /// strength ± `strength_spread`), breaths shaped to the true
    /// crossings.
    pub fn signal_params(&self, seed: u64) -> SignalParams {
        SignalParams {
            seed,
            neutral_volts: self.rest_volts,
            crossings: self.crossings(),
            breath_volts: self.puff_volts,
            sip_volts: Some(self.sip_volts),
            breath_jitter: self.strength_spread,
            ramp_ms: DEFAULT_RAMP_MS,
            tremor_volts: self.tremor_volts,
            wander_volts: 0.0,
            noise_volts: self.noise_volts,
            hum_volts: self.hum_volts,
            hum_hz: self.hum_hz,
            body_tremor: self.body_tremor,
            adc_bits: self.adc_bits,
            drift_volts: self.drift_volts,
            drift_period_ms: self.drift_period_ms,
            spike_every_ms: self.spike_every_ms,
        }
    }

    /// One breath's length for a prompt, ms: the mean ± [`VARIATION`]
    /// (± [`HOLD_VARIATION`] for a hold), uniform.
    pub fn draw_ms(&self, ask: Ask, rng: &mut ChaCha8Rng) -> u32 {
        let spread = match ask {
            Ask::Breath(_) => VARIATION,
            Ask::Hold(_) => HOLD_VARIATION,
        };
        vary(self.mean_ms(ask), spread, rng)
    }
}

/// `mean` ± `spread` of it, uniform, rounded to the ms.
fn vary(mean: u32, spread: f64, rng: &mut ChaCha8Rng) -> u32 {
    (f64::from(mean) * rng.random_range(1.0 - spread..=1.0 + spread)).round() as u32
}

/// A uniform draw from an inclusive range of ms.
fn between(range: (u32, u32), rng: &mut ChaCha8Rng) -> u32 {
    rng.random_range(range.0..=range.1)
}

/// One breath of a protocol session, where it truly lies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct ProtocolBreath {
    /// What the prompt asked for (written as its words, "short puff").
    #[serde(rename = "kind")]
    pub ask: Ask,
    /// First tick past the true start level.
    #[serde(rename = "start_tick")]
    pub start: u64,
    /// Ticks (ms) from `start` to the first tick past the true end level.
    pub ms: u32,
}

/// One breath of a practice session, where it truly lies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct PracticeBreath {
    /// The action the user meant (written as its words, "short puff").
    #[serde(rename = "kind", serialize_with = "action_words")]
    pub action: Action,
    /// First tick past the true start level.
    #[serde(rename = "start_tick")]
    pub start: u64,
    /// Ticks (ms) from `start` to the first tick past the true end level.
    pub ms: u32,
}

fn action_words<S: Serializer>(action: &Action, serializer: S) -> Result<S::Ok, S::Error> {
    serializer.collect_str(action)
}

/// A simulated session: what to play through the sensor model and where
/// every breath truly lies.
#[derive(Debug, Clone, PartialEq)]
pub struct Session<B> {
    /// The sensor model playing the breather.
    pub params: SignalParams,
    /// What the breather breathes.
    pub script: Vec<Step>,
    /// Every breath in order, where it truly lies.
    pub breaths: Vec<B>,
    /// The library entries entered, in order (practice; none in a
    /// protocol session).
    pub modes: Vec<Mode>,
    /// Samples (ms) in the session: [`Session::signal`] plays this many.
    pub ticks: u64,
}

impl<B> Session<B> {
    /// The session's samples, one per ms.
    pub fn signal(&self) -> std::iter::Take<SignalGenerator<'_>> {
        SignalGenerator::new(self.params, &self.script)
            .take(usize::try_from(self.ticks).unwrap_or(usize::MAX))
    }
}

/// A breather following the calibration protocol as a careful user would:
/// a rest of 5–6 s, then each block's breaths (length and strength ±
/// [`VARIATION`]; holds at [`Breather::hold_ms`] ± [`HOLD_VARIATION`]),
/// 1–2 s of rest between breaths, 3–4 s between blocks, and 2 s of rest at
/// the end. One truth record per prompt, in order. Deterministic for a
/// seed.
pub fn protocol_session(
    breather: &Breather,
    protocol: &Protocol,
    seed: u64,
) -> Session<ProtocolBreath> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xca11_b4a7_e000);
    let mut script = vec![Step::Rest {
        ms: between(PROTOCOL_START_MS, &mut rng),
    }];
    let mut asks = Vec::new();
    for block in &protocol.blocks {
        for i in 0..block.count {
            if !asks.is_empty() {
                let gap = if i == 0 {
                    PROTOCOL_BLOCK_GAP_MS
                } else {
                    PROTOCOL_BREATH_GAP_MS
                };
                script.push(Step::Rest {
                    ms: between(gap, &mut rng),
                });
            }
            script.push(Step::Breath {
                breath: block.ask.breath(),
                ms: breather.draw_ms(block.ask, &mut rng),
            });
            asks.push(block.ask);
        }
    }
    script.push(Step::Rest {
        ms: PROTOCOL_END_MS,
    });
    let params = breather.signal_params(seed);
    let (placed, ticks) = play(params, &script);
    let breaths = asks
        .into_iter()
        .zip(placed)
        .map(|(ask, b)| ProtocolBreath {
            ask,
            start: b.start,
            ms: b.ms,
        })
        .collect();
    Session {
        params,
        script,
        breaths,
        modes: Vec::new(),
        ticks,
    }
}

/// A breather in ordinary use for exactly `seconds`: after 2 s of rest,
/// random sequences from `library` (each breath of the breather's short or
/// long length and strength ± [`VARIATION`], the breather's gaps ±
/// [`VARIATION`] within a sequence), 1.5–3 s of rest after each. Every
/// breath ends at least half a second before the end. Held-out data for
/// scoring a fit: one truth record per breath, the action the user meant.
/// Deterministic for a seed; an empty library gives rest only.
pub fn practice_session(
    breather: &Breather,
    library: &[SequenceEntry],
    seconds: u64,
    seed: u64,
) -> Session<PracticeBreath> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x9a7c_71ce_0000);
    let total = seconds.saturating_mul(1000);
    // Samples a breath plays at most: its length and two whole ramps.
    let most = |ms: u32| u64::from(ms) + 2 * DEFAULT_RAMP_MS.1.ceil() as u64 + 3;
    let mut script = vec![Step::Rest {
        ms: PRACTICE_START_MS,
    }];
    let mut actions = Vec::new();
    let mut modes = Vec::new();
    let mut high = u64::from(PRACTICE_START_MS);
    // A breather breathes the entries made of breaths only.
    let library: Vec<(ActionSeq, Target)> = library
        .iter()
        .filter_map(|e| Some((e.breaths()?, e.target)))
        .collect();
    while !library.is_empty() {
        let (entry_actions, target) = library[rng.random_range(0..library.len())];
        let mut steps = Vec::new();
        let mut length = 0;
        for (i, &action) in entry_actions.as_slice().iter().enumerate() {
            if i > 0 {
                let ms = vary(breather.gap_ms, VARIATION, &mut rng);
                steps.push(Step::Rest { ms });
                length += u64::from(ms);
            }
            let ms = breather.draw_ms(Ask::Breath(action), &mut rng);
            steps.push(Step::Breath {
                breath: action.breath(),
                ms,
            });
            length += most(ms);
        }
        let rest = between(PRACTICE_SEQUENCE_GAP_MS, &mut rng);
        steps.push(Step::Rest { ms: rest });
        if high + length + 500 > total {
            break;
        }
        high += length + u64::from(rest);
        script.extend(steps);
        actions.extend_from_slice(entry_actions.as_slice());
        if let Some(mode) = target.mode() {
            modes.push(mode);
        }
    }
    let params = breather.signal_params(seed);
    let (placed, played) = play(params, &script);
    // Rest to the end: appended steps leave the samples before unchanged.
    let mut fill = total.saturating_sub(played);
    while fill > 0 {
        let ms = u32::try_from(fill).unwrap_or(u32::MAX);
        script.push(Step::Rest { ms });
        fill -= u64::from(ms);
    }
    let breaths = actions
        .into_iter()
        .zip(placed)
        .map(|(action, b)| PracticeBreath {
            action,
            start: b.start,
            ms: b.ms,
        })
        .collect();
    Session {
        params,
        script,
        breaths,
        modes,
        ticks: total,
    }
}

/// Plays a script: where the sensor model placed each breath, and how many
/// samples it lasts.
fn play(params: SignalParams, script: &[Step]) -> (Vec<ScriptedBreath>, u64) {
    let mut signal = SignalGenerator::new(params, script);
    let mut placed: Vec<ScriptedBreath> = Vec::new();
    let mut ticks = 0;
    while signal.next().is_some() {
        ticks += 1;
        if let Some(b) = signal.scripted_breath()
            && placed.last() != Some(&b)
        {
            placed.push(b);
        }
    }
    (placed, ticks)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;

    #[test]
    fn the_built_ins_have_their_truths() {
        let names: Vec<&str> = Breather::all().iter().map(|b| b.name).collect();
        assert_eq!(
            names,
            [
                "typical",
                "weak",
                "short_capacity",
                "slow",
                "tremulous",
                "asymmetric",
                "tremor_4hz",
                "tremor_6hz",
                "tremor_9hz",
                "hum_50hz",
                "hum_60hz",
                "adc_8bit",
                "adc_10bit",
                "wandering",
                "spiky"
            ]
        );
        let b = |name| Breather::named(name).unwrap();
        let typical = b("typical");
        assert_eq!(
            (typical.puff_volts, typical.sip_volts, typical.short_ms),
            (1.2, 1.2, 150)
        );
        assert_eq!((typical.long_ms, typical.hold_ms), (800, 4000));
        assert_eq!((typical.noise_volts, typical.tremor_volts), (0.01, 0.03));
        assert_eq!((b("weak").puff_volts, b("weak").sip_volts), (0.4, 0.4));
        let sc = b("short_capacity");
        assert_eq!((sc.short_ms, sc.long_ms, sc.hold_ms), (200, 600, 720));
        assert!(f64::from(sc.long_ms) * (1.0 + VARIATION) <= 800.0);
        assert!(f64::from(sc.hold_ms) * (1.0 + HOLD_VARIATION) <= 800.0);
        let slow = b("slow");
        assert_eq!((slow.short_ms, slow.long_ms), (400, 1500));
        assert!(slow.gap_ms > typical.gap_ms);
        let t = b("tremulous");
        assert_eq!((t.noise_volts, t.tremor_volts), (0.08, 0.1));
        let a = b("asymmetric");
        assert_eq!((a.puff_volts, a.sip_volts), (1.8, 0.35));
        assert_eq!(Breather::named("nobody"), None);
        // Rest levels differ, inside 2–3 V.
        let mut rests: Vec<f64> = Breather::all().iter().map(|b| b.rest_volts).collect();
        assert!(rests.iter().all(|v| (2.0..=3.0).contains(v)));
        rests.dedup();
        assert_eq!(rests.len(), Breather::all().len());
    }

    #[test]
    fn no_breath_reaches_the_rails() {
        for b in Breather::all() {
            let wobble =
                b.tremor_volts + b.rest_swing_volts() + 5.0 * b.noise_volts + b.drift_volts;
            let top = b.rest_volts + b.puff_volts * (1.0 + b.strength_spread) + wobble;
            let bottom = b.rest_volts - b.sip_volts * (1.0 + b.strength_spread) - wobble;
            assert!(top < 5.0 && bottom > 0.0, "{}: {bottom}–{top} V", b.name);
        }
    }

    #[test]
    fn the_crossings_are_fixed_fractions_of_the_heights() {
        let c = Breather::named("typical").unwrap().crossings();
        assert!((c.puff_on - 0.48).abs() < 1e-12 && (c.puff_off - 0.36).abs() < 1e-12);
        assert!((c.sip_on - 0.48).abs() < 1e-12 && (c.sip_off - 0.36).abs() < 1e-12);
        let a = Breather::named("asymmetric").unwrap();
        let c = a.crossings();
        assert!((c.puff_on - 0.72).abs() < 1e-12 && (c.sip_on - 0.14).abs() < 1e-12);
        // One hysteresis, a tenth of the weaker kind's height.
        assert!((c.puff_on - c.puff_off - 0.035).abs() < 1e-12);
        assert!((c.sip_on - c.sip_off - 0.035).abs() < 1e-12);
        // The true detector is a valid configuration for every breather.
        for b in Breather::all() {
            let text = format!(
                "[detector]\nneutral_volts = {}\npuff_threshold_volts = {}\n\
                 sip_threshold_volts = {}\nhysteresis_volts = {}\nlong_burst_ms = {}\n\
                 max_hold_ms = {}\n",
                b.rest_volts,
                b.true_detector().puff_threshold_volts,
                b.true_detector().sip_threshold_volts,
                b.true_detector().hysteresis_volts,
                b.true_detector().long_burst_ms,
                b.true_detector().max_hold_ms,
            );
            assert!(Config::from_toml_str(&text).is_ok(), "{}: {text}", b.name);
        }
    }

    #[test]
    fn lengths_vary_by_thirty_percent_and_holds_by_ten() {
        let b = Breather::named("typical").unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let draws = |ask, rng: &mut ChaCha8Rng| -> Vec<u32> {
            (0..2000).map(|_| b.draw_ms(ask, rng)).collect()
        };
        let short = draws(Ask::Breath(Action::ShortSip), &mut rng);
        assert_eq!(short.iter().min(), Some(&105));
        assert_eq!(short.iter().max(), Some(&195));
        let hold = draws(Ask::Hold(Breath::Puff), &mut rng);
        assert!(*hold.iter().min().unwrap() >= 3600 && *hold.iter().min().unwrap() < 3620);
        assert!(*hold.iter().max().unwrap() <= 4400 && *hold.iter().max().unwrap() > 4380);
    }

    #[test]
    fn sessions_are_deterministic_for_a_seed() {
        let b = Breather::named("tremulous").unwrap();
        let p = Protocol::new(2, 1);
        let one = protocol_session(&b, &p, 5);
        assert_eq!(one, protocol_session(&b, &p, 5));
        assert_ne!(one.script, protocol_session(&b, &p, 6).script);
        assert_eq!(one.breaths.len(), 10);
        assert_eq!(one.signal().count() as u64, one.ticks);
        let library = Config::default().core().sequences().to_vec();
        let practice = practice_session(&b, &library, 30, 5);
        assert_eq!(practice, practice_session(&b, &library, 30, 5));
    }

    #[test]
    fn a_practice_session_lasts_exactly_its_seconds() {
        let library = Config::default().core().sequences().to_vec();
        for (seconds, seed) in [(1, 1), (20, 2), (45, 3)] {
            for b in Breather::all() {
                let s = practice_session(b, &library, seconds, seed);
                assert_eq!(s.ticks, seconds * 1000);
                assert_eq!(s.signal().count() as u64, seconds * 1000, "{}", b.name);
                let breaths: usize = s
                    .modes
                    .iter()
                    .map(|m| {
                        library
                            .iter()
                            .find(|e| e.target.mode() == Some(*m))
                            .unwrap()
                            .actions
                            .len()
                    })
                    .sum();
                assert_eq!(s.breaths.len(), breaths);
                if let Some(last) = s.breaths.last() {
                    assert!(last.start + u64::from(last.ms) + 500 <= s.ticks);
                }
            }
        }
        let none = practice_session(&TYPICAL, &[], 10, 1);
        assert!(none.breaths.is_empty() && none.signal().all(|v| (v - 2.5).abs() < 0.1));
    }
}
