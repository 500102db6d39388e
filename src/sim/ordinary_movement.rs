//! Everyday head motion that must trigger nothing, as a stretch of
//! activities drawn at random (weights in brackets):
//!
//! - **look around** (30 %): yaw to a new direction 10–60° away (within
//!   ±60° of straight ahead) over 0.8–1.8 s, often with a few degrees of
//!   pitch, and stay there 2–8 s;
//! - **glance** (15 %): a quick look to the side (25–60° yaw out in
//!   0.4–0.7 s) or up or down (10–25° pitch), held 0.4–2 s, and back —
//!   what real users do, and close to a turn or look gesture;
//! - **talk** (20 %): 3–10 s of small fast pitch and yaw oscillations
//!   (2–5 Hz, 0.5–3°) with up to two small nods (4–8°) of emphasis;
//! - **shift posture** (10 %): pitch and roll 2–5° over 1–2 s, and stay;
//! - **drift back** (10 %): yaw back most of the way to straight ahead
//!   over 1.5–3 s;
//! - **ride** (15 %): 5–20 s of wheelchair vibration (broadband 5–20 Hz,
//!   0.4–1.0 m/s² RMS, more for a wheelchair user), bumps (1–3 m/s²
//!   decaying in 0.08 s, one every ~3 s) and the head rocking 0.2–0.5°;
//! - otherwise (rest) 1–5 s still.
//!
//! All angles are multiplied by the user's amplitude factor and times
//! divided by their speed, as for gestures. Every activity ends inside
//! its stretch.

use std::f64::consts::PI;

use rand::RngExt;
use rand_chacha::ChaCha8Rng;

use crate::sim::head_gesture::{GestureName, gesture_example};
use crate::sim::head_motion::{Axis, Envelope, HeadMotion, Jolt, Step, Wave};
use crate::sim::imu_user::ImuUser;

/// Where the head points, relative to its resting posture, rad: ordinary
/// movement keeps track of it from stretch to stretch.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Gaze {
    /// Yaw, rad (positive left).
    pub yaw: f64,
    /// Pitch, rad (positive down).
    pub pitch: f64,
    /// Roll, rad (positive right).
    pub roll: f64,
}

