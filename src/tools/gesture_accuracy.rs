//! How well a gesture set reads a session whose truth is known: the
//! recognizer run live over it, tick by tick as the control thread runs
//! it, each gesture recognised matched with the movement truly made, and
//! every other one counted as a false activation.

use serde::Serialize;

use crate::control::Tick;
use crate::control::gesture::{GestureEvent, Recognizer};
use crate::control::imu::ImuSample;
use crate::gestures::set::GestureSet;

/// A recognised gesture is the movement truly made when the two overlap
/// within this much, ms (the front end sees a movement begin and end a
/// little away from where the head starts and stops).
pub const OVERLAP_SLACK_MS: Tick = 300;

/// A gesture truly made: its name and where the head moved.
#[derive(Debug, Clone, PartialEq)]
pub struct Made {
    /// Its name in the set.
    pub name: String,
    /// First tick of the movement.
    pub start: Tick,
    /// Last tick of it.
    pub end: Tick,
}

/// One gesture's score.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GestureScore {
    /// Its name.
    pub name: String,
    /// Times it was made.
    pub made: usize,
    /// Recognised as itself.
    pub right: usize,
    /// Recognised as another gesture.
    pub confused: usize,
    /// Nothing recognised (rejected, or not seen).
    pub missed: usize,
}

impl GestureScore {
    /// Right of made, %.
    pub fn accuracy_pct(&self) -> f64 {
        if self.made == 0 {
            0.0
        } else {
            100.0 * self.right as f64 / self.made as f64
        }
    }
}

/// A session's score.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SessionScore {
    /// Per gesture of the set, in its order.
    pub gestures: Vec<GestureScore>,
    /// Gestures recognised where none was made: (tick, name).
    pub false_activations: Vec<(Tick, String)>,
    /// Hours of ordinary movement in the session.
    pub ordinary_hours: f64,
}

impl SessionScore {
    /// False activations per hour of ordinary movement.
    pub fn false_per_hour(&self) -> f64 {
        if self.ordinary_hours > 0.0 {
            self.false_activations.len() as f64 / self.ordinary_hours
        } else {
            0.0
        }
    }
}

/// The recognizer's events over `samples`, stepped on every tick from the
/// first sample's to the last one's, each sample held until the next.
pub fn live_events(
    recognizer: &mut Recognizer,
    samples: &[(Tick, ImuSample)],
) -> Vec<GestureEvent> {
    let mut events = Vec::new();
    let mut next: Option<Tick> = None;
    for (tick, sample) in samples {
        let mut t = next.unwrap_or(*tick);
        while t < *tick {
            events.extend(recognizer.step(t, None));
            t += 1;
        }
        events.extend(recognizer.step(*tick, Some(sample)));
        next = Some(tick + 1);
    }
    events
}

/// Scores `set` on `samples`, where `made` is what the person truly did
/// and `ordinary_ms` how long they moved ordinarily.
pub fn score(
    set: &GestureSet,
    samples: &[(Tick, ImuSample)],
    made: &[Made],
    ordinary_ms: Tick,
) -> Result<SessionScore, Vec<String>> {
    let mut recognizer = set.recognizer()?;
    let events = live_events(&mut recognizer, samples);
    let mut scores: Vec<GestureScore> = set
        .gestures
        .iter()
        .map(|g| GestureScore {
            name: g.name.clone(),
            made: 0,
            right: 0,
            confused: 0,
            missed: 0,
        })
        .collect();
    let mut taken = vec![false; made.len()];
    let mut false_activations = Vec::new();
    for event in &events {
        let GestureEvent::Recognised {
            gesture,
            start,
            end,
            ..
        } = *event
        else {
            continue;
        };
        let name = set.name(gesture);
        let truth = made.iter().enumerate().position(|(i, m)| {
            !taken.get(i).copied().unwrap_or(true)
                && start <= m.end + OVERLAP_SLACK_MS
                && end + OVERLAP_SLACK_MS >= m.start
        });
        match truth {
            Some(i) => {
                if let Some(t) = taken.get_mut(i) {
                    *t = true;
                }
                let meant = made.get(i).map_or("", |m| m.name.as_str());
                if let Some(score) = scores.iter_mut().find(|s| s.name == meant) {
                    if meant == name {
                        score.right += 1;
                    } else {
                        score.confused += 1;
                    }
                }
            }
            None => false_activations.push((start, name.to_string())),
        }
    }
    for m in made {
        if let Some(score) = scores.iter_mut().find(|s| s.name == m.name) {
            score.made += 1;
        }
    }
    for score in &mut scores {
        score.missed = score.made - score.right - score.confused;
    }
    Ok(SessionScore {
        gestures: scores,
        false_activations,
        ordinary_hours: ordinary_ms as f64 / 3_600_000.0,
    })
}
