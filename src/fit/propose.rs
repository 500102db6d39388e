//! The settings proposed for a user, each with its reason in one line:
//! levels between the rest's noise and the weakest intended breath, the
//! short/long boundary where the user's short and long breaths are
//! equally far from it, the longest breath from their longest holds.
//! Settings the calibration cannot measure are kept, and the reason says
//! why.

use serde::Serialize;

use crate::config::Config;
use crate::control::action::{Action, Breath};
use crate::control::detector::DetectorConfig;
use crate::fit::breaths::Found;
use crate::fit::predict::{durations, fitted_ms};
use crate::fit::protocol::Ask;
use crate::fit::session::Answers;
use crate::fit::signal::Signal;
use crate::fit::usage::Pauses;

/// One proposed setting.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Setting {
    /// Its key, e.g. `detector.long_burst_ms`.
    pub key: &'static str,
    /// Its value as TOML writes it.
    pub value: String,
    /// Why, in one line.
    pub reason: String,
}

/// The proposal: the detector settings and every setting's reason.
#[derive(Debug, Clone, PartialEq)]
pub struct Proposal {
    /// The proposed `[detector]`.
    pub detector: DetectorConfig,
    /// The proposed `matcher.sequence_timeout_ms`.
    pub sequence_timeout_ms: u32,
    /// The proposed `command.inactivity_timeout_ms`.
    pub inactivity_timeout_ms: u32,
    /// Every `[detector]`, `[matcher]` and `[command]` setting, in the
    /// file's order, with its reason.
    pub settings: Vec<Setting>,
}

/// Volts rounded to the hundredth (offsets) or the thousandth (levels).
fn hundredths(v: f64) -> f64 {
    (v * 100.0).round() / 100.0
}
fn thousandths(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}

/// The weakest plateau of a kind, and which prompt it answered.
fn weakest(answers: &Answers, breath: Breath) -> (f64, Ask) {
    answers
        .answers
        .iter()
        .filter(|a| a.ask.breath() == breath)
        .map(|a| (a.region.plateau, a.ask))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .unwrap_or((0.0, Ask::Breath(Action::new(breath, false))))
}

