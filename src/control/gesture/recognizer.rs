//! Segments to gestures: the nearest template by banded DTW, or a
//! rejection. Motion that matches nothing is rejected, never guessed.
//!
//! * Every template is a candidate; LB_Keogh skips those whose bound
//!   already exceeds what could still matter, and the DTW of the rest
//!   abandons early at the same bound.
//! * What could matter: a distance below the nearest gesture's so far
//!   (a new nearest), or, for a different gesture, within the ambiguity
//!   margin of it; and only below that gesture's own best.
//! * Rejected: a too-long segment; no threshold or a distance above the
//!   nearest gesture's threshold; another gesture within
//!   `ambiguity_margin` of the nearest; a movement that turns the head
//!   less than [`MIN_SIZE`] of the least any example of the nearest
//!   gesture turned it (a small copy of the gesture: talk's nods of
//!   emphasis, which DTW on the features alone finds as near as the
//!   person's own nods when a tremor blurs them).

use crate::control::Tick;
use crate::control::gesture::config::GestureConfig;
use crate::control::gesture::dtw::{Envelope, dtw_distance, lb_keogh};
use crate::control::gesture::features::{Frame, RestEstimate, excursion};
use crate::control::gesture::segmenter::Segmenter;
use crate::control::gesture::templates::{GestureId, GestureTemplates, MAX_GESTURES};
use crate::control::imu::ImuSample;

/// Why a segment was rejected. Serialized by its name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RejectReason {
    /// Further from the nearest gesture than its threshold (or it has none,
    /// or there are no templates).
    AboveThreshold,
    /// A different gesture is within the ambiguity margin of the nearest.
    Ambiguous,
    /// The segment lasted longer than `max_ms`.
    TooLong,
    /// The movement turned the head less than [`MIN_SIZE`] of the least
    /// any example of the nearest gesture did.
    TooSmall,
}

/// A movement is taken for a gesture only if it turns the head at least
/// this fraction of the least that any of the gesture's examples turned
/// it ([`excursion`]; 0.75: a person repeats a gesture's size within
/// ±15 %, so a new example is at least 0.74 of their smallest of five;
/// the simulated people's held-out gestures came at 0.80 or more. A nod
/// of emphasis in talk is 4–8°, about half of a deliberate 15° nod,
/// though the talk's own 1–3° swings add to it).
pub const MIN_SIZE: f64 = 0.75;

/// What the recognizer says about a segment that ended. `Copy`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GestureEvent {
    /// The segment is this gesture.
    Recognised {
        /// Which gesture.
        gesture: GestureId,
        /// First tick of the segment.
        start: Tick,
        /// First tick after it.
        end: Tick,
        /// DTW distance to the nearest template.
        distance: f64,
    },
    /// The segment is no gesture.
    Rejected {
        /// First tick of the segment.
        start: Tick,
        /// First tick after it.
        end: Tick,
        /// The nearest gesture, if any was compared.
        nearest: Option<GestureId>,
        /// Its distance (∞ if none).
        distance: f64,
        /// Why.
        why: RejectReason,
    },
}

/// A movement is compared only with templates at most 1.5 times longer
/// or shorter than it: DTW would otherwise match a slow glance down and
/// back with a quick nod, shapes that differ mostly in speed. A person
/// repeats their own gesture within ±15 %.
pub fn comparable_lengths(a: usize, b: usize) -> bool {
    2 * a <= 3 * b && 2 * b <= 3 * a
}

/// The decision on one segment's frames. `Copy`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Verdict {
    /// The frames are this gesture, at this distance.
    Recognised {
        /// Which gesture.
        gesture: GestureId,
        /// DTW distance to its nearest template.
        distance: f64,
    },
    /// The frames are no gesture.
    Rejected {
        /// The nearest gesture, if any was compared.
        nearest: Option<GestureId>,
        /// Its distance (∞ if none).
        distance: f64,
        /// Why.
        why: RejectReason,
    },
}

/// The nearest gestures to a sequence of frames. `Copy`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Classification {
    /// The nearest gesture and its distance (its nearest template's).
    pub nearest: Option<(GestureId, f64)>,
    /// The nearest other gesture and its distance: exact when within the
    /// ambiguity margin of the nearest; beyond it, the search may have
    /// skipped that gesture's templates, so the distance may be too high
    /// or the gesture absent.
    pub runner_up: Option<(GestureId, f64)>,
    /// How far the frames turned the head, rad ([`excursion`]).
    pub excursion: f64,
}

/// A template ready to compare: its frames, gesture and envelope.
#[derive(Debug, Clone)]
struct Prepared {
    gesture: GestureId,
    frames: Vec<Frame>,
    envelope: Envelope,
}

/// The gesture front end: samples in, gesture events out. Construct once
/// (allocates); [`Recognizer::step`] is RT-safe (no allocation, no panic).
#[derive(Debug, Clone)]
pub struct Recognizer {
    config: GestureConfig,
    segmenter: Segmenter,
    templates: Vec<Prepared>,
    thresholds: [Option<f64>; MAX_GESTURES],
    /// Per gesture, the least [`excursion`] of its templates (∞ if none).
    least_excursion: [f64; MAX_GESTURES],
}

