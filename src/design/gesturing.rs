//! A person's gestures as the designer needs them, from their gesture
//! set: how long each takes them (its recorded examples' mean length, then
//! the front end's `rest_ms` of stillness before it is read) and how the
//! recognizer reads it (the set's leave-one-out check: each example left
//! out and recognised by the others as itself, as another gesture, or
//! rejected).

use serde::Serialize;

use crate::control::gesture::name::GestureName;
use crate::gestures::check::confusion;
use crate::gestures::set::GestureSet;

/// One gesture as this person makes it and the recognizer reads it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GestureStats {
    /// Its name in the set.
    pub name: GestureName,
    /// Its examples' mean length, from the movement's start to its end
    /// as the front end cut them, ms.
    pub mean_ms: f64,
    /// Examples it was measured on.
    pub examples: usize,
    /// Chance it is rejected (read as nothing): its examples rejected in
    /// leave-one-out.
    pub rejected: f64,
    /// Chance it is read as another of the person's gestures, each: its
    /// examples taken for that gesture in leave-one-out.
    pub taken_for: Vec<TakenFor>,
}

/// A gesture read as another.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TakenFor {
    /// The gesture read.
    pub gesture: GestureName,
    /// Its place in the set.
    #[serde(skip)]
    pub index: usize,
    /// The chance.
    pub p: f64,
}

/// A person's gestures and where the figures come from.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Gesturing {
    /// The set, in words (its file).
    pub source: String,
    /// From a gesture's end to the front end reading it: `rest_ms` of
    /// stillness, ms.
    pub read_ms: f64,
    /// The gestures, in the set's order.
    pub gestures: Vec<GestureStats>,
}

impl Gesturing {
    /// The gestures of `set` (named `source`): each one's mean length
    /// from its examples, its misreadings from the set's leave-one-out
    /// confusion matrix. An error for a name the core cannot carry (a set
    /// read from a file never has one).
    pub fn of_set(set: &GestureSet, source: &str) -> Result<Gesturing, String> {
        let matrix = confusion(set);
        let mut gestures = Vec::with_capacity(set.gestures.len());
        for (g, (gesture, row)) in set.gestures.iter().zip(&matrix).enumerate() {
            let name = GestureName::new(&gesture.name)
                .ok_or_else(|| format!("`{}` is not a gesture's name", gesture.name))?;
            let examples = gesture.examples.len();
            let share = |count: usize| count as f64 / examples.max(1) as f64;
            let mean_ms = gesture
                .examples
                .iter()
                .map(|e| e.end.saturating_sub(e.start) as f64)
                .sum::<f64>()
                / examples.max(1) as f64;
            let taken_for = row
                .iter()
                .take(set.gestures.len())
                .enumerate()
                .filter(|(h, count)| *h != g && **count > 0)
                .filter_map(|(h, count)| {
                    Some(TakenFor {
                        gesture: GestureName::new(&set.gestures.get(h)?.name)?,
                        index: h,
                        p: share(*count),
                    })
                })
                .collect();
            gestures.push(GestureStats {
                name,
                mean_ms,
                examples,
                rejected: share(row.last().copied().unwrap_or(0)),
                taken_for,
            });
        }
        Ok(Gesturing {
            source: source.to_string(),
            read_ms: f64::from(set.config.rest_ms),
            gestures,
        })
    }

    /// Gesture `k`'s time from the movement's start to the front end
    /// reading it, ms.
    pub fn time_ms(&self, k: usize) -> f64 {
        self.gestures
            .get(k)
            .map_or(f64::INFINITY, |g| g.mean_ms + self.read_ms)
    }

    /// The place in the set of the gesture called `name`.
    pub fn index(&self, name: &GestureName) -> Option<usize> {
        self.gestures.iter().position(|g| g.name == *name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The simulated `typical` person's six gestures (fixtures/gesture-user).
    fn typical() -> GestureSet {
        GestureSet::from_toml(include_str!("../../fixtures/gesture-user/gestures.toml")).unwrap()
    }

    #[test]
    fn each_gesture_is_timed_from_its_examples_and_read_as_leave_one_out_reads_it() {
        let set = typical();
        let g = Gesturing::of_set(&set, "typical").unwrap();
        assert_eq!(g.read_ms, 300.0);
        for (stats, gesture) in g.gestures.iter().zip(&set.gestures) {
            let total: u64 = gesture.examples.iter().map(|e| e.end - e.start).sum();
            assert_eq!(stats.mean_ms, total as f64 / 5.0, "{}", gesture.name);
            // 5/5 in leave-one-out: never rejected, never another.
            assert_eq!((stats.rejected, stats.taken_for.len()), (0.0, 0));
        }
        assert_eq!(g.gestures[0].name.as_str(), "nod");
        assert_eq!(g.time_ms(0), g.gestures[0].mean_ms + 300.0);
        assert_eq!(g.time_ms(6), f64::INFINITY);
    }

    #[test]
    fn two_examples_swapped_show_as_a_confused_pair() {
        // The 5th nod recorded as a shake and the 5th shake as a nod, as
        // if the person made the wrong one when prompted.
        let mut set = typical();
        let nod = set.gestures[0].examples[4].clone();
        set.gestures[0].examples[4] = std::mem::replace(&mut set.gestures[2].examples[4], nod);
        let g = Gesturing::of_set(&set, "swapped").unwrap();
        // As `gestures check` gives it: of the five nods left out, one
        // is read as a shake and one rejected (as near a shake example);
        // of the shakes, two are read as nods.
        let nod = &g.gestures[0];
        assert_eq!(nod.rejected, 0.2);
        assert_eq!(nod.taken_for.len(), 1);
        assert_eq!(
            (
                nod.taken_for[0].gesture.as_str(),
                nod.taken_for[0].index,
                nod.taken_for[0].p
            ),
            ("shake", 2, 0.2)
        );
        let shake = &g.gestures[2];
        assert_eq!(shake.rejected, 0.0);
        assert_eq!(
            (shake.taken_for[0].gesture.as_str(), shake.taken_for[0].p),
            ("nod", 0.4)
        );
        assert!(g.gestures[1].taken_for.is_empty());
    }
}
