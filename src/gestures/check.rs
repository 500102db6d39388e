//! What a clinician reads before a gesture set is used: each example left
//! out and recognised by the others (leave-one-out), the confusion
//! matrix, the activations that ordinary movement would cause per hour,
//! the gestures too alike to tell apart, and how accuracy trades against
//! false activations as the thresholds move. Every verdict is the core's:
//! the same segments, the same search, the same rule.

use serde::Serialize;

use crate::control::Tick;
use crate::control::gesture::{Frame, GestureId, Recognizer, Segment, Verdict, segments};
use crate::control::imu::ImuSample;
use crate::gestures::set::GestureSet;

/// A gesture that ordinary movement sets off more often than this, per
/// hour, is said to be imitated by it (the bar: one false
/// activation an hour).
pub const IMITATED_PER_HOUR: f64 = 1.0;

/// The thresholds' scales the trade-off is shown at.
pub const SCALES: [f64; 7] = [0.5, 0.7, 0.85, 1.0, 1.2, 1.5, 2.0];

/// Ordinary movement recorded: a name for it and its samples.
#[derive(Debug, Clone)]
pub struct Ordinary<'a> {
    /// Where it came from (a file, or "the recording's ordinary stretch").
    pub source: String,
    /// Its samples, in tick order; the core holds each until the next.
    pub samples: &'a [(Tick, ImuSample)],
}

/// One gesture's leave-one-out result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GestureResult {
    /// Its name.
    pub name: String,
    /// Its threshold.
    pub threshold: f64,
    /// Examples recorded.
    pub examples: usize,
    /// Recognised as itself with the others as templates.
    pub right: usize,
    /// Recognised as another gesture: (which, how many).
    pub confused: Vec<(String, usize)>,
    /// Rejected (above threshold or ambiguous).
    pub rejected: usize,
    /// Ordinary movement taken for it.
    pub ordinary_activations: usize,
}

/// An activation in ordinary movement: a gesture recognised where none
/// was meant.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Activation {
    /// Which recording.
    pub source: String,
    /// First tick of the movement.
    pub start: Tick,
    /// First tick after it.
    pub end: Tick,
    /// Taken for this gesture.
    pub gesture: String,
    /// At this distance (its threshold is in the results).
    pub distance: f64,
}

/// One row of the trade-off: every threshold scaled by `scale`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TradeOff {
    /// The thresholds' scale.
    pub scale: f64,
    /// Leave-one-out examples recognised as themselves, %.
    pub accuracy_pct: f64,
    /// Activations in the ordinary movement, per hour.
    pub activations_per_hour: f64,
}

/// Two gestures too alike to separate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TooAlike {
    /// The gesture whose examples land elsewhere.
    pub gesture: String,
    /// Where they land (or are nearest).
    pub other: String,
    /// Of its examples, how many are nearer the other than their own.
    pub nearer_other: usize,
    /// What to do.
    pub advice: String,
}

/// The whole check.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Check {
    /// Per gesture, in the set's order.
    pub gestures: Vec<GestureResult>,
    /// Leave-one-out examples right, of all.
    pub right: usize,
    /// Examples in all.
    pub examples: usize,
    /// Rows: the gesture made; columns: the gestures recognised, then
    /// "rejected".
    pub confusion: Vec<Vec<usize>>,
    /// Hours of ordinary movement checked.
    pub ordinary_hours: f64,
    /// The activations in it, at the set's thresholds.
    pub activations: Vec<Activation>,
    /// Pairs too alike.
    pub too_alike: Vec<TooAlike>,
    /// What to do about each gesture ordinary movement sets off more than
    /// [`IMITATED_PER_HOUR`].
    pub imitated: Vec<String>,
    /// Accuracy against activations per hour, thresholds scaled.
    pub trade_off: Vec<TradeOff>,
}

impl Check {
    /// Leave-one-out accuracy, %.
    pub fn accuracy_pct(&self) -> f64 {
        pct(self.right, self.examples)
    }

    /// Activations in ordinary movement per hour.
    pub fn activations_per_hour(&self) -> f64 {
        per_hour(self.activations.len(), self.ordinary_hours)
    }
}

