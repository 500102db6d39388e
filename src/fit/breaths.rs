//! Where the breaths are, before any detector setting is known: the rest
//! at the start gives the level; every stretch well outside what the rest
//! does is a breath. What the rest does is measured, not assumed Gaussian:
//! its largest excursions over the opening rest and the pauses between
//! breaths (a tremor, mains hum, a wandering level), plus a margin for the
//! sample-to-sample noise. Nothing here depends on a threshold to be
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
    /// The spread: standard deviation, volts (from the median absolute
    /// deviation, so spikes do not count). A tremor or hum counts.
    pub sd: f64,
    /// The sample-to-sample noise: standard deviation, volts, from the
    /// differences of neighbouring samples (a 4–9 Hz tremor or a slow
    /// wander barely moves between two samples; spikes do not count).
    pub white_sd: f64,
    /// The largest distance above the level, volts, over the opening rest
    /// and the pauses between breaths, spikes left out.
    pub excursion_up: f64,
    /// The largest distance below the level, likewise.
    pub excursion_down: f64,
    /// Time at rest measured in the pauses between breaths, ms.
    pub pauses_ms: usize,
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
    /// How far the signal swings from the rest level in the first
    /// seconds, volts (a breath there left out).
    pub opening_swing: f64,
    /// The furthest the signal stayed from the rest level for a whole
    /// [`MIN_BREATH_MS`] after the first seconds, volts: how strong the
    /// strongest breath was, found or not.
    pub strongest: f64,
}

/// The level the session starts at: the median of its first look at the
/// rest (`None` if under a second of it is there). Says which scale the
/// signal is in before anything is fitted.
pub fn opening_level(signal: &Signal) -> Option<f64> {
    let first: Vec<f64> = (REST_MARGIN_MS..FIRST_LOOK_MS.min(signal.len()))
        .filter_map(|t| signal.volts(t))
        .collect();
    (first.len() >= 1000).then(|| stats::median(&first))
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
    let opening_swing = first_swing(&first, level0);
    let mut outside = band(white_sd(&first), opening_swing);
    let mut level = level0;
    // A tremor that waxes after the first look, a level that wanders
    // faster than the baseline follows it: the band widens until the rest
    // stays inside it.
    let mut widenings = 0;
    let (regions, rest) = loop {
        let (regions, quiet) = followed(signal, &Baseline::Tracking(level), outside);
        let rest = rest(signal, &regions, &quiet, outside)?;
        let wider = band(rest.white_sd, rest.excursion_up.max(rest.excursion_down));
        if wider <= outside || widenings == MAX_WIDENINGS {
            break (regions, rest);
        }
        outside = wider;
        level = rest.level;
        widenings += 1;
    };
    Ok(Found {
        opening_swing,
        strongest: strongest(signal, rest.level),
        rest,
        outside,
        regions,
    })
}

/// The breaths and the rest between them, the baseline followed through
/// each breath: first tracked (held through a breath), then drawn between
/// the rests found on either side, until the breaths found stay the same.
fn followed(signal: &Signal, start: &Baseline, outside: f64) -> (Vec<Region>, Vec<Quiet>) {
    let (mut regions, mut quiet) = regions(signal, start, outside);
    for _ in 0..ANCHOR_PASSES {
        let (again, again_quiet) = self::regions(signal, &Baseline::anchored(&quiet), outside);
        let same = again.len() == regions.len()
            && again.iter().zip(&regions).all(|(a, b)| a.start == b.start);
        (regions, quiet) = (again, again_quiet);
        if same {
            break;
        }
    }
    (regions, quiet)
}

/// [`Found::strongest`], from `level`.
fn strongest(signal: &Signal, level: f64) -> f64 {
    let distance: Vec<f64> = (FIRST_LOOK_MS..signal.len())
        .map(|t| signal.volts(t).map_or(0.0, |v| (v - level).abs()))
        .collect();
    distance
        .windows(MIN_BREATH_MS)
        .map(|w| w.iter().copied().fold(f64::INFINITY, f64::min))
        .fold(0.0, f64::max)
}

/// The band a breath must leave, volts: past the rest's largest excursion
/// by a fifth, and past six standard deviations of its sample-to-sample
/// noise (an hour of Gaussian noise reaches further than a few seconds
/// of it).
fn band(white_sd: f64, excursion: f64) -> f64 {
    (6.0 * white_sd)
        .max(1.2 * excursion)
        .max(OUTSIDE_FLOOR_VOLTS)
}

