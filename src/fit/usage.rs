//! Fitting from ordinary use: a `run --record` session where nobody
//! prompted anything. The breaths are those the user made, read by the
//! settings in use; those made to select (not in a mode, where a breath
//! moves the arm) are split into short and long by a two-part mixture per
//! kind, not by the boundary in use, so a boundary that drifted away from
//! the user is seen. The pauses inside sequences
//! and in a mode give the sequence and inactivity timeouts.

use crate::config::Config;
use crate::control::action::{Action, Breath};
use crate::control::event::Event;
use crate::control::mode::{Direction, ModeState};
use crate::control::pipeline::Pipeline;
use crate::control::tick::{TickInput, TickOutput};
use crate::fit::breaths::{self, Found, Region, Rest};
use crate::fit::protocol::{Ask, Block, Protocol};
use crate::fit::session::{Answer, Answers};
use crate::fit::signal::{FitError, Signal};
use crate::fit::stats::{self, quantile_sorted};

/// What ordinary use shows beyond the breaths: the pauses.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Pauses {
    /// From the end of a burst to the start of the next of the same
    /// sequence, ms.
    pub in_sequence: Vec<f64>,
    /// From entering a mode, or the end of a breath in it, to the next
    /// breath in that mode, ms.
    pub in_mode: Vec<f64>,
    /// Times a mode ended by inactivity.
    pub inactivity_exits: usize,
}

/// A session of ordinary use, made to look like a calibration: the rest
/// (from the quiet stretches), the breaths as regions, each answering the
/// prompt its mixture component stands for; and the pauses.
#[derive(Debug, Clone)]
pub struct Use {
    /// The rest and breaths.
    pub found: Found,
    /// The breaths, each as short or long of its kind.
    pub answers: Answers,
    /// One block per kind and length, with the breaths found.
    pub protocol: Protocol,
    /// The pauses.
    pub pauses: Pauses,
    /// Breaths cut by a fault (the loop stalled, or a breath held past
    /// `detector.max_hold_ms`): neither rest nor a breath to measure.
    pub cut_by_fault: usize,
}

/// Samples this close to a burst are not rest, ms.
const QUIET_MARGIN_MS: usize = 500;