fn pct(n: usize, of: usize) -> f64 {
    if of == 0 {
        0.0
    } else {
        100.0 * n as f64 / of as f64
    }
}

fn per_hour(n: usize, hours: f64) -> f64 {
    if hours > 0.0 { n as f64 / hours } else { 0.0 }
}

/// A recognizer for `set` without example `leave_out`, its thresholds
/// scaled by `scale`.
fn recognizer(
    set: &GestureSet,
    leave_out: Option<(usize, usize)>,
    scale: f64,
) -> Option<Recognizer> {
    Recognizer::new(set.config, set.templates(leave_out, scale)).ok()
}

/// What the core decides for `frames`.
fn verdict(recognizer: &Recognizer, frames: &[Frame]) -> Verdict {
    recognizer.verdict(&recognizer.classify(frames))
}

/// Leave-one-out at `scale`: per gesture, per example, the verdict.
fn leave_one_out(set: &GestureSet, scale: f64) -> Vec<Vec<Verdict>> {
    set.gestures
        .iter()
        .enumerate()
        .map(|(g, gesture)| {
            gesture
                .examples
                .iter()
                .enumerate()
                .map(|(e, example)| match recognizer(set, Some((g, e)), scale) {
                    Some(r) => verdict(&r, &example.frames),
                    None => Verdict::Rejected {
                        nearest: None,
                        distance: f64::INFINITY,
                        why: crate::control::gesture::RejectReason::AboveThreshold,
                    },
                })
                .collect()
        })
        .collect()
}

/// The recognised gesture of a verdict.
fn recognised(v: &Verdict) -> Option<GestureId> {
    match v {
        Verdict::Recognised { gesture, .. } => Some(*gesture),
        Verdict::Rejected { .. } => None,
    }
}

/// The segments of each ordinary recording, with its source.
struct OrdinarySegments {
    source: String,
    segments: Vec<Segment>,
}

/// The leave-one-out confusion matrix of `set`: rows the gesture made,
/// columns the gesture recognised, then "rejected" (as [`check`] gives
/// it, without the ordinary movement).
pub fn confusion(set: &GestureSet) -> Vec<Vec<usize>> {
    confusion_of(set.gestures.len(), &leave_one_out(set, 1.0))
}

/// The confusion matrix of `n` gestures' leave-one-out verdicts.
fn confusion_of(n: usize, loo: &[Vec<Verdict>]) -> Vec<Vec<usize>> {
    let mut confusion = vec![vec![0usize; n + 1]; n];
    for (row, verdicts) in confusion.iter_mut().zip(loo) {
        for v in verdicts {
            let column = recognised(v).map_or(n, |id| usize::from(id.0));
            if let Some(cell) = row.get_mut(column) {
                *cell += 1;
            }
        }
    }
    confusion
}