/// How many times the band may widen before the breaths are taken as
/// found.
const MAX_WIDENINGS: usize = 12;

/// How far the first look's samples swing from `level`, volts: the
/// furthest within three (robust) standard deviations, so a tremor's
/// peaks count and a breath in the first seconds does not.
fn first_swing(values: &[f64], level: f64) -> f64 {
    let within = 3.0 * stats::mad_sd(values, level);
    values
        .iter()
        .map(|v| (v - level).abs())
        .filter(|d| *d <= within)
        .fold(0.0, f64::max)
}

/// The largest distance above and below `level` of the `values` within
/// `outside` of it (further ones are spikes), volts.
fn largest(values: &[f64], level: f64, outside: f64) -> (f64, f64) {
    values
        .iter()
        .map(|v| v - level)
        .filter(|d| d.abs() <= outside)
        .fold((0.0_f64, 0.0_f64), |(up, down), d| {
            (up.max(d), down.max(-d))
        })
}

/// The standard deviation of the sample-to-sample noise: of the
/// differences of neighbouring samples (robustly, from their median
/// absolute deviation), divided by √2.
pub fn white_sd(values: &[f64]) -> f64 {
    let diffs: Vec<f64> = values.windows(2).map(|w| w[1] - w[0]).collect();
    if diffs.is_empty() {
        return 0.0;
    }
    stats::mad_sd(&diffs, 0.0) / std::f64::consts::SQRT_2
}

/// No narrower band than this counts as "outside the noise", volts: a
/// quantised sensor may show no noise at all.
const OUTSIDE_FLOOR_VOLTS: f64 = 0.05;