/// The lowest a breath of this kind falls, volts from its baseline,
/// between the first and last time it is past the threshold of `d` for
/// longer than the glitch filter, over the
/// session's breaths of that kind that fell back under it in between, and
/// the prompt it answered; `None` if none did.
fn lowest_dip(
    signal: &Signal,
    answers: &Answers,
    d: &DetectorConfig,
    breath: Breath,
) -> Option<(f64, Ask)> {
    let (on, _) = crate::fit::predict::levels(d, breath);
    let sign = crate::control::mode::Direction::of(breath).sign();
    answers
        .answers
        .iter()
        .filter(|a| a.ask.breath() == breath)
        .filter_map(|a| {
            let r = &a.region;
            let distance: Vec<f64> = (r.start..r.end)
                .filter_map(|t| signal.volts(t))
                .map(|v| sign * (v - r.baseline))
                .collect();
            // Past the threshold for longer than the glitch filter: a
            // spike at either end is not the breath.
            let w = d.glitch_ms as usize + 1;
            let held: Vec<f64> = distance
                .windows(w)
                .map(|w| w.iter().copied().fold(f64::INFINITY, f64::min))
                .collect();
            let first = held.iter().position(|&x| x > on)?;
            let last = held.iter().rposition(|&x| x > on)? + w - 1;
            // A dip the detector ignores (no longer than the glitch
            // filter) does not count.
            let low = distance[first..=last]
                .windows(w)
                .map(|w| w.iter().copied().fold(f64::NEG_INFINITY, f64::max))
                .fold(f64::INFINITY, f64::min);
            (low <= on).then_some((low, a.ask))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
}

/// Sips and puffs whose weakest plateaus differ more than this many times
/// get a hysteresis each.
const OWN_HYSTERESIS_RATIO: f64 = 2.0;

/// The hysteresis for the kinds `kinds` (0 puff, 1 sip) and why, from each
/// kind's room between its threshold and the rest (`gaps`), the rest's
/// excursion on its side and the deepest dip of its breaths: a quarter of
/// the room, or, when a tremor riding on a breath dips it back under its
/// threshold, midway between that dip and the rest, but never within a
/// quarter of the room of the rest.
fn end_level(
    kinds: &[usize],
    gaps: &[f64; 2],
    excursions: &[f64; 2],
    dips: &[Option<(f64, Ask)>; 2],
) -> (f64, String) {
    let room = kinds.iter().map(|&i| gaps[i]).fold(f64::INFINITY, f64::min);
    let quarter = hundredths((room / 4.0).clamp(0.01, 0.2));
    let needed = kinds
        .iter()
        .filter_map(|&i| {
            let (dip, ask) = dips[i]?;
            let offset = gaps[i] + excursions[i];
            Some((offset - (dip + excursions[i]) / 2.0, dip, ask))
        })
        .max_by(|a, b| a.0.total_cmp(&b.0));
    let most = hundredths(room * 0.75 - 0.005).max(0.01);
    match needed {
        Some((h, dip, ask)) if hundredths(h) > quarter => {
            let h = hundredths(h);
            (
                h.min(most),
                format!(
                    "ends {:.2} V back inside its threshold: your {} dipped to {dip:.2} V from rest (a tremor riding on it), so it ends midway between that and the rest's largest excursion, and one breath stays one burst{}",
                    h.min(most),
                    ask.words(),
                    if h > most {
                        " (as far as the rest allows: a deeper dip splits the breath)"
                    } else {
                        ""
                    }
                ),
            )
        }
        _ => (
            quarter,
            format!(
                "ends {quarter:.2} V back inside its threshold: a quarter of the {room:.2} V between {} threshold and the rest noise",
                if kinds.len() > 1 { "the nearer" } else { "its" }
            ),
        ),
    }
}

/// A kind's short and long durations: (mean, spread) of each, ms.
pub type ShortLong = ((f64, f64), (f64, f64));

/// The short/long boundary, ms, farthest in spreads from both classes of
/// both kinds: maximises the smaller of (b − short mean) / short spread
/// and (long mean − b) / long spread.
pub fn boundary(classes: &[ShortLong], lowest: u32) -> Option<u32> {
    let top = classes
        .iter()
        .map(|(_, (m, s))| m + 3.0 * s)
        .fold(f64::from(lowest) + 1.0, f64::max) as u32;
    (lowest + 1..=top).max_by(|&a, &b| margin(classes, a).total_cmp(&margin(classes, b)))
}

/// The smaller margin, in spreads, of a boundary.
pub fn margin(classes: &[ShortLong], b: u32) -> f64 {
    let b = f64::from(b);
    classes
        .iter()
        .map(|((ms, ss), (ml, sl))| ((b - ms) / ss).min((ml - b) / sl))
        .fold(f64::INFINITY, f64::min)
}

/// Rounded up to a multiple of `step`.
fn ceil_to(v: f64, step: u32) -> u32 {
    ((v / f64::from(step)).ceil() as u32) * step
}

/// Proposes settings for the user of this calibration, starting from
/// `current`.
pub fn propose(
    signal: &Signal,
    found: &Found,
    answers: &Answers,
    current: &Config,
    pauses: Option<&Pauses>,
) -> Proposal {
    let now = *current.core().detector();
    let rest = &found.rest;
    let mut settings = Vec::new();
    let mut set = |key: &'static str, value: String, reason: String| {
        settings.push(Setting { key, value, reason })
    };
    let mut d = DetectorConfig {
        neutral_volts: thousandths(rest.level),
        ..now
    };
    set(
        "detector.neutral_volts",
        format!("{}", d.neutral_volts),
        format!(
            "your rest level, measured over {:.1} s (a run measures it again at start)",
            rest.ms as f64 / 1000.0
        ),
    );
    let mut gaps = [0.0; 2];
    for (i, breath) in [Breath::Puff, Breath::Sip].into_iter().enumerate() {
        let (noise, side, word) = match breath {
            Breath::Puff => (rest.excursion_up, 1.0, "puff"),
            Breath::Sip => (rest.excursion_down, -1.0, "sip"),
        };
        let (plateau, ask) = weakest(answers, breath);
        let offset = hundredths((noise + plateau) / 2.0).max(0.01);
        gaps[i] = offset - noise;
        let level = thousandths(d.neutral_volts + side * offset);
        let key = match breath {
            Breath::Puff => {
                d.puff_threshold_volts = level;
                "detector.puff_threshold_volts"
            }
            Breath::Sip => {
                d.sip_threshold_volts = level;
                "detector.sip_threshold_volts"
            }
        };
        set(
            key,
            format!("{level}"),
            format!(
                "{word} threshold {offset:.2} V {} rest: midway between the rest noise's largest excursion, {noise:.2} V, and your weakest {}'s plateau, {plateau:.2} V",
                if side > 0.0 { "above" } else { "below" },
                ask.words()
            ),
        );
    }
    let dips = [Breath::Puff, Breath::Sip].map(|b| lowest_dip(signal, answers, &d, b));
    let excursions = [rest.excursion_up, rest.excursion_down];
    let end = |kinds: &[usize]| end_level(kinds, &gaps, &excursions, &dips);
    // A person whose puffs and sips differ much in strength gets an end
    // level per kind: the weaker kind's would hold the stronger's breath
    // too tightly.
    let strengths = [Breath::Puff, Breath::Sip].map(|b| weakest(answers, b).0);
    let ratio = strengths[0].max(strengths[1]) / strengths[0].min(strengths[1]).max(1e-6);
    if ratio > OWN_HYSTERESIS_RATIO {
        let ((puff, puff_why), (sip, sip_why)) = (end(&[0]), end(&[1]));
        d.hysteresis_volts = puff;
        d.sip_hysteresis_volts = Some(sip);
        let stronger = if strengths[0] > strengths[1] {
            "puffs"
        } else {
            "sips"
        };
        set(
            "detector.hysteresis_volts",
            format!("{puff}"),
            format!(
                "a puff {puff_why}; your weakest {stronger} are {ratio:.1}× as strong as the other kind's, so each kind has its own"
            ),
        );
        set(
            "detector.sip_hysteresis_volts",
            format!("{sip}"),
            format!("a sip {sip_why}"),
        );
    } else {
        let (shared, why) = end(&[0, 1]);
        d.hysteresis_volts = shared;
        set(
            "detector.hysteresis_volts",
            format!("{shared}"),
            format!("a breath {why}"),
        );
        if now.sip_hysteresis_volts.is_some() {
            d.sip_hysteresis_volts = Some(shared);
            set(
                "detector.sip_hysteresis_volts",
                format!("{shared}"),
                "the same as a puff's: your sips and puffs are alike in strength".to_string(),
            );
        }
    }
    let glitch = rest.longest_spike_ms as u32 + 2;
    if rest.spikes > 0 && glitch > now.glitch_ms {
        d.glitch_ms = glitch;
        set(
            "detector.glitch_ms",
            format!("{glitch}"),
            format!(
                "the rest had {} spikes, the longest {} ms: changes shorter than {glitch} ms are ignored",
                rest.spikes, rest.longest_spike_ms
            ),
        );
    } else {
        set(
            "detector.glitch_ms",
            format!("{}", d.glitch_ms),
            format!(
                "kept: the longest spike at rest was {} ms",
                rest.longest_spike_ms
            ),
        );
    }
    // Durations as the proposed levels measure them.
    let class_ms = |action: Action, d: &DetectorConfig| -> Vec<f64> {
        durations(signal, answers, Ask::Breath(action), d)
            .into_iter()
            .flatten()
            .map(|ms| ms as f64)
            .collect()
    };
    let shortest = [Action::ShortPuff, Action::ShortSip]
        .iter()
        .flat_map(|&a| class_ms(a, &d))
        .fold(f64::INFINITY, f64::min);
    if shortest.is_finite() && shortest < 2.0 * f64::from(now.min_burst_ms) {
        d.min_burst_ms = ((shortest / 2.0 / 5.0).floor() as u32 * 5).max(d.glitch_ms + 1);
        set(
            "detector.min_burst_ms",
            format!("{}", d.min_burst_ms),
            format!(
                "half your shortest short breath, {shortest:.0} ms: shorter stretches are ignored"
            ),
        );
    } else {
        set(
            "detector.min_burst_ms",
            format!("{}", d.min_burst_ms),
            format!("kept: your shortest short breath, {shortest:.0} ms, is well above it"),
        );
    }
    let classes: Vec<ShortLong> = [Breath::Puff, Breath::Sip]
        .iter()
        .filter_map(|&b| {
            let short = class_ms(Action::new(b, false), &d);
            let long = class_ms(Action::new(b, true), &d);
            (!short.is_empty() && !long.is_empty()).then(|| (fitted_ms(&short), fitted_ms(&long)))
        })
        .collect();
    if let Some(b) = boundary(&classes, d.min_burst_ms) {
        let b = (b + 5) / 10 * 10;
        d.long_burst_ms = b.max(d.min_burst_ms + 1);
        let words: Vec<String> = [Breath::Puff, Breath::Sip]
            .iter()
            .zip(&classes)
            .map(|(b, ((ms, ss), (ml, sl)))| {
                let w = if *b == Breath::Puff { "puffs" } else { "sips" };
                format!("short {w} {ms:.0} ± {ss:.0} ms, long {ml:.0} ± {sl:.0} ms")
            })
            .collect();
        set(
            "detector.long_burst_ms",
            format!("{}", d.long_burst_ms),
            format!(
                "where your short and long breaths are equally far, {:.1} spreads: {}",
                margin(&classes, d.long_burst_ms),
                words.join("; ")
            ),
        );
    } else {
        set(
            "detector.long_burst_ms",
            format!("{}", d.long_burst_ms),
            "kept: no short or long breath passed the proposed thresholds".into(),
        );
    }
    let longest_breath = [
        Action::ShortPuff,
        Action::LongPuff,
        Action::ShortSip,
        Action::LongSip,
    ]
    .iter()
    .flat_map(|&a| class_ms(a, &d))
    .fold(0.0, f64::max);
    let holds: Vec<f64> = [Breath::Puff, Breath::Sip]
        .iter()
        .flat_map(|&b| {
            let (on, off) = crate::fit::predict::levels(&d, b);
            answers
                .of(Ask::Hold(b))
                .filter_map(|r| r.duration_at(signal, on, off, d.glitch_ms as usize))
                .map(|ms| ms as f64)
                .collect::<Vec<_>>()
        })
        .collect();
    let floor = d.long_burst_ms.max(d.min_burst_ms) + 500;
    if let Some(hold) = holds.iter().copied().reduce(f64::max) {
        d.max_hold_ms = ceil_to(1.25 * hold.max(longest_breath), 100).max(floor);
        set(
            "detector.max_hold_ms",
            format!("{}", d.max_hold_ms),
            format!(
                "a quarter over your longest comfortable hold, {hold:.0} ms: a breath held longer is a stuck sensor and stops the arm"
            ),
        );
    } else if f64::from(now.max_hold_ms) < 1.5 * longest_breath || now.max_hold_ms < floor {
        d.max_hold_ms = ceil_to(1.5 * longest_breath, 500).max(floor);
        set(
            "detector.max_hold_ms",
            format!("{}", d.max_hold_ms),
            format!(
                "half over your longest breath, {longest_breath:.0} ms (holds not measured: fit with --holds)"
            ),
        );
    } else {
        set(
            "detector.max_hold_ms",
            format!("{}", d.max_hold_ms),
            format!(
                "kept: above your longest breath, {longest_breath:.0} ms (holds not measured: fit with --holds)"
            ),
        );
    }
    let sensor = "kept: a property of the sensor, not of your breathing";
    for (key, value) in [
        ("detector.neutral_tracking_ms", d.neutral_tracking_ms),
        ("detector.fault_recovery_ms", d.fault_recovery_ms),
        ("detector.stale_ms", d.stale_ms),
        ("detector.rezero_ms", d.rezero_ms),
    ] {
        set(key, format!("{value}"), sensor.into());
    }
    set(
        "detector.fault_margin_volts",
        format!("{}", d.fault_margin_volts),
        sensor.into(),
    );
    let core = current.core();
    let (sequence_timeout_ms, reason) = timeout(
        pauses.map(|p| p.in_sequence.as_slice()),
        core.matcher().sequence_timeout_ms,
        (300, 5000, 100),
        "between the breaths of a sequence",
    );
    set(
        "matcher.sequence_timeout_ms",
        format!("{sequence_timeout_ms}"),
        reason,
    );
    let (inactivity_timeout_ms, reason) = timeout(
        pauses.map(|p| p.in_mode.as_slice()),
        core.command().inactivity_timeout_ms,
        (1000, 10_000, 500),
        "between your breaths in a mode",
    );
    set(
        "command.inactivity_timeout_ms",
        format!("{inactivity_timeout_ms}"),
        reason,
    );
    set(
        "command.motion_onset_ms",
        format!("{}", core.command().motion_onset_ms),
        "kept: a choice of how the interface works (0: every breath in a mode moves the arm, as in the paper)".into(),
    );
    Proposal {
        detector: d,
        sequence_timeout_ms,
        inactivity_timeout_ms,
        settings,
    }
}

/// Pauses measured in use at least this many times give a timeout.
const MIN_PAUSES: usize = 20;

/// A timeout half over the 95th percentile of the user's `pauses`, within
/// `(lowest, highest)` and rounded up to `step` ms; kept when the session
/// measured too few pauses (a calibration, paced by its prompts, measures
/// none).
fn timeout(
    pauses: Option<&[f64]>,
    now: u32,
    (lowest, highest, step): (u32, u32, u32),
    what: &str,
) -> (u32, String) {
    match pauses {
        Some(p) if p.len() >= MIN_PAUSES => {
            let mut sorted = p.to_vec();
            sorted.sort_unstable_by(f64::total_cmp);
            let p95 = crate::fit::stats::quantile_sorted(&sorted, 0.95);
            let ms = ceil_to(1.5 * p95, step).clamp(lowest, highest);
            (
                ms,
                format!(
                    "half over your longest usual pause {what}, {p95:.0} ms (95th percentile of {})",
                    p.len()
                ),
            )
        }
        Some(p) => (
            now,
            format!("kept: only {} pauses {what} in the session", p.len()),
        ),
        None => (
            now,
            "kept: the calibration paces breaths by its prompts, so it does not measure your pauses in use; `fit --from` a recording of ordinary use does".into(),
        ),
    }
}
