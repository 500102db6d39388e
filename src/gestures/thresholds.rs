//! Each gesture's rejection threshold, from the person's own data: wide
//! enough to take their own examples (each measured against the others,
//! as a new movement will be) with room for how a gesture varies from day
//! to day, and short of every ordinary movement recorded, so motion that
//! is not a gesture is rejected. Where the two cannot both hold, the
//! ordinary movement wins: a missed gesture is repeated, a false one
//! moves the arm.

use crate::control::gesture::Frame;
use crate::gestures::distances;
use crate::gestures::set::GestureSet;

/// The threshold is this many times the largest distance between an
/// example and the nearest other of its gesture: a new movement is
/// compared with all of them, but varies more than one session does
/// (five examples rarely span how a held tilt's hold or a shake's size
/// varies: held out, the simulated people's 29th-nearest of 30 came at
/// up to 1.5–1.8 times the largest of the five).
pub const OWN_MARGIN: f64 = 1.5;
/// …and at most this fraction of the nearest ordinary movement's distance.
pub const ORDINARY_MARGIN: f64 = 0.8;

/// How a gesture's threshold was chosen.
#[derive(Debug, Clone, PartialEq)]
pub struct Choice {
    /// The threshold.
    pub threshold: f64,
    /// The largest distance of an example to the nearest other of its own.
    pub own_max: f64,
    /// The nearest ordinary movement's distance, if any was recorded.
    pub ordinary_min: Option<f64>,
    /// How many of its examples the threshold leaves out (0 unless the
    /// ordinary movement came closer than its own examples).
    pub own_rejected: usize,
}

/// The thresholds for `set`'s gestures given the frames of the ordinary
/// movement recorded (each a segment the front end cut from it).
pub fn choose(set: &GestureSet, ordinary: &[Vec<Frame>]) -> Vec<Choice> {
    let own = distances::own(set);
    let mut ordinary_min = vec![f64::INFINITY; set.gestures.len()];
    for frames in ordinary {
        for (min, d) in ordinary_min.iter_mut().zip(distances::to_each(set, frames)) {
            *min = min.min(d);
        }
    }
    own.iter()
        .zip(ordinary_min)
        .map(|(own, ordinary_min)| {
            let own_max = own
                .iter()
                .copied()
                .filter(|d| d.is_finite())
                .fold(0.0, f64::max);
            let wide = own_max * OWN_MARGIN;
            let threshold = if ordinary_min.is_finite() {
                wide.min(ordinary_min * ORDINARY_MARGIN)
            } else {
                wide
            };
            Choice {
                threshold,
                own_max,
                ordinary_min: ordinary_min.is_finite().then_some(ordinary_min),
                own_rejected: own.iter().filter(|&&d| d > threshold).count(),
            }
        })
        .collect()
}