/// The rest: the opening one, from the start to shortly before the first
/// of `regions`, and the pauses between them (`quiet`: each sample's
/// distance from the baseline that follows the level); samples further
/// than `outside` from the level are spikes.
fn rest(
    signal: &Signal,
    regions: &[Region],
    quiet: &[Quiet],
    outside: f64,
) -> Result<Rest, FitError> {
    let end = regions.first().map_or(signal.len(), |r| r.start);
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
    let (mut spikes, mut longest, mut run) = (0, 0, 0);
    let mut inside: Vec<f64> = Vec::new();
    for &v in &values {
        if (v - level).abs() > outside {
            run += 1;
            continue;
        }
        if run > 0 {
            spikes += 1;
            longest = longest.max(run);
            run = 0;
        }
        inside.push(v);
    }
    if run > 0 {
        spikes += 1;
        longest = longest.max(run);
    }
    let (mut up, mut down) = largest(&inside, level, outside);
    let after_opening = regions.first().map_or(usize::MAX, |r| r.end);
    let mut next = regions.iter().map(|r| r.start).peekable();
    let mut pauses_ms = 0;
    for &Quiet { t, distance: d, .. } in quiet.iter().filter(|q| q.t >= after_opening) {
        while next.peek().is_some_and(|&s| s <= t) {
            next.next();
        }
        let before_breath = next.peek().is_some_and(|&s| s - t <= REST_MARGIN_MS);
        if before_breath || d.abs() > outside {
            continue;
        }
        up = up.max(d);
        down = down.max(-d);
        pauses_ms += 1;
    }
    Ok(Rest {
        ms: to - REST_MARGIN_MS,
        level,
        sd,
        white_sd: white_sd(&values),
        excursion_up: up,
        excursion_down: down,
        pauses_ms,
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

/// The rest level a breath is measured from, at each tick.
enum Baseline {
    /// Follows the level between breaths from this start, and holds it
    /// through each breath.
    Tracking(f64),
    /// Drawn straight between levels measured at rest on either side
    /// (`(tick, volts)` in time order), so a level that wanders during a
    /// long breath is followed through it.
    Anchored(Vec<(usize, f64)>),
}

impl Baseline {
    /// Anchors from the samples at rest: every [`ANCHOR_MS`] of rest, the
    /// mean of the rest within [`ANCHOR_WINDOW_MS`] either side (long
    /// enough to average out a tremor, short against a wandering level).
    fn anchored(quiet: &[Quiet]) -> Baseline {
        let mut anchors: Vec<(usize, f64)> = Vec::new();
        let (mut from, mut to, mut sum) = (0, 0, 0.0);
        for q in quiet {
            if anchors.last().is_some_and(|a| q.t < a.0 + ANCHOR_MS) {
                continue;
            }
            while to < quiet.len() && quiet[to].t <= q.t + ANCHOR_WINDOW_MS {
                sum += quiet[to].volts;
                to += 1;
            }
            while quiet[from].t + ANCHOR_WINDOW_MS < q.t {
                sum -= quiet[from].volts;
                from += 1;
            }
            anchors.push((q.t, sum / (to - from) as f64));
        }
        Baseline::Anchored(anchors)
    }
}

/// Rest between anchors of the baseline, ms.
const ANCHOR_MS: usize = 250;
/// Rest either side of an anchor averaged into it, ms.
const ANCHOR_WINDOW_MS: usize = 1000;
/// Times the anchored baseline is redrawn from the rest it finds.
const ANCHOR_PASSES: usize = 3;

/// A sample at rest: its tick, reading and distance from the baseline.
#[derive(Debug, Clone, Copy)]
struct Quiet {
    t: usize,
    volts: f64,
    distance: f64,
}

/// Where the baseline is at each tick, in time order.
struct BaselineAt<'a> {
    baseline: &'a Baseline,
    tracked: f64,
    next: usize,
}

impl BaselineAt<'_> {
    fn new(baseline: &Baseline) -> BaselineAt<'_> {
        let tracked = match baseline {
            Baseline::Tracking(level) => *level,
            Baseline::Anchored(anchors) => anchors.first().map_or(0.0, |a| a.1),
        };
        BaselineAt {
            baseline,
            tracked,
            next: 0,
        }
    }

    /// The baseline at `t` (never earlier than the last asked).
    fn at(&mut self, t: usize) -> f64 {
        let Baseline::Anchored(anchors) = self.baseline else {
            return self.tracked;
        };
        while self.next < anchors.len() && anchors[self.next].0 <= t {
            self.next += 1;
        }
        match (
            self.next.checked_sub(1).map(|i| anchors[i]),
            anchors.get(self.next),
        ) {
            (Some((t0, v0)), Some(&(t1, v1))) => {
                v0 + (v1 - v0) * (t - t0) as f64 / (t1 - t0) as f64
            }
            (Some((_, v)), None) | (None, Some(&(_, v))) => v,
            (None, None) => self.tracked,
        }
    }

    /// A sample at rest: a tracking baseline moves toward it.
    fn rest_at(&mut self, volts: f64) {
        if let Baseline::Tracking(_) = self.baseline {
            self.tracked += (volts - self.tracked) / TRACKING_MS;
        }
    }
}

/// The stretches further than `outside` from the baseline, and the
/// samples at rest (from shortly after a stretch to the next).
fn regions(signal: &Signal, baseline: &Baseline, outside: f64) -> (Vec<Region>, Vec<Quiet>) {
    let mut found = Vec::new();
    let mut quiet = Vec::new();
    let mut at = BaselineAt::new(baseline);
    let mut held = at.at(0);
    let mut open: Option<Stretch> = None;
    let mut quiet_since = 0;
    let close = |s: Stretch, baseline: f64, found: &mut Vec<Region>| {
        if s.outside >= MIN_BREATH_MS {
            found.push(region(signal, s.sign, s.start, s.last + 1, baseline));
        }
    };
    for t in 0..signal.len() {
        let Some(v) = signal.volts(t) else { continue };
        let level = at.at(t);
        let d = v - level;
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
            // A sample past the other side (a spike to the other rail)
            // does not end a breath; a stretch there that lasts does.
            Some(s) if t - s.last > END_MS || sign == -s.sign && t - s.last > END_MS / 2 => {
                close(s, held, &mut found);
                quiet_since = t;
                held = level;
                started
            }
            Some(s) => Some(s),
            None if started.is_some() => {
                held = level;
                started
            }
            None => {
                if t - quiet_since > REST_MARGIN_MS {
                    quiet.push(Quiet {
                        t,
                        volts: v,
                        distance: d,
                    });
                    at.rest_at(v);
                }
                None
            }
        };
    }
    if let Some(s) = open {
        close(s, held, &mut found);
    }
    (found, quiet)
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
