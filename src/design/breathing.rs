//! How a person breathes, as the designer needs it: how long each of the
//! four bursts takes them, how long they rest between bursts and react,
//! and how often the detector reads each burst as another (missed, or the
//! other length). From the study's simulated user or from the statistics
//! a fitted profile carries; with their gestures beside, when they use a
//! set ([`Gesturing`]), the alphabet their sequences are made of.

use serde::Serialize;

use crate::config::Config;
use crate::control::action::{Action, Breath};
use crate::control::detector::DetectorConfig;
use crate::control::sequence::Sequence;
use crate::control::token::Token;
use crate::design::gesturing::{GestureStats, Gesturing};
use crate::design::symbol::{Symbol, SymbolSeq};
use crate::fit::profile::Measured;
use crate::fit::stats::normal_cdf;
use crate::sim::sensor_model::DEFAULT_RAMP_MS;
use crate::sim::user::UserModel;

/// One burst kind as this person breathes it and the detector reads it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BurstStats {
    /// Mean length, ms.
    pub mean_ms: f64,
    /// Standard deviation of the length, ms.
    pub sd_ms: f64,
    /// Chance the detector reads no burst at all.
    pub missed: f64,
    /// Chance the detector reads it as the other length (a long one as
    /// short, a short one as long).
    pub other_length: f64,
}

/// A person's breathing and the detector settings reading it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Breathing {
    /// Who this is, in words.
    pub source: String,
    /// From seeing the interface ready to starting the first burst, ms.
    pub reaction_ms: f64,
    /// The four bursts, in [`Action::ALL`]'s order.
    pub bursts: [BurstStats; 4],
    /// Rest between the bursts of a sequence, ms.
    pub gap_ms: f64,
    /// The time a burst's signal takes to rise to the threshold and fall
    /// back from it, beyond its length, ms.
    pub edge_ms: f64,
    /// Chance per selection that the person breathes one burst of it at
    /// the wrong length (their mistake, not the detector's).
    pub error_rate: f64,
    /// Bursts per hour nobody breathed (noise passing a threshold).
    pub false_per_hour: f64,
    /// Chance a burst is read as the other breath (a sip as a puff):
    /// nothing measures it, so 0 unless a clinician gives it
    /// (`design --swap-rate`).
    pub swap_rate: f64,
    /// The longest breath they can hold, ms (`None`: no limit measured).
    pub hold_capacity_ms: Option<f64>,
    /// Where the detector's rates (`missed`, `other_length`,
    /// `false_per_hour`) come from, so a report can set them apart from
    /// the assumed `error_rate` and `swap_rate`.
    pub rates_from: RatesFrom,
    /// The person's gestures, when they use a set (`[gestures] set`):
    /// how long each takes them and how it is read. `None`: breaths only.
    pub gestures: Option<Gesturing>,
}

/// Where a person's misreading rates come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RatesFrom {
    /// The fit's predicted misreadings, from the person's measured
    /// breaths and signal (the profile's header).
    Fit,
    /// The normal spread of the lengths the fit measured around the
    /// detector's boundaries (a profile without predicted rates).
    FitLengths,
    /// The study's simulated user's length spread.
    Model,
}

impl RatesFrom {
    /// The label a report gives these rates.
    pub fn label(self) -> &'static str {
        match self {
            RatesFrom::Fit => "measured (fit)",
            RatesFrom::FitLengths => "from the fit's measured lengths",
            RatesFrom::Model => "modelled (the study's simulated user)",
        }
    }
}

impl Breathing {
    /// The study's simulated participant read by `d`: the same lengths
    /// for sips and puffs, misreadings from the normal spread of each
    /// length around the detector's boundaries.
    pub fn of_model(user: &UserModel, d: &DetectorConfig, source: &str) -> Breathing {
        let bursts = Action::ALL.map(|a| {
            let (mean_ms, sd_ms) = if a.is_long() {
                user.long_ms
            } else {
                user.short_ms
            };
            burst_read_by(a, mean_ms, sd_ms, d)
        });
        Breathing {
            source: source.to_string(),
            // The participants' mean reaction is the population's times a
            // log-normal factor of mean exp(σ²/2).
            reaction_ms: user.reaction_ms.0 * (user.between_users.powi(2) / 2.0).exp(),
            bursts,
            gap_ms: user.gap_ms.0,
            edge_ms: EDGE_MS,
            error_rate: user.error_rate,
            false_per_hour: 0.0,
            swap_rate: 0.0,
            hold_capacity_ms: user
                .hold_capacity_ms
                .is_finite()
                .then_some(user.hold_capacity_ms),
            rates_from: RatesFrom::Model,
            gestures: None,
        }
    }

