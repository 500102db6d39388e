//! The distances a set's thresholds and its check are read from: each
//! example against the other examples of its own gesture (left out of
//! them, as a new movement would be), and ordinary movement against every
//! gesture. Plain DTW as the core computes it, without pruning, so every
//! figure is exact.

use crate::control::gesture::{Frame, GestureConfig, comparable_lengths, dtw_distance};
use crate::gestures::set::GestureSet;

/// The distance from `frames` to the nearest of `templates` it may be
/// compared with (of a comparable length), by the core's banded DTW (the
/// band of each template's length); ∞ if none.
pub fn nearest<'a>(
    config: &GestureConfig,
    frames: &[Frame],
    templates: impl IntoIterator<Item = &'a [Frame]>,
) -> f64 {
    templates
        .into_iter()
        .filter(|t| comparable_lengths(frames.len(), t.len()))
        .map(|t| dtw_distance(frames, t, config.band_frames(t.len()), f64::INFINITY))
        .fold(f64::INFINITY, f64::min)
}

/// For each gesture, each example's distance to the nearest other example
/// of the same gesture.
pub fn own(set: &GestureSet) -> Vec<Vec<f64>> {
    set.gestures
        .iter()
        .map(|gesture| {
            gesture
                .examples
                .iter()
                .enumerate()
                .map(|(e, example)| {
                    let others = gesture
                        .examples
                        .iter()
                        .enumerate()
                        .filter(|&(o, _)| o != e)
                        .map(|(_, other)| other.frames.as_slice());
                    nearest(&set.config, &example.frames, others)
                })
                .collect()
        })
        .collect()
}

/// For each gesture, the distance from `frames` to its nearest example.
pub fn to_each(set: &GestureSet, frames: &[Frame]) -> Vec<f64> {
    set.gestures
        .iter()
        .map(|gesture| {
            let templates = gesture.examples.iter().map(|e| e.frames.as_slice());
            nearest(&set.config, frames, templates)
        })
        .collect()
}
