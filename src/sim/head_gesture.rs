//! Head gestures as a person makes them: each a few minimum-jerk moves
//! ([`Step`]s) of the head's angles that end where they started, scaled
//! by the user's speed and amplitude and varied from example to example.
//!
//! Nominal shapes (amplitude × the user's factor, durations ÷ the user's
//! speed; each example varies both by ± [`ImuUser::within_person`], and
//! carries off-axis moves of ± [`OFF_AXIS`] of its amplitude on the
//! other two angles, same timing):
//!
//! | gesture | angle | amplitude | shape |
//! |---|---|---|---|
//! | `nod` | pitch | 15° down | down 0.25 s, up 0.30 s |
//! | `shake` | yaw | 20° | left 0.2 s, right, left (0.35 s each, 40°), centre 0.2 s; moves overlap 20 % |
//! | `wobble` | roll | 15° left | left 0.2 s, right 0.35 s (30°), centre 0.25 s, one after another |
//! | `tilt_left` / `tilt_right` | roll | 20° | out 0.40 s, hold 0.3–1.2 s, back 0.45 s |
//! | `look_up` / `look_down` | pitch | 25° | out 0.45 s, hold 0.3–1.2 s, back 0.50 s |
//! | `turn_left` / `turn_right` | yaw | 45° | out 0.50 s, hold 0.3–1.2 s, back 0.55 s |
//! | `double_nod` | pitch | 12° down | two nods of 0.2 + 0.25 s, 0.1 s apart |

use std::fmt;

use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use serde::{Serialize, Serializer};

use crate::sim::head_motion::{Axis, Step};
use crate::sim::imu_user::ImuUser;

/// Off-axis moves: at most this fraction of the gesture's amplitude.
pub const OFF_AXIS: f64 = 0.08;

/// A named head gesture.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum GestureName {
    /// Pitch down and back up.
    Nod,
    /// Two quick nods.
    DoubleNod,
    /// Yaw left, right, left, centre.
    Shake,
    /// Roll left ear down, hold, back.
    TiltLeft,
    /// Roll right ear down, hold, back.
    TiltRight,
    /// Roll left, right, centre: a quick head bobble.
    Wobble,
    /// Pitch up, hold, back.
    LookUp,
    /// Pitch down, hold, back.
    LookDown,
    /// Yaw left, hold, back.
    TurnLeft,
    /// Yaw right, hold, back.
    TurnRight,
}

impl GestureName {
    /// Every gesture.
    pub const ALL: [GestureName; 10] = [
        GestureName::Nod,
        GestureName::DoubleNod,
        GestureName::Shake,
        GestureName::TiltLeft,
        GestureName::TiltRight,
        GestureName::Wobble,
        GestureName::LookUp,
        GestureName::LookDown,
        GestureName::TurnLeft,
        GestureName::TurnRight,
    ];

    /// The six a session makes unless told otherwise: those ordinary
    /// movement does not imitate. Not the looks: an everyday glance up
    /// or down (10–25° of pitch, held, back) is the same movement as
    /// `look_up`/`look_down`, which ordinary movement set off 11–15 times
    /// an hour; nor the turns, which a glance aside resembles.
    pub const DEFAULT: [GestureName; 6] = [
        GestureName::Nod,
        GestureName::DoubleNod,
        GestureName::Shake,
        GestureName::TiltLeft,
        GestureName::TiltRight,
        GestureName::Wobble,
    ];

    /// Its name: `nod`, `tilt_left`, ….
    pub const fn name(self) -> &'static str {
        match self {
            GestureName::Nod => "nod",
            GestureName::DoubleNod => "double_nod",
            GestureName::Shake => "shake",
            GestureName::TiltLeft => "tilt_left",
            GestureName::TiltRight => "tilt_right",
            GestureName::Wobble => "wobble",
            GestureName::LookUp => "look_up",
            GestureName::LookDown => "look_down",
            GestureName::TurnLeft => "turn_left",
            GestureName::TurnRight => "turn_right",
        }
    }

    /// The gesture named `name`; the error lists the names.
    pub fn parse(name: &str) -> Result<GestureName, String> {
        GestureName::ALL
            .into_iter()
            .find(|g| g.name() == name)
            .ok_or_else(|| {
                let names: Vec<&str> = GestureName::ALL.iter().map(|g| g.name()).collect();
                format!("no gesture {name:?}: one of {}", names.join(", "))
            })
    }

    /// A comma-separated list of names (`nod,shake`), each once.
    pub fn parse_list(text: &str) -> Result<Vec<GestureName>, String> {
        let mut list = Vec::new();
        for name in text.split(',').map(str::trim) {
            let gesture = GestureName::parse(name)?;
            if list.contains(&gesture) {
                return Err(format!("gesture {name:?} given twice"));
            }
            list.push(gesture);
        }
        Ok(list)
    }

    /// Its main angle, direction (+1/−1 of that angle) and nominal
    /// amplitude, degrees.
    fn main_move(self) -> (Axis, f64, f64) {
        match self {
            GestureName::Nod => (Axis::Pitch, 1.0, 15.0),
            GestureName::DoubleNod => (Axis::Pitch, 1.0, 12.0),
            GestureName::Shake => (Axis::Yaw, 1.0, 20.0),
            GestureName::TiltLeft => (Axis::Roll, -1.0, 20.0),
            GestureName::TiltRight => (Axis::Roll, 1.0, 20.0),
            GestureName::Wobble => (Axis::Roll, -1.0, 15.0),
            GestureName::LookUp => (Axis::Pitch, -1.0, 25.0),
            GestureName::LookDown => (Axis::Pitch, 1.0, 25.0),
            GestureName::TurnLeft => (Axis::Yaw, 1.0, 45.0),
            GestureName::TurnRight => (Axis::Yaw, -1.0, 45.0),
        }
    }
}