impl Recognizer {
    /// A recognizer with `templates` (their envelopes are made here), or
    /// every bad field of `config`. Not RT-safe.
    pub fn new(config: GestureConfig, templates: GestureTemplates) -> Result<Self, Vec<String>> {
        config.validate()?;
        let mut thresholds = [None; MAX_GESTURES];
        for (id, slot) in thresholds.iter_mut().enumerate() {
            *slot = templates.threshold(GestureId(id as u8));
        }
        let mut least_excursion = [f64::INFINITY; MAX_GESTURES];
        for t in templates.iter() {
            if let Some(least) = least_excursion.get_mut(usize::from(t.gesture.0)) {
                *least = least.min(excursion(&t.frames, config.frame_ms));
            }
        }
        let templates = templates
            .iter()
            .map(|t| Prepared {
                gesture: t.gesture,
                envelope: Envelope::of(&t.frames, config.band_frames(t.frames.len())),
                frames: t.frames.clone(),
            })
            .collect();
        Ok(Recognizer {
            config,
            segmenter: Segmenter::new(&config),
            templates,
            thresholds,
            least_excursion,
        })
    }

    /// Tick `now`, with the sensor's new sample if one arrived (else the
    /// last is held). Returns the verdict on a segment that ended on this
    /// tick. RT-safe.
    pub fn step(&mut self, now: Tick, sample: Option<&ImuSample>) -> Option<GestureEvent> {
        let end = self.segmenter.step(now, sample)?;
        let (start, end_tick) = (end.start, end.end);
        if end.too_long {
            return Some(GestureEvent::Rejected {
                start,
                end: end_tick,
                nearest: None,
                distance: f64::INFINITY,
                why: RejectReason::TooLong,
            });
        }
        let found = self.classify(self.segmenter.frames());
        Some(match self.verdict(&found) {
            Verdict::Recognised { gesture, distance } => GestureEvent::Recognised {
                gesture,
                start,
                end: end_tick,
                distance,
            },
            Verdict::Rejected {
                nearest,
                distance,
                why,
            } => GestureEvent::Rejected {
                start,
                end: end_tick,
                nearest,
                distance,
                why,
            },
        })
    }

    /// A movement is under way (see [`Segmenter::in_motion`]).
    pub fn in_motion(&self) -> bool {
        self.segmenter.in_motion()
    }

    /// The head at rest, as last tracked: gyro bias and gravity.
    pub fn rest(&self) -> &RestEstimate {
        self.segmenter.rest()
    }

    /// The nearest gesture to `frames` and the nearest other one, by the
    /// same search [`Recognizer::step`] makes. RT-safe.
    pub fn classify(&self, frames: &[Frame]) -> Classification {
        let mut best = [f64::INFINITY; MAX_GESTURES];
        let mut nearest: Option<(GestureId, f64)> = None;
        let widen = 1.0 + self.config.ambiguity_margin;
        for template in &self.templates {
            let index = usize::from(template.gesture.0);
            let Some(own) = best.get(index).copied() else {
                continue;
            };
            if !comparable_lengths(frames.len(), template.frames.len()) {
                continue;
            }
            let bound = own.min(nearest.map_or(f64::INFINITY, |(_, d)| d * widen));
            if lb_keogh(frames, &template.envelope) > bound {
                continue;
            }
            let d = dtw_distance(frames, &template.frames, template.envelope.band, bound);
            if d < own {
                if let Some(slot) = best.get_mut(index) {
                    *slot = d;
                }
                if nearest.is_none_or(|(_, n)| d < n) {
                    nearest = Some((template.gesture, d));
                }
            }
        }
        let runner_up = nearest.and_then(|(g, _)| {
            best.iter()
                .enumerate()
                .filter(|&(i, d)| i != usize::from(g.0) && d.is_finite())
                .min_by(|a, b| a.1.total_cmp(b.1))
                .map(|(i, &d)| (GestureId(i as u8), d))
        });
        Classification {
            nearest,
            runner_up,
            excursion: excursion(frames, self.config.frame_ms),
        }
    }

    /// What the core decides for a segment classified as `found`: the
    /// nearest gesture if within its threshold, no other gesture is
    /// within the ambiguity margin and the movement is not too small
    /// for it; else rejected, with why. RT-safe.
    pub fn verdict(&self, found: &Classification) -> Verdict {
        let Some((gesture, distance)) = found.nearest else {
            return Verdict::Rejected {
                nearest: None,
                distance: f64::INFINITY,
                why: RejectReason::AboveThreshold,
            };
        };
        let threshold = self
            .thresholds
            .get(usize::from(gesture.0))
            .copied()
            .flatten();
        if threshold.is_none_or(|t| distance > t) {
            Verdict::Rejected {
                nearest: Some(gesture),
                distance,
                why: RejectReason::AboveThreshold,
            }
        } else if found
            .runner_up
            .is_some_and(|(_, d)| d <= distance * (1.0 + self.config.ambiguity_margin))
        {
            Verdict::Rejected {
                nearest: Some(gesture),
                distance,
                why: RejectReason::Ambiguous,
            }
        } else if self
            .least_excursion
            .get(usize::from(gesture.0))
            .is_some_and(|&least| found.excursion < MIN_SIZE * least)
        {
            Verdict::Rejected {
                nearest: Some(gesture),
                distance,
                why: RejectReason::TooSmall,
            }
        } else {
            Verdict::Recognised { gesture, distance }
        }
    }

    /// The frames of the last segment that ended.
    pub fn frames(&self) -> &[Frame] {
        self.segmenter.frames()
    }

    /// The settings it runs with.
    pub fn config(&self) -> &GestureConfig {
        &self.config
    }

    /// Back to rest with no sample (the templates stay). RT-safe.
    pub fn reset(&mut self) {
        self.segmenter.reset();
    }

    /// Back to rest from the next sample's posture, keeping the gyro's
    /// bias. RT-safe.
    pub fn restart(&mut self) {
        self.segmenter.restart();
    }
}