    /// The person a fitted profile measured, read by the profile's own
    /// detector settings: each burst's length as measured, the fit's
    /// predicted misreadings where the profile states them (they know the
    /// signal's heights too) and the normal spread otherwise. What the
    /// calibration does not measure (reaction, gaps, the person's own
    /// mistakes) is the study population's.
    pub fn of_profile(measured: &Measured, config: &Config, source: &str) -> Breathing {
        let d = config.core().detector();
        let population = Breathing::of_model(&UserModel::POPULATION, d, source);
        let bursts = Action::ALL.map(|a| {
            let (mean_ms, sd_ms) = measured.length_ms(a);
            let mut burst = burst_read_by(a, mean_ms, sd_ms, d);
            if let Some(rates) = &measured.rates {
                let kind = rates.of(a.breath());
                burst.missed = kind.missed;
                burst.other_length = if a.is_long() {
                    kind.long_as_short
                } else {
                    kind.short_as_long
                };
            }
            burst
        });
        Breathing {
            bursts,
            false_per_hour: measured.rates.as_ref().map_or(0.0, |r| r.false_per_hour),
            hold_capacity_ms: measured.hold_ms,
            rates_from: if measured.rates.is_some() {
                RatesFrom::Fit
            } else {
                RatesFrom::FitLengths
            },
            ..population
        }
    }

    /// The burst `a` as this person breathes it.
    pub fn burst(&self, a: Action) -> &BurstStats {
        &self.bursts[a.index()]
    }

    /// Who this is, in words: the breathing's source, and the gesture
    /// set's when there is one.
    pub fn described(&self) -> String {
        match &self.gestures {
            Some(g) => format!("{}, with the gestures of {}", self.source, g.source),
            None => self.source.clone(),
        }
    }

    /// The gesture `s` is, as this person makes it (`None`: a burst, or
    /// no such gesture).
    pub fn gesture(&self, s: Symbol) -> Option<&GestureStats> {
        self.gestures.as_ref()?.gestures.get(s.gesture_index()?)
    }

    /// How long `s` takes from its start to being read, gaps apart: a
    /// burst's mean length (its edges and the detector's latency are the
    /// attempt's), a gesture's mean length and the front end's wait for
    /// rest.
    #[inline]
    pub fn time_ms(&self, s: Symbol) -> f64 {
        match self.bursts.get(s.index()) {
            Some(burst) => burst.mean_ms,
            None => self.gesture_time_ms(s),
        }
    }

    /// [`Breathing::time_ms`] of a gesture (infinite: no such gesture).
    #[cold]
    fn gesture_time_ms(&self, s: Symbol) -> f64 {
        match (&self.gestures, s.gesture_index()) {
            (Some(g), Some(k)) => g.time_ms(k),
            _ => f64::INFINITY,
        }
    }

    /// Every symbol this person has: the four bursts, then their gestures.
    pub fn alphabet(&self) -> Vec<Symbol> {
        let gestures = self.gestures.as_ref().map_or(0, |g| g.gestures.len());
        Action::ALL
            .into_iter()
            .map(Symbol::burst)
            .chain((0..gestures).filter_map(Symbol::gesture))
            .collect()
    }

    /// The symbol of `token` (`None`: a gesture not in the person's set).
    pub fn symbol(&self, token: Token) -> Option<Symbol> {
        match token {
            Token::Breath(a) => Some(Symbol::burst(a)),
            Token::Gesture(name) => Symbol::gesture(self.gestures.as_ref()?.index(&name)?),
        }
    }

    /// The token of `s` (a gesture the person lacks: a short sip, never
    /// met: symbols come from [`Breathing::alphabet`] or [`Breathing::symbol`]).
    pub fn token(&self, s: Symbol) -> Token {
        match (s.action(), self.gesture(s)) {
            (Some(a), _) => Token::Breath(a),
            (None, Some(g)) => Token::Gesture(g.name),
            (None, None) => Token::Breath(Action::ShortSip),
        }
    }