/// Adds ordinary movement from `start` to `end` s to `motion`.
pub fn ordinary_movement(
    motion: &mut HeadMotion,
    user: &ImuUser,
    gaze: &mut Gaze,
    (start, end): (f64, f64),
    rng: &mut ChaCha8Rng,
) {
    let deg = |d: f64| (d * user.amplitude).to_radians();
    let slow = 1.0 / user.speed;
    let mut t = start;
    while t < end {
        let pick: f64 = rng.random_range(0.0..1.0);
        let mut steps: Vec<Step> = Vec::new();
        let mut waves: Vec<Wave> = Vec::new();
        let mut jolts: Vec<Jolt> = Vec::new();
        let mut step = |axis, at: f64, duration: f64, amount| {
            steps.push(Step {
                axis,
                start: at,
                duration,
                amount,
            })
        };
        let length = if pick < 0.30 {
            // Look around.
            let limit = 60f64.to_radians();
            let mut target = gaze.yaw;
            while (target - gaze.yaw).abs() < 10f64.to_radians() {
                target = rng.random_range(-limit..=limit);
            }
            let dy = (target - gaze.yaw) * user.amplitude;
            let move_s = rng.random_range(0.8..=1.8) * slow;
            step(Axis::Yaw, t, move_s, dy);
            let dp = deg(rng.random_range(-5.0..=5.0)) - 0.5 * gaze.pitch;
            step(Axis::Pitch, t, move_s, dp);
            gaze.yaw += dy;
            gaze.pitch += dp;
            move_s + rng.random_range(2.0..=8.0)
        } else if pick < 0.45 {
            // Glance.
            let sideways = rng.random_bool(0.6);
            let (axis, amount) = if sideways {
                let side = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
                (Axis::Yaw, side * deg(rng.random_range(25.0..=60.0)))
            } else {
                let side = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
                (Axis::Pitch, side * deg(rng.random_range(10.0..=25.0)))
            };
            let out = rng.random_range(0.4..=0.7) * slow;
            let hold = rng.random_range(0.4..=2.0);
            let back = rng.random_range(0.5..=0.9) * slow;
            step(axis, t, out, amount);
            step(axis, t + out + hold, back, -amount);
            out + hold + back + rng.random_range(0.5..=2.0)
        } else if pick < 0.65 {
            // Talk.
            let length = rng.random_range(3.0..=10.0);
            let envelope = Envelope::Window {
                start: t,
                end: t + length,
                ramp: 0.4,
            };
            for (axis, low, high) in [(Axis::Pitch, 1.0, 3.0), (Axis::Yaw, 0.5, 2.0)] {
                for _ in 0..2 {
                    waves.push(Wave {
                        axis,
                        amplitude: deg(rng.random_range(low..=high)) / 2.0,
                        hz: rng.random_range(2.0..=5.0),
                        phase: rng.random_range(0.0..2.0 * PI),
                        envelope,
                    });
                }
            }
            for _ in 0..rng.random_range(0..=2) {
                let nod = gesture_example(GestureName::Nod, user, rng);
                let scale = rng.random_range(4.0..=8.0) / 15.0;
                let at = t + rng.random_range(0.5..=(length - nod.duration - 0.5).max(0.5));
                for s in nod.steps {
                    step(s.axis, at + s.start, s.duration, s.amount * scale);
                }
            }
            length
        } else if pick < 0.75 {
            // Shift posture, kept within ±8° of the resting one.
            let move_s = rng.random_range(1.0..=2.0) * slow;
            let limit = 8f64.to_radians();
            for (axis, now) in [(Axis::Pitch, &mut gaze.pitch), (Axis::Roll, &mut gaze.roll)] {
                let mut d = deg(rng.random_range(2.0..=5.0));
                if *now > 0.0 || (*now == 0.0 && rng.random_bool(0.5)) {
                    d = -d;
                }
                let d = (*now + d).clamp(-limit, limit) - *now;
                step(axis, t, move_s, d);
                *now += d;
            }
            move_s + rng.random_range(1.0..=4.0)
        } else if pick < 0.85 {
            // Drift back towards straight ahead.
            let move_s = rng.random_range(1.5..=3.0) * slow;
            let dy = -gaze.yaw * rng.random_range(0.6..=1.0);
            step(Axis::Yaw, t, move_s, dy);
            gaze.yaw += dy;
            move_s + rng.random_range(1.0..=4.0)
        } else if pick < 0.95 {
            // Ride.
            let length = rng.random_range(5.0..=20.0);
            let level = user.wheelchair.max(rng.random_range(0.4..=1.0));
            jolts.extend(vibration(level, (t, t + length), rng));
            let mut b = t + rng.random_range(0.5..=3.0);
            while b + 0.6 < t + length {
                jolts.push(Jolt {
                    direction: [0.0, 0.0, 1.0],
                    amplitude: rng.random_range(1.0..=3.0),
                    hz: rng.random_range(8.0..=12.0),
                    phase: 0.0,
                    envelope: Envelope::Window {
                        start: b,
                        end: b + 0.6,
                        ramp: 0.01,
                    },
                    decay: 0.08,
                });
                b += rng.random_range(1.0..=5.0);
            }
            let envelope = Envelope::Window {
                start: t,
                end: t + length,
                ramp: 0.5,
            };
            for axis in [Axis::Pitch, Axis::Roll] {
                waves.push(Wave {
                    axis,
                    amplitude: rng.random_range(0.2..=0.5f64).to_radians(),
                    hz: rng.random_range(2.0..=4.0),
                    phase: rng.random_range(0.0..2.0 * PI),
                    envelope,
                });
            }
            length
        } else {
            rng.random_range(1.0..=5.0)
        };
        let last = steps
            .iter()
            .map(Step::end)
            .chain(waves.iter().map(|w| t + wave_length(w)))
            .fold(t + length, f64::max);
        if last > end {
            // Does not fit: the stretch ends still (the gaze as it was).
            for s in &steps {
                match s.axis {
                    Axis::Yaw => gaze.yaw -= s.amount,
                    Axis::Pitch => gaze.pitch -= s.amount,
                    Axis::Roll => gaze.roll -= s.amount,
                }
            }
            break;
        }
        motion.steps.extend(steps);
        motion.waves.extend(waves);
        motion.jolts.extend(jolts);
        t = last;
    }
}