/// Checks `set` by leave-one-out and on `ordinary` movement.
pub fn check(set: &GestureSet, ordinary: &[Ordinary<'_>]) -> Check {
    let n = set.gestures.len();
    let loo = leave_one_out(set, 1.0);
    let confusion = confusion_of(n, &loo);
    let mut gestures = Vec::with_capacity(n);
    for (g, (gesture, verdicts)) in set.gestures.iter().zip(&loo).enumerate() {
        let mut result = GestureResult {
            name: gesture.name.clone(),
            threshold: gesture.threshold,
            examples: verdicts.len(),
            right: 0,
            confused: Vec::new(),
            rejected: 0,
            ordinary_activations: 0,
        };
        for v in verdicts {
            match recognised(v) {
                Some(id) if usize::from(id.0) == g => result.right += 1,
                Some(id) => {
                    let other = set.name(id).to_string();
                    match result.confused.iter_mut().find(|(name, _)| *name == other) {
                        Some((_, count)) => *count += 1,
                        None => result.confused.push((other, 1)),
                    }
                }
                None => result.rejected += 1,
            }
        }
        gestures.push(result);
    }
    let right = gestures.iter().map(|g| g.right).sum();
    let examples = gestures.iter().map(|g| g.examples).sum();

    let cut: Vec<OrdinarySegments> = ordinary
        .iter()
        .map(|o| OrdinarySegments {
            source: o.source.clone(),
            segments: segments(&set.config, o.samples.iter().copied()),
        })
        .collect();
    // Folded from +0.0: an empty sum of f64 is -0.0, printed "-0.00 h".
    let ordinary_hours: f64 = ordinary
        .iter()
        .map(|o| match (o.samples.first(), o.samples.last()) {
            (Some((a, _)), Some((b, _))) => (b - a) as f64 / 3_600_000.0,
            _ => 0.0,
        })
        .fold(0.0, |sum, h| sum + h);
    let activations_at = |scale: f64| -> Vec<Activation> {
        let Some(r) = recognizer(set, None, scale) else {
            return Vec::new();
        };
        let mut found = Vec::new();
        for o in &cut {
            for s in o.segments.iter().filter(|s| !s.too_long) {
                if let Verdict::Recognised { gesture, distance } = verdict(&r, &s.frames) {
                    found.push(Activation {
                        source: o.source.clone(),
                        start: s.start,
                        end: s.end,
                        gesture: set.name(gesture).to_string(),
                        distance,
                    });
                }
            }
        }
        found
    };
    let activations = activations_at(1.0);
    for activation in &activations {
        if let Some(g) = gestures.iter_mut().find(|g| g.name == activation.gesture) {
            g.ordinary_activations += 1;
        }
    }
    let imitated = gestures
        .iter()
        .filter(|g| per_hour(g.ordinary_activations, ordinary_hours) > IMITATED_PER_HOUR)
        .map(|g| {
            format!(
                "ordinary movement was taken for '{}' {} times in {:.2} h ({:.1} per hour): everyday movement imitates it; choose a gesture people seldom make by chance (a roll of the head: tilt_left, tilt_right, wobble), or drop it",
                g.name,
                g.ordinary_activations,
                ordinary_hours,
                per_hour(g.ordinary_activations, ordinary_hours)
            )
        })
        .collect();
    let trade_off = SCALES
        .iter()
        .map(|&scale| {
            let loo = if scale == 1.0 {
                loo.clone()
            } else {
                leave_one_out(set, scale)
            };
            let right: usize = loo
                .iter()
                .enumerate()
                .map(|(g, vs)| {
                    vs.iter()
                        .filter(|v| recognised(v).is_some_and(|id| usize::from(id.0) == g))
                        .count()
                })
                .sum();
            TradeOff {
                scale,
                accuracy_pct: pct(right, examples),
                activations_per_hour: per_hour(activations_at(scale).len(), ordinary_hours),
            }
        })
        .collect();
    let too_alike = too_alike(set, &loo);
    Check {
        gestures,
        right,
        examples,
        confusion,
        ordinary_hours,
        activations,
        too_alike,
        imitated,
        trade_off,
    }
}

/// Gestures whose examples are nearer another gesture than their own, or
/// taken for it in leave-one-out.
fn too_alike(set: &GestureSet, loo: &[Vec<Verdict>]) -> Vec<TooAlike> {
    let mut pairs = Vec::new();
    for (g, verdicts) in loo.iter().enumerate() {
        let name = set.name(GestureId(g as u8));
        let mut nearer: Vec<(GestureId, usize)> = Vec::new();
        for v in verdicts {
            let nearest = match v {
                Verdict::Recognised { gesture, .. } => Some(*gesture),
                Verdict::Rejected { nearest, .. } => *nearest,
            };
            if let Some(other) = nearest.filter(|id| usize::from(id.0) != g) {
                match nearer.iter_mut().find(|(id, _)| *id == other) {
                    Some((_, n)) => *n += 1,
                    None => nearer.push((other, 1)),
                }
            }
        }
        for (other, count) in nearer {
            let other = set.name(other);
            pairs.push(TooAlike {
                gesture: name.to_string(),
                other: other.to_string(),
                nearer_other: count,
                advice: format!(
                    "{count} of {} examples of '{name}' are nearer '{other}' than the rest of their own: redo '{name}' more distinctly, or drop one of the two",
                    verdicts.len()
                ),
            });
        }
    }
    pairs
}