/// Reads a session of ordinary use with the settings it was recorded
/// with.
pub fn measure(signal: &Signal, in_use: &Config) -> Result<Use, FitError> {
    let mut core = Pipeline::new(in_use.core());
    let mut out = TickOutput::default();
    let mut bursts = Vec::new();
    let mut pauses = Pauses::default();
    let mut last_in_sequence: Option<u64> = None;
    let mut mode_since: Option<u64> = None;
    let mut faults = Vec::new();
    for (tick, &sample) in signal.samples.iter().enumerate() {
        let tick = tick as u64;
        let before = out.command.state;
        core.step(&TickInput::new(tick, sample), &mut out);
        for event in out.events.iter() {
            match *event {
                Event::Burst(b) => {
                    let in_mode = matches!(before, ModeState::Command(_));
                    if in_mode {
                        if let Some(since) = mode_since {
                            pauses.in_mode.push(b.start.saturating_sub(since) as f64);
                        }
                        mode_since = Some(b.end);
                    } else {
                        if let Some(end) = last_in_sequence {
                            pauses.in_sequence.push(b.start.saturating_sub(end) as f64);
                        }
                        last_in_sequence = Some(b.end);
                    }
                    bursts.push((b, in_mode));
                }
                Event::Match { .. } => {
                    last_in_sequence = None;
                    mode_since = Some(tick);
                }
                Event::Fault { .. } => {
                    faults.push(tick as usize);
                    last_in_sequence = None;
                }
                Event::Reset { .. } => last_in_sequence = None,
                Event::Detection { reason } => {
                    mode_since = None;
                    pauses.inactivity_exits +=
                        usize::from(reason == crate::control::modes::DetectionReason::Inactivity);
                }
                _ => {}
            }
        }
    }
    if bursts.len() < 12 {
        return Err(FitError::new(format!(
            "{} breaths in the session: ordinary use needs at least 12 to fit (record a longer session)",
            bursts.len()
        )));
    }
    let cut = fault_spans(signal, in_use, &faults);
    bursts.retain(|(b, _)| {
        !cut.iter()
            .any(|&(from, to)| (b.start as usize) < to && from < b.end as usize)
    });
    let mut quiet: Vec<bool> = (0..signal.len())
        .map(|t| signal.volts(t).is_some())
        .collect();
    for &(from, to) in &cut {
        let from = from.saturating_sub(QUIET_MARGIN_MS);
        let to = (to + QUIET_MARGIN_MS).min(signal.len());
        quiet[from..to].fill(false);
    }
    for (b, _) in &bursts {
        let from = (b.start as usize).saturating_sub(QUIET_MARGIN_MS);
        let to = (b.end as usize + QUIET_MARGIN_MS).min(signal.len());
        quiet[from..to].fill(false);
    }
    let rest = rest(signal, &quiet)?;
    let long_in_use = in_use.core().detector().long_burst_ms;
    let regions: Vec<(Region, bool)> = bursts
        .iter()
        .map(|(b, in_mode)| (region(signal, &quiet, rest.level, b), *in_mode))
        .collect();
    let mut answers = Vec::new();
    let mut blocks = Vec::new();
    for breath in [Breath::Puff, Breath::Sip] {
        let mine: Vec<&Region> = regions
            .iter()
            .filter(|(r, in_mode)| r.breath == breath && !in_mode)
            .map(|(r, _)| r)
            .collect();
        let ms: Vec<f64> = mine.iter().map(|r| (r.end - r.start) as f64).collect();
        let long = split(&ms, f64::from(long_in_use));
        let mut counts = [0u32; 2];
        for (r, &is_long) in mine.iter().zip(&long) {
            counts[usize::from(is_long)] += 1;
            answers.push(Answer {
                ask: Ask::Breath(Action::new(breath, is_long)),
                region: **r,
            });
        }
        for (is_long, count) in [(false, counts[0]), (true, counts[1])] {
            blocks.push(Block {
                ask: Ask::Breath(Action::new(breath, is_long)),
                count,
            });
        }
    }
    answers.sort_by_key(|a| a.region.start);
    let regions_only: Vec<Region> = regions.iter().map(|(r, _)| *r).collect();
    Ok(Use {
        found: Found {
            rest,
            outside: 0.0,
            opening_swing: rest.excursion_up.max(rest.excursion_down),
            strongest: regions_only.iter().map(|r| r.peak).fold(0.0, f64::max),
            regions: regions_only,
        },
        answers: Answers {
            answers,
            wrong: Vec::new(),
            extra: Vec::new(),
            notes: Vec::new(),
        },
        protocol: Protocol { blocks },
        pauses,
        cut_by_fault: cut.len(),
    })
}

/// The breaths the faults at `faults` (ticks) cut: for each, the span
/// the detector did not read as rest, from the start of the breath in
/// progress to the signal's return inside the band (past both release
/// levels of the settings in use), missing samples counted as outside.
/// A fault outside any breath (a stall at rest) cuts none; two faults in
/// one breath cut it once.
fn fault_spans(signal: &Signal, in_use: &Config, faults: &[usize]) -> Vec<(usize, usize)> {
    let d = in_use.core().detector();
    let puff_off = d.puff_threshold_volts - d.hysteresis_volts;
    let sip_off = d.sip_threshold_volts + d.sip_hysteresis_volts.unwrap_or(d.hysteresis_volts);
    let outside = |t: usize| {
        signal
            .volts(t)
            .is_none_or(|v| v >= puff_off || v <= sip_off)
    };
    let mut spans: Vec<(usize, usize)> = Vec::new();
    for &fault in faults {
        if spans.last().is_some_and(|&(_, to)| fault < to) {
            continue;
        }
        let mut from = fault.min(signal.len());
        while from > 0 && outside(from - 1) {
            from -= 1;
        }
        let mut to = fault;
        while to < signal.len() && outside(to) {
            to += 1;
        }
        if (from..to).any(|t| signal.volts(t).is_some()) {
            spans.push((from, to));
        }
    }
    spans
}