/// A window's length after its start.
fn wave_length(w: &Wave) -> f64 {
    match w.envelope {
        Envelope::Window { start, end, .. } => end - start,
        Envelope::Modulated { .. } => 0.0,
    }
}

/// Broadband wheelchair vibration of `level` m/s² RMS from `start` to
/// `end` s (`end` = ∞: for ever, gently waxing and waning): eight
/// sines of 5–20 Hz, mostly vertical.
pub fn vibration(level: f64, (start, end): (f64, f64), rng: &mut ChaCha8Rng) -> Vec<Jolt> {
    const SINES: usize = 8;
    let envelope = if end.is_finite() {
        Envelope::Window {
            start,
            end,
            ramp: 0.5,
        }
    } else {
        Envelope::Modulated {
            depth: 0.5,
            hz: 0.05,
            phase: rng.random_range(0.0..2.0 * PI),
        }
    };
    (0..SINES)
        .map(|_| {
            let (x, y) = (rng.random_range(-0.3..=0.3), rng.random_range(-0.3..=0.3));
            let norm = f64::sqrt(x * x + y * y + 1.0);
            Jolt {
                direction: [x / norm, y / norm, 1.0 / norm],
                amplitude: level * (2.0 / SINES as f64).sqrt(),
                hz: rng.random_range(5.0..=20.0),
                phase: rng.random_range(0.0..2.0 * PI),
                envelope,
                decay: 0.0,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use rand::SeedableRng;

    use super::*;

    #[test]
    fn ten_minutes_hold_every_activity_and_end_inside_the_stretch() {
        for user in ImuUser::all() {
            let mut motion = HeadMotion::default();
            let mut gaze = Gaze::default();
            let mut rng = ChaCha8Rng::seed_from_u64(11);
            ordinary_movement(&mut motion, &user, &mut gaze, (5.0, 605.0), &mut rng);
            let steps = &motion.steps;
            assert!(steps.iter().all(|s| s.start >= 5.0 && s.end() <= 605.0));
            let quick_glances = steps
                .iter()
                .filter(|s| s.axis == Axis::Yaw && s.amount.abs() >= 17f64.to_radians())
                .filter(|s| s.duration <= 0.7 / user.speed)
                .count();
            let looks = steps
                .iter()
                .filter(|s| s.axis == Axis::Yaw && s.duration >= 0.8 / user.speed)
                .count();
            let talking = motion.waves.iter().filter(|w| w.hz >= 2.0 && w.hz <= 5.0);
            let bumps = motion.jolts.iter().filter(|j| j.decay > 0.0).count();
            let name = user.name;
            assert!(quick_glances >= 3, "{name}: {quick_glances} glances");
            assert!(looks >= 10, "{name}: {looks} looks");
            assert!(talking.count() >= 8, "{name}: talking");
            assert!(bumps >= 3, "{name}: {bumps} bumps");
            let waves_end = motion.waves.iter().map(|w| match w.envelope {
                Envelope::Window { end, .. } => end,
                Envelope::Modulated { .. } => f64::INFINITY,
            });
            assert!(waves_end.fold(0.0, f64::max) <= 605.0);
            assert!(gaze.yaw.abs() <= 60f64.to_radians() * user.amplitude.max(1.0));
            assert!(gaze.roll.abs() <= 8f64.to_radians() + 1e-12);
        }
    }
}