    /// A library sequence's symbols (`None`: it names a gesture not in
    /// the person's set).
    pub fn symbols(&self, sequence: &Sequence) -> Option<SymbolSeq> {
        let mut out = SymbolSeq::EMPTY;
        for token in sequence.as_slice() {
            out.try_push(self.symbol(*token)?).ok()?;
        }
        Some(out)
    }

    /// Symbols as a library sequence.
    pub fn tokens(&self, symbols: &SymbolSeq) -> Sequence {
        Sequence::from_tokens(symbols.as_slice().iter().map(|s| self.token(*s))).unwrap_or_default()
    }

    /// `s` in words: "short puff", "nod".
    pub fn word(&self, s: Symbol) -> String {
        self.token(s).to_string()
    }

    /// A study participant who breathes like this: sips and puffs share
    /// the mean of their lengths (the simulated user has one length per
    /// class), with the larger spread.
    pub fn user_model(&self) -> UserModel {
        let class = |long: bool| {
            let (sip, puff) = (
                self.burst(Action::new(Breath::Sip, long)),
                self.burst(Action::new(Breath::Puff, long)),
            );
            (
                (sip.mean_ms + puff.mean_ms) / 2.0,
                sip.sd_ms.max(puff.sd_ms),
            )
        };
        UserModel {
            short_ms: class(false),
            long_ms: class(true),
            gap_ms: (self.gap_ms, UserModel::POPULATION.gap_ms.1),
            error_rate: self.error_rate,
            hold_capacity_ms: self.hold_capacity_ms.unwrap_or(f64::INFINITY),
            ..UserModel::POPULATION
        }
    }
}

/// A burst's rise and fall outside its threshold crossings, ms: the
/// study sensor's ramps (30–80 ms, uniform) spend 0.84 of their length
/// there at the default thresholds and a 1.2 V breath. Calibration does
/// not measure it, so a profile's person takes it too.
pub const EDGE_MS: f64 = 0.84 * (DEFAULT_RAMP_MS.0 + DEFAULT_RAMP_MS.1) / 2.0;

/// A burst of length N(mean, sd) read by `d`: under `min_burst_ms` it is
/// missed; past `long_burst_ms` it is long.
fn burst_read_by(a: Action, mean_ms: f64, sd_ms: f64, d: &DetectorConfig) -> BurstStats {
    let below = |ms: f64| {
        if sd_ms > 0.0 {
            normal_cdf((ms - mean_ms) / sd_ms)
        } else if mean_ms < ms {
            1.0
        } else {
            0.0
        }
    };
    let missed = below(f64::from(d.min_burst_ms));
    let short = below(f64::from(d.long_burst_ms)) - missed;
    BurstStats {
        mean_ms,
        sd_ms,
        missed,
        other_length: if a.is_long() {
            short
        } else {
            1.0 - missed - short
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_study_user_misreads_a_long_burst_one_time_in_160() {
        let b = Breathing::of_model(
            &UserModel::POPULATION,
            &DetectorConfig::default(),
            "the study's user",
        );
        // 800 ± 120 ms against the 500 ms boundary: 2.5 SD, Φ(−2.5).
        let long = b.burst(Action::LongPuff);
        assert!((long.other_length - 0.00621).abs() < 1e-4, "{long:?}");
        // 150 ± 35 ms: 10 SD below 500 ms, 3.1 SD above 40 ms.
        let short = b.burst(Action::ShortSip);
        assert!(short.other_length < 1e-12);
        assert!((short.missed - 0.00083).abs() < 1e-4, "{short:?}");
        assert_eq!(b.gap_ms, 300.0);
        assert!((b.reaction_ms - 450.0 * 0.02f64.exp()).abs() < 1e-9);
    }

    #[test]
    fn the_user_model_round_trips_the_classes() {
        let b = Breathing::of_model(&UserModel::POPULATION, &DetectorConfig::default(), "x");
        let u = b.user_model();
        assert_eq!(u.short_ms, UserModel::POPULATION.short_ms);
        assert_eq!(u.long_ms, UserModel::POPULATION.long_ms);
        assert_eq!(u.error_rate, 0.05);
    }
}