/// The rest from the quiet stretches: level, noise and its extremes (the
/// 99.99th percentiles: a long session's single largest sample says more
/// about its length than about the noise).
fn rest(signal: &Signal, quiet: &[bool]) -> Result<Rest, FitError> {
    let values: Vec<f64> = (0..signal.len())
        .filter(|&t| quiet[t])
        .filter_map(|t| signal.volts(t))
        .collect();
    if values.len() < 3000 {
        return Err(FitError::new(
            "less than 3 s at rest in the session: ordinary use must have pauses to measure the rest",
        ));
    }
    let level = stats::median(&values);
    let mut up: Vec<f64> = values.iter().map(|v| v - level).collect();
    up.sort_unstable_by(f64::total_cmp);
    Ok(Rest {
        ms: values.len(),
        level,
        sd: stats::mad_sd(&values, level),
        white_sd: crate::fit::breaths::white_sd(&values),
        pauses_ms: values.len(),
        excursion_up: quantile_sorted(&up, 0.9999).max(0.0),
        excursion_down: (-quantile_sorted(&up, 0.0001)).max(0.0),
        spikes: 0,
        longest_spike_ms: 0,
    })
}

/// A burst as a region: its span, the rest level just before it, and its
/// levels.
fn region(
    signal: &Signal,
    quiet: &[bool],
    level: f64,
    b: &crate::control::detector::Burst,
) -> Region {
    let (start, end) = (b.start as usize, b.end as usize);
    let before: Vec<f64> = (start.saturating_sub(2000)..start)
        .filter(|&t| quiet[t])
        .filter_map(|t| signal.volts(t))
        .collect();
    let baseline = if before.len() >= 200 {
        stats::median(&before)
    } else {
        level
    };
    let sign = Direction::of(b.action.breath()).sign();
    breaths::region(signal, sign, start, end, baseline)
}

/// Two groups this far apart (difference of means over their pooled
/// spread, in logarithms) are two lengths the user means; closer, they are
/// one length and the boundary in use says which.
const SEPARATED: f64 = 3.0;

/// Splits durations into short and long: a two-part Gaussian mixture on
/// their logarithms, started from the shortest and longest tenth. When the
/// parts are not clearly apart (the user breathed one length only), the
/// boundary in use decides. `true` for long.
pub fn split(ms: &[f64], boundary: f64) -> Vec<bool> {
    let by_boundary: Vec<bool> = ms.iter().map(|&m| m >= boundary).collect();
    let logs: Vec<f64> = ms.iter().map(|m| m.max(1.0).ln()).collect();
    let mut sorted = logs.clone();
    sorted.sort_unstable_by(f64::total_cmp);
    let (low, high) = (quantile_sorted(&sorted, 0.1), quantile_sorted(&sorted, 0.9));
    let mut long: Vec<bool> = logs.iter().map(|&x| x - low > high - x).collect();
    let part = |long: &[bool], want: bool| {
        let v: Vec<f64> = logs
            .iter()
            .zip(long)
            .filter(|(_, l)| **l == want)
            .map(|(x, _)| *x)
            .collect();
        let (m, s) = stats::mean_sd(&v);
        (m, s.max(0.05), v.len() as f64 / logs.len().max(1) as f64)
    };
    for _ in 0..50 {
        let (short, long_part) = (part(&long, false), part(&long, true));
        if short.2 == 0.0 || long_part.2 == 0.0 {
            return by_boundary;
        }
        let density =
            |x: f64, (m, s, w): (f64, f64, f64)| w / s * (-0.5 * ((x - m) / s).powi(2)).exp();
        let next: Vec<bool> = logs
            .iter()
            .map(|&x| density(x, long_part) > density(x, short))
            .collect();
        if next == long {
            break;
        }
        long = next;
    }
    let (short, long_part) = (part(&long, false), part(&long, true));
    let pooled = ((short.1.powi(2) + long_part.1.powi(2)) / 2.0).sqrt();
    if short.2 == 0.0 || long_part.2 == 0.0 || (long_part.0 - short.0) / pooled < SEPARATED {
        return by_boundary;
    }
    long
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mixture_finds_the_users_own_boundary() {
        // Short breaths of 350 ms and long of 600 ms, read by a boundary
        // of 500 ms: 300–420 ms are short, 520–680 ms long.
        let ms = [
            320.0, 350.0, 380.0, 420.0, 340.0, 560.0, 600.0, 640.0, 680.0, 520.0, 300.0,
        ];
        let long = split(&ms, 500.0);
        assert_eq!(
            long,
            [
                false, false, false, false, false, true, true, true, true, true, false
            ]
        );
        // A boundary in use far off (200 ms) still finds the two groups.
        assert_eq!(split(&ms, 200.0), long);
        // One length only: the boundary in use decides.
        let one = [140.0, 150.0, 160.0, 170.0, 150.0, 130.0];
        assert_eq!(split(&one, 155.0), [false, false, true, true, false, false]);
    }
}