impl fmt::Display for GestureName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl Serialize for GestureName {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// One example of a gesture, from time 0: its moves, its true length and
/// its main move's amplitude.
#[derive(Debug, Clone, PartialEq)]
pub struct GestureExample {
    /// Which gesture.
    pub name: GestureName,
    /// The moves, times from the gesture's start (the first move starts
    /// at 0; the head is back where it was at [`GestureExample::duration`]).
    pub steps: Vec<Step>,
    /// From the first move's start to the last one's end, s.
    pub duration: f64,
    /// The main angle's furthest excursion, rad, signed.
    pub amplitude: f64,
}

/// One example of `name` by `user`, varied by `rng`.
pub fn gesture_example(name: GestureName, user: &ImuUser, rng: &mut ChaCha8Rng) -> GestureExample {
    let spread = user.within_person;
    let mut vary = |x: f64| x * (1.0 + rng.random_range(-spread..=spread));
    let (axis, sign, degrees) = name.main_move();
    let amplitude = sign * vary(degrees * user.amplitude).to_radians();
    let time = vary(1.0) / user.speed;
    let hold = rng.random_range(0.3..=1.2) / user.speed.sqrt();
    // Main moves as (start, duration, fraction of amplitude).
    let moves: Vec<(f64, f64, f64)> = match name {
        GestureName::Nod => vec![(0.0, 0.25 * time, 1.0), (0.25 * time, 0.30 * time, -1.0)],
        GestureName::DoubleNod => {
            let (down, up, gap) = (0.2 * time, 0.25 * time, 0.1 * time);
            let second = down + up + gap;
            vec![
                (0.0, down, 1.0),
                (down, up, -1.0),
                (second, down, 1.0),
                (second + down, up, -1.0),
            ]
        }
        GestureName::Shake => {
            let durations = [0.2 * time, 0.35 * time, 0.35 * time, 0.2 * time];
            let fractions = [1.0, -2.0, 2.0, -1.0];
            let mut start = 0.0;
            durations
                .iter()
                .zip(fractions)
                .map(|(&d, f)| {
                    let m = (start, d, f);
                    start += 0.8 * d;
                    m
                })
                .collect()
        }
        // In turn, not overlapping: the head reaches each side.
        GestureName::Wobble => {
            let (left, right, centre) = (0.2 * time, 0.35 * time, 0.25 * time);
            vec![
                (0.0, left, 1.0),
                (left, right, -2.0),
                (left + right, centre, 1.0),
            ]
        }
        _ => {
            let (out, back) = match axis {
                Axis::Roll => (0.40, 0.45),
                Axis::Pitch => (0.45, 0.50),
                Axis::Yaw => (0.50, 0.55),
            };
            vec![
                (0.0, out * time, 1.0),
                (out * time + hold, back * time, -1.0),
            ]
        }
    };
    let others: Vec<Axis> = [Axis::Roll, Axis::Pitch, Axis::Yaw]
        .into_iter()
        .filter(|&a| a != axis)
        .collect();
    let off: Vec<f64> = others
        .iter()
        .map(|_| rng.random_range(-OFF_AXIS..=OFF_AXIS))
        .collect();
    let mut steps = Vec::new();
    for &(start, duration, fraction) in &moves {
        steps.push(Step {
            axis,
            start,
            duration,
            amount: fraction * amplitude,
        });
        for (&other, &k) in others.iter().zip(&off) {
            steps.push(Step {
                axis: other,
                start,
                duration,
                amount: fraction * amplitude.abs() * k,
            });
        }
    }
    let duration = steps.iter().map(Step::end).fold(0.0, f64::max);
    GestureExample {
        name,
        steps,
        duration,
        amplitude,
    }
}

#[cfg(test)]
mod tests {
    use rand::SeedableRng;

    use super::*;

    #[test]
    fn every_gesture_ends_where_it_started() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for user in ImuUser::all() {
            for name in GestureName::ALL {
                let g = gesture_example(name, &user, &mut rng);
                let mut net = [0.0; 3];
                for s in &g.steps {
                    net[s.axis as usize] += s.amount;
                    assert!(s.start >= 0.0 && s.end() <= g.duration + 1e-12);
                }
                assert!(net.iter().all(|x| x.abs() < 1e-12), "{name}: {net:?}");
                assert!((0.3..6.0).contains(&g.duration), "{name}: {}", g.duration);
            }
        }
    }

    #[test]
    fn names_parse_and_bad_ones_list_the_choices() {
        assert_eq!(
            GestureName::parse_list("nod, shake").unwrap(),
            [GestureName::Nod, GestureName::Shake]
        );
        assert_eq!(
            GestureName::parse("wave").unwrap_err(),
            "no gesture \"wave\": one of nod, double_nod, shake, tilt_left, tilt_right, \
             wobble, look_up, look_down, turn_left, turn_right"
        );
        assert!(GestureName::parse_list("nod,nod").is_err());
    }
}
