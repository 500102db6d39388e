//! Where the breaths are, before any detector setting is known: the rest
//! at the start gives the level and its noise; every stretch well outside
//! that noise is a breath. Nothing here depends on a threshold to be
//! proposed, so the proposal can be made from what is found.

use crate::control::action::Breath;
use crate::control::mode::Direction;
use crate::fit::signal::{FitError, Signal};
use crate::fit::stats;

/// The rest at the start of the session.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rest {
    /// Ticks measured: from the start to shortly before the first breath.
    pub ms: usize,
    /// The level at rest (the neutral), volts: the median.
    pub level: f64,
    /// The noise: standard deviation, volts (from the median absolute
    /// deviation, so spikes do not count).
    pub sd: f64,
    /// The largest distance above the level, volts, spikes left out.
    pub excursion_up: f64,
    /// The largest distance below the level, volts, spikes left out.
    pub excursion_down: f64,
    /// Spikes: runs of samples far outside the noise, shorter than any
    /// breath.
    pub spikes: usize,
    /// The longest spike, ms (0 if none).
    pub longest_spike_ms: usize,
}

/// One breath as found: a stretch outside the rest's noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Region {
    /// Sip or puff.
    pub breath: Breath,
    /// First tick outside the noise.
    pub start: usize,
    /// First tick back inside it.
    pub end: usize,
    /// The rest level just before the breath, volts (the level drifts).
    pub baseline: f64,
    /// The 95th percentile of the distance from the baseline, volts.
    pub peak: f64,
    /// The plateau: the median distance over the samples above half the
    /// peak, volts.
    pub plateau: f64,
}

/// Shortest stretch outside the noise that is a breath, ms: shorter ones
/// are spikes.
pub const MIN_BREATH_MS: usize = 20;
/// A breath ends after this long back inside the noise, ms: a shorter dip
/// is part of it.
const END_MS: usize = 50;
/// The first and last this many ms of the initial rest are not measured
/// (the sensor settling; the breath's rise).
const REST_MARGIN_MS: usize = 200;
/// Shortest usable initial rest, ms.
pub const MIN_REST_MS: usize = 2000;
/// Time constant of the baseline's tracking between breaths, ms.
const TRACKING_MS: f64 = 2000.0;
/// Samples for the first estimate of the rest: the first 3 s.
const FIRST_LOOK_MS: usize = 3000;

/// Everything found in a session.
#[derive(Debug, Clone, PartialEq)]
pub struct Found {
    /// The initial rest.
    pub rest: Rest,
    /// The distance from the baseline beyond which a sample is outside the
    /// noise, volts.
    pub outside: f64,
    /// The breaths, in time order.
    pub regions: Vec<Region>,
}

/// Finds the rest and the breaths of a session that starts at rest.
pub fn find(signal: &Signal) -> Result<Found, FitError> {
    let first: Vec<f64> = (REST_MARGIN_MS..FIRST_LOOK_MS.min(signal.len()))
        .filter_map(|t| signal.volts(t))
        .collect();
    if first.len() < 1000 {
        return Err(FitError::new(format!(
            "the session has {} ms of signal at its start: a calibration starts with at least 5 s at rest",
            signal.len()
        )));
    }
    let level0 = stats::median(&first);
    let sd0 = stats::mad_sd(&first, level0);
    let outside = (6.0 * sd0).max(OUTSIDE_FLOOR_VOLTS);
    let regions = regions(signal, level0, outside);
    let rest_end = regions.first().map_or(signal.len(), |r| r.start);
    let rest = rest(signal, rest_end, outside)?;
    // The rest's own excursions widen the band a breath must leave.
    let outside = outside.max(1.2 * rest.excursion_up.max(rest.excursion_down));
    let regions = self::regions(signal, rest.level, outside);
    Ok(Found {
        rest,
        outside,
        regions,
    })
}

/// No narrower band than this counts as "outside the noise", volts: a
/// quantised sensor may show no noise at all.
const OUTSIDE_FLOOR_VOLTS: f64 = 0.05;

/// The initial rest, from the start to shortly before `end`.
fn rest(signal: &Signal, end: usize, outside: f64) -> Result<Rest, FitError> {
    let to = end.saturating_sub(REST_MARGIN_MS);
    if to < REST_MARGIN_MS + MIN_REST_MS {
        return Err(FitError::new(format!(
            "the first breath starts {:.1} s into the session: a calibration starts with at least 5 s at rest (check that the user waits for the first prompt)",
            end as f64 / 1000.0
        )));
    }
    let values: Vec<f64> = (REST_MARGIN_MS..to)
        .filter_map(|t| signal.volts(t))
        .collect();
    let level = stats::median(&values);
    let sd = stats::mad_sd(&values, level);
    let (mut up, mut down) = (0.0_f64, 0.0_f64);
    let (mut spikes, mut longest, mut run) = (0, 0, 0);
    let mut pending: Vec<f64> = Vec::new();
    for &v in &values {
        let d = v - level;
        if d.abs() > outside {
            run += 1;
            continue;
        }
        if run > 0 {
            spikes += 1;
            longest = longest.max(run);
            run = 0;
        }
        pending.push(d);
    }
    if run > 0 {
        spikes += 1;
        longest = longest.max(run);
    }
    for d in pending {
        up = up.max(d);
        down = down.max(-d);
    }
    Ok(Rest {
        ms: to - REST_MARGIN_MS,
        level,
        sd,
        excursion_up: up,
        excursion_down: down,
        spikes,
        longest_spike_ms: longest,
    })
}

/// A stretch being followed: its sign, first tick, ticks outside and last
/// tick outside.
#[derive(Clone, Copy)]
struct Stretch {
    sign: f64,
    start: usize,
    outside: usize,
    last: usize,
}

/// The stretches further than `outside` from a baseline that follows the
/// rest level between breaths.
fn regions(signal: &Signal, level: f64, outside: f64) -> Vec<Region> {
    let mut found = Vec::new();
    let mut baseline = level;
    let mut open: Option<Stretch> = None;
    let mut quiet_since = 0;
    let close = |s: Stretch, baseline: f64, found: &mut Vec<Region>| {
        if s.outside >= MIN_BREATH_MS {
            found.push(region(signal, s.sign, s.start, s.last + 1, baseline));
        }
    };
    for t in 0..signal.len() {
        let Some(v) = signal.volts(t) else { continue };
        let d = v - baseline;
        let sign = if d > outside {
            1.0
        } else if d < -outside {
            -1.0
        } else {
            0.0
        };
        let started = (sign != 0.0).then_some(Stretch {
            sign,
            start: t,
            outside: 1,
            last: t,
        });
        open = match open {
            Some(s) if sign == s.sign => Some(Stretch {
                outside: s.outside + 1,
                last: t,
                ..s
            }),
            Some(s) if t - s.last > END_MS || sign != 0.0 => {
                close(s, baseline, &mut found);
                quiet_since = t;
                started
            }
            Some(s) => Some(s),
            None if started.is_some() => started,
            None => {
                if t - quiet_since > REST_MARGIN_MS {
                    baseline += (v - baseline) / TRACKING_MS;
                }
                None
            }
        };
    }
    if let Some(s) = open {
        close(s, baseline, &mut found);
    }
    found
}

/// Measures the stretch `start..end` of a breath (`sign` +1 for a puff,
/// −1 for a sip) against `baseline`.
pub fn region(signal: &Signal, sign: f64, start: usize, end: usize, baseline: f64) -> Region {
    let mut distances: Vec<f64> = (start..end)
        .filter_map(|t| signal.volts(t))
        .map(|v| sign * (v - baseline))
        .collect();
    distances.sort_unstable_by(f64::total_cmp);
    let peak = stats::quantile_sorted(&distances, 0.95);
    let high: Vec<f64> = distances
        .iter()
        .copied()
        .filter(|d| *d >= peak / 2.0)
        .collect();
    Region {
        breath: if sign > 0.0 {
            Breath::Puff
        } else {
            Breath::Sip
        },
        start,
        end,
        baseline,
        peak,
        plateau: stats::median(&high),
    }
}

impl Region {
    /// How long the detector would see this breath past a threshold `on`
    /// volts from the baseline, ending back past `off`, each crossing
    /// confirmed by more than `glitch` ticks; `None` if it never passes
    /// `on` for longer than `glitch` ticks. Only its own crossings count:
    /// an onset released before this stretch begins belongs to the breath
    /// before (a sequence's breaths may be closer than the look-around),
    /// and one after the stretch ends to the next.
    pub fn duration_at(&self, signal: &Signal, on: f64, off: f64, glitch: usize) -> Option<usize> {
        let sign = Direction::of(self.breath).sign();
        let to = (self.end + LOOK_AROUND_MS).min(signal.len());
        let distance = |t: usize| signal.volts(t).map(|v| sign * (v - self.baseline));
        let mut from = self.start.saturating_sub(LOOK_AROUND_MS);
        loop {
            let start = confirmed_run(from, to, glitch, |t| distance(t).is_some_and(|d| d > on))
                .filter(|&s| s < self.end)?;
            let end = confirmed_run(start, to, glitch, |t| distance(t).is_some_and(|d| d < off))
                .unwrap_or(to);
            if end > self.start {
                return Some(end - start);
            }
            from = end;
        }
    }
}

/// How far around a stretch its threshold crossings are looked for, ms: a
/// lower threshold is crossed earlier on the rise.
const LOOK_AROUND_MS: usize = 300;

/// The first tick of the first run of more than `glitch` ticks where
/// `holds` is true, within `from..to`.
fn confirmed_run(
    from: usize,
    to: usize,
    glitch: usize,
    holds: impl Fn(usize) -> bool,
) -> Option<usize> {
    let mut run_start = None;
    for t in from..to {
        if holds(t) {
            let s = *run_start.get_or_insert(t);
            if t - s >= glitch {
                return Some(s);
            }
        } else {
            run_start = None;
        }
    }
    None
}
