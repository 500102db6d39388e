//! A simulated IMU user's sessions, with the truth: the recording
//! protocol ([`protocol_session`]), practice ([`practice_session`]: many
//! examples, to measure accuracy on) and ordinary use ([`use_session`]).
//!
//! A gesture's true extent: from the start of its first move to the end
//! of its last one ([`GestureExample::duration`] later), in ms, rounded
//! to the nearest tick. Outside it the head makes no move of that
//! gesture; the tremor, the noise and the vibration go on throughout.

use rand::seq::SliceRandom;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::control::Tick;
use crate::control::imu::{Channels, ImuSample};
use crate::sim::head_gesture::{GestureName, gesture_example};
use crate::sim::head_motion::{Axis, HeadMotion, Step};
use crate::sim::imu_user::ImuUser;
use crate::sim::ordinary_movement::{Gaze, ordinary_movement};
use crate::sim::worn_imu::{WornImu, add_body};

/// Examples of each gesture in the protocol.
pub const EXAMPLES: u32 = 5;
/// The protocol's first rest, ms (uniform).
pub const PROTOCOL_START_MS: (u32, u32) = (3000, 4000);
/// Rest between the examples of one gesture, ms (uniform).
pub const EXAMPLE_GAP_MS: (u32, u32) = (1500, 3000);
/// Rest between gestures, and before the ordinary movement, ms (uniform).
pub const GESTURE_GAP_MS: (u32, u32) = (3000, 4000);
/// The protocol's closing stretch of ordinary movement, ms.
pub const ORDINARY_MS: u32 = 60_000;
/// In ordinary use, a stretch of ordinary movement between gestures, ms
/// (uniform).
pub const USE_ORDINARY_MS: (u32, u32) = (20_000, 90_000);
/// In ordinary use, the rest just before and after a gesture, ms (uniform).
pub const USE_GESTURE_REST_MS: (u32, u32) = (1500, 3000);

/// In practice, the rest just before and after a gesture, ms (uniform):
/// two gestures are at least twice its low end apart, as in the protocol.
pub const PRACTICE_REST_MS: (u32, u32) = (1500, 3000);
/// In practice, the chance of a stretch of ordinary movement between two
/// gestures.
pub const PRACTICE_ORDINARY_CHANCE: f64 = 0.3;
/// In practice, a stretch of ordinary movement, ms (uniform).
pub const PRACTICE_ORDINARY_MS: (u32, u32) = (5000, 15_000);

/// A gesture the user truly made.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrueGesture {
    /// Which.
    pub name: GestureName,
    /// Its example number within the session's examples of it, from 1.
    pub example: u32,
    /// The tick its first move starts.
    pub start: Tick,
    /// The tick its last move ends.
    pub end: Tick,
}

/// A simulated session: samples every `1000 / rate_hz` ms (rounded), the
/// gestures made and the stretches of ordinary movement.
#[derive(Debug, Clone, PartialEq)]
pub struct ImuSession {
    /// All six.
    pub channels: Channels,
    /// Increasing ticks.
    pub samples: Vec<(Tick, ImuSample)>,
    /// In time order.
    pub truth: Vec<TrueGesture>,
    /// Ordinary movement, `[start, end)` ticks, in time order.
    pub ordinary: Vec<(Tick, Tick)>,
    /// The gyro's constant bias this session, rad/s, x y z (its slow
    /// drift, ± [`ImuUser::gyro_drift`], comes on top).
    pub gyro_bias: [f64; 3],
}

/// The random generator of `user`'s session seeded `seed`: the user's
/// name is mixed in (FNV-1a), so two users given one seed still move
/// differently.
fn session_rng(user: &ImuUser, seed: u64) -> ChaCha8Rng {
    let name = user.name.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    });
    ChaCha8Rng::seed_from_u64(seed ^ name)
}

/// A session's plan before it is sampled.
struct Plan {
    motion: HeadMotion,
    truth: Vec<TrueGesture>,
    ordinary: Vec<(Tick, Tick)>,
    gaze: Gaze,
    /// Where the plan has got to, ms.
    now: Tick,
}

impl Plan {
    fn new() -> Plan {
        Plan {
            motion: HeadMotion::default(),
            truth: Vec::new(),
            ordinary: Vec::new(),
            gaze: Gaze::default(),
            now: 0,
        }
    }

    fn rest(&mut self, (low, high): (u32, u32), rng: &mut ChaCha8Rng) {
        self.now += Tick::from(rng.random_range(low..=high));
    }

    fn gesture(&mut self, user: &ImuUser, name: GestureName, example: u32, rng: &mut ChaCha8Rng) {
        let g = gesture_example(name, user, rng);
        let start = self.now as f64 / 1000.0;
        self.motion.steps.extend(g.steps.iter().map(|s| Step {
            start: s.start + start,
            ..*s
        }));
        // Round the end up, so the next rest starts after the head stops.
        let end = self.now + (g.duration * 1000.0).ceil() as Tick;
        self.truth.push(TrueGesture {
            name,
            example,
            start: self.now,
            end,
        });
        self.now = end;
    }

    fn ordinary(&mut self, user: &ImuUser, ms: u32, rng: &mut ChaCha8Rng) {
        let end = self.now + Tick::from(ms);
        let span = (self.now as f64 / 1000.0, end as f64 / 1000.0);
        ordinary_movement(&mut self.motion, user, &mut self.gaze, span, rng);
        self.ordinary.push((self.now, end));
        self.now = end;
    }

    /// Samples the plan, `user`'s sensor and body added.
    fn sample(mut self, user: &ImuUser, rng: &mut ChaCha8Rng) -> ImuSession {
        let length = self.now;
        add_body(user, &mut self.motion, rng);
        self.motion.finish();
        let sensor = WornImu::new(user, rng);
        let mut cursor = self.motion.into_cursor();
        let rate = u64::from(user.rate_hz.clamp(1, 1000));
        let mut samples = Vec::new();
        for i in 0.. {
            let tick = (i * 1000 + rate / 2) / rate;
            if tick > length {
                break;
            }
            let t = tick as f64 / 1000.0;
            samples.push((tick, sensor.read(t, &cursor.at(t), rng)));
        }
        ImuSession {
            channels: Channels::ALL,
            samples,
            truth: self.truth,
            ordinary: self.ordinary,
            gyro_bias: sensor.bias,
        }
    }
}

/// `user` following the recording protocol for `gestures`, seeded:
/// [`PROTOCOL_START_MS`] of rest; then for each gesture in order,
/// [`EXAMPLES`] examples with [`EXAMPLE_GAP_MS`] of rest between them
/// and [`GESTURE_GAP_MS`] between gestures; then, after another
/// [`GESTURE_GAP_MS`], [`ORDINARY_MS`] of ordinary movement. The session
/// ends with that stretch.
pub fn protocol_session(user: &ImuUser, gestures: &[GestureName], seed: u64) -> ImuSession {
    let mut rng = session_rng(user, seed);
    let mut plan = Plan::new();
    plan.rest(PROTOCOL_START_MS, &mut rng);
    for (i, &name) in gestures.iter().enumerate() {
        if i > 0 {
            plan.rest(GESTURE_GAP_MS, &mut rng);
        }
        for example in 1..=EXAMPLES {
            if example > 1 {
                plan.rest(EXAMPLE_GAP_MS, &mut rng);
            }
            plan.gesture(user, name, example, &mut rng);
        }
    }
    plan.rest(GESTURE_GAP_MS, &mut rng);
    plan.ordinary(user, ORDINARY_MS, &mut rng);
    plan.sample(user, &mut rng)
}

/// `user` practising `gestures`, seeded: each `per_gesture` times, in a
/// shuffled order, each with [`PRACTICE_REST_MS`] of rest before and
/// after it; between two gestures, with [`PRACTICE_ORDINARY_CHANCE`], a
/// stretch of ordinary movement ([`PRACTICE_ORDINARY_MS`]) as well, so
/// a gesture does not always start from the head at rest where it rests.
/// The session ends with the last gesture's rest.
pub fn practice_session(
    user: &ImuUser,
    gestures: &[GestureName],
    per_gesture: u32,
    seed: u64,
) -> ImuSession {
    let mut rng = session_rng(user, seed);
    let mut plan = Plan::new();
    let mut order: Vec<usize> = (0..gestures.len())
        .flat_map(|k| std::iter::repeat_n(k, per_gesture as usize))
        .collect();
    order.shuffle(&mut rng);
    let mut examples = vec![0; gestures.len()];
    for (i, &k) in order.iter().enumerate() {
        if i > 0 && rng.random_bool(PRACTICE_ORDINARY_CHANCE) {
            let ms = rng.random_range(PRACTICE_ORDINARY_MS.0..=PRACTICE_ORDINARY_MS.1);
            plan.ordinary(user, ms, &mut rng);
        }
        plan.rest(PRACTICE_REST_MS, &mut rng);
        examples[k] += 1;
        plan.gesture(user, gestures[k], examples[k], &mut rng);
        plan.rest(PRACTICE_REST_MS, &mut rng);
    }
    plan.sample(user, &mut rng)
}

/// `user` in ordinary use for `minutes`, seeded: stretches of ordinary
/// movement ([`USE_ORDINARY_MS`]), and between them one of `gestures`
/// (in turn, from a random first) with [`USE_GESTURE_REST_MS`] of rest
/// either side. With no gestures, `minutes` of ordinary movement alone.
/// The session is exactly `minutes` long; a gesture that would not fit
/// is left out.
pub fn use_session(
    user: &ImuUser,
    gestures: &[GestureName],
    minutes: u32,
    seed: u64,
) -> ImuSession {
    let mut rng = session_rng(user, seed);
    let mut plan = Plan::new();
    let length = Tick::from(minutes) * 60_000;
    let mut examples = vec![0; gestures.len()];
    let mut next = if gestures.is_empty() {
        0
    } else {
        rng.random_range(0..gestures.len())
    };
    while plan.now < length {
        let ms = rng.random_range(USE_ORDINARY_MS.0..=USE_ORDINARY_MS.1);
        let ms = ms.min(u32::try_from(length - plan.now).unwrap_or(u32::MAX));
        plan.ordinary(user, ms, &mut rng);
        // Room for a gesture, its rests and a little ordinary movement.
        if gestures.is_empty() || plan.now + 15_000 > length {
            continue;
        }
        plan.rest(USE_GESTURE_REST_MS, &mut rng);
        examples[next] += 1;
        plan.gesture(user, gestures[next], examples[next], &mut rng);
        plan.rest(USE_GESTURE_REST_MS, &mut rng);
        next = (next + 1) % gestures.len();
    }
    plan.sample(user, &mut rng)
}

/// One selection and what follows it in a [`drive_session`]: a gesture,
/// then the head's pitch tilted and held, then back.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drive {
    /// The gesture that selects the mode.
    pub gesture: GestureName,
    /// How far the head is pitched from its rest, degrees (positive: chin
    /// down).
    pub pitch_deg: f64,
    /// How long it is held there, ms.
    pub hold_ms: u32,
}

/// Rest after a selecting gesture before the head tilts, ms: the gesture
/// is read once the head has been still for the front end's `rest_ms`.
pub const DRIVE_AFTER_GESTURE_MS: u32 = 800;
/// How long a tilt takes to reach its angle, and to come back, ms.
pub const DRIVE_TILT_MS: u32 = 400;
/// Rest after a tilt comes back, ms: longer than the default
/// inactivity timeout, so the next gesture is read in selection.
pub const DRIVE_REST_MS: u32 = 3500;

/// `user` driving the arm with their head, seeded: after
/// [`PROTOCOL_START_MS`] of rest, for each drive its gesture, then the
/// pitch tilted over [`DRIVE_TILT_MS`], held, and brought back, then
/// [`DRIVE_REST_MS`] of rest. Returns the session and each hold's
/// `[start, end)` ticks (the head at its angle).
pub fn drive_session(
    user: &ImuUser,
    drives: &[Drive],
    seed: u64,
) -> (ImuSession, Vec<(Tick, Tick)>) {
    let mut rng = session_rng(user, seed);
    let mut plan = Plan::new();
    let mut holds = Vec::new();
    plan.rest(PROTOCOL_START_MS, &mut rng);
    for (i, drive) in drives.iter().enumerate() {
        plan.gesture(user, drive.gesture, i as u32 + 1, &mut rng);
        plan.now += Tick::from(DRIVE_AFTER_GESTURE_MS);
        let amount = drive.pitch_deg.to_radians();
        let tilt_s = f64::from(DRIVE_TILT_MS) / 1000.0;
        plan.motion.steps.push(Step {
            axis: Axis::Pitch,
            start: plan.now as f64 / 1000.0,
            duration: tilt_s,
            amount,
        });
        plan.now += Tick::from(DRIVE_TILT_MS);
        let hold = (plan.now, plan.now + Tick::from(drive.hold_ms));
        holds.push(hold);
        plan.now = hold.1;
        plan.motion.steps.push(Step {
            axis: Axis::Pitch,
            start: plan.now as f64 / 1000.0,
            duration: tilt_s,
            amount: -amount,
        });
        plan.now += Tick::from(DRIVE_TILT_MS + DRIVE_REST_MS);
    }
    (plan.sample(user, &mut rng), holds)
}

/// `user`'s ordinary movement alone for `minutes`, seeded: no gesture
/// ([`use_session`] with none).
pub fn ordinary_session(user: &ImuUser, minutes: u32, seed: u64) -> ImuSession {
    use_session(user, &[], minutes, seed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::head_motion::{GRAVITY, ideal_reading};

    fn typical() -> ImuUser {
        ImuUser::builtin("typical").unwrap()
    }

    /// Samples `motion` noise-free at 1 kHz for `seconds`.
    fn ideal(mut motion: HeadMotion, seconds: f64) -> Vec<([f64; 3], [f64; 3])> {
        motion.finish();
        let mut cursor = motion.into_cursor();
        (0..=(seconds * 1000.0) as u64)
            .map(|ms| ideal_reading(&cursor.at(ms as f64 / 1000.0)))
            .collect()
    }

    #[test]
    fn the_same_seed_gives_the_same_samples_and_another_differs() {
        let user = ImuUser::builtin("wheelchair").unwrap();
        let a = use_session(&user, &GestureName::DEFAULT, 2, 7);
        assert_eq!(a, use_session(&user, &GestureName::DEFAULT, 2, 7));
        let b = use_session(&user, &GestureName::DEFAULT, 2, 8);
        assert_eq!(a.samples.len(), b.samples.len());
        assert_ne!(a.samples, b.samples);
        assert_eq!(a.samples.last().unwrap().0, 120_000);
    }

    #[test]
    fn at_rest_the_accelerometer_reads_gravity_and_the_gyro_its_bias() {
        let user = typical();
        let session = protocol_session(&user, &[GestureName::Nod], 2);
        // The first rest: the head still at its posture.
        let rest: Vec<&ImuSample> = session
            .samples
            .iter()
            .filter(|(tick, _)| *tick < session.truth[0].start)
            .map(|(_, s)| s)
            .collect();
        assert!(rest.len() >= 300);
        let n = rest.len() as f64;
        let norm = rest
            .iter()
            .map(|s| s.acceleration().iter().map(|a| a * a).sum::<f64>().sqrt())
            .sum::<f64>()
            / n;
        // The mean of the norm: within a few noise σ / √n of g.
        assert!((norm - GRAVITY).abs() < 0.005, "{norm}");
        for k in 0..3 {
            let mean = rest.iter().map(|s| s.rate()[k]).sum::<f64>() / n;
            // The bias, give or take the drift (≤ 0.002), what is left of
            // the tremor's rate over ≥ 15 cycles (≤ 0.001) and the noise.
            let bias = session.gyro_bias[k];
            assert!((mean - bias).abs() <= 0.003, "{k}: {mean} vs {bias}");
        }
        assert!(session.gyro_bias.iter().any(|b| b.abs() > 0.003));
    }

    #[test]
    fn a_nods_and_a_wobbles_gyro_integrate_to_their_amplitude_and_back_to_zero() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        // The gyro's axis of each: gy for pitch, gx for roll.
        for (name, k) in [(GestureName::Nod, 1), (GestureName::Wobble, 0)] {
            for user in ImuUser::all() {
                let g = gesture_example(name, &user, &mut rng);
                let motion = HeadMotion {
                    steps: g.steps.clone(),
                    ..HeadMotion::default()
                };
                let samples = ideal(motion, g.duration + 0.1);
                let mut angle = 0.0;
                let mut peak: f64 = 0.0;
                for pair in samples.windows(2) {
                    angle += (pair[0].1[k] + pair[1].1[k]) / 2.0 / 1000.0;
                    peak = peak.max(angle.abs());
                }
                let who = format!("{name}/{}", user.name);
                assert!(angle.abs() < 1e-4, "{who}: net {angle}");
                let relative = (peak - g.amplitude.abs()) / g.amplitude.abs();
                assert!(relative.abs() < 0.01, "{who}: {peak} vs {}", g.amplitude);
            }
        }
    }

    #[test]
    fn a_tilts_hold_reads_g_sin_roll_on_y() {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let user = typical();
        for name in [GestureName::TiltLeft, GestureName::TiltRight] {
            let tilt = gesture_example(name, &user, &mut rng);
            let hold = tilt.steps[0].end() + 0.1;
            let (mut roll, mut pitch) = (0.0, 0.0);
            for s in tilt.steps.iter().filter(|s| s.end() <= hold) {
                match s.axis {
                    Axis::Roll => roll += s.amount,
                    Axis::Pitch => pitch += s.amount,
                    Axis::Yaw => {}
                }
            }
            assert_eq!(roll, tilt.amplitude);
            let motion = HeadMotion {
                steps: tilt.steps.clone(),
                ..HeadMotion::default()
            };
            let (accel, gyro) = ideal(motion, hold)[(hold * 1000.0) as usize];
            assert_eq!(gyro, [0.0; 3]);
            let ay = GRAVITY * f64::cos(pitch) * roll.sin();
            assert!((accel[1] - ay).abs() < 1e-9, "{accel:?} vs {ay}");
            assert!((accel[1] - GRAVITY * roll.sin()).abs() < 0.002 * GRAVITY);
        }
    }

    #[test]
    fn the_protocol_keeps_every_rule_for_every_user() {
        let gestures = GestureName::DEFAULT;
        for user in ImuUser::all() {
            for seed in 1..=4 {
                let s = protocol_session(&user.at_rate(10), &gestures, seed);
                let t = &s.truth;
                assert_eq!(t.len(), gestures.len() * EXAMPLES as usize);
                assert!(t[0].start >= 3000, "{}", t[0].start);
                for (i, pair) in t.windows(2).enumerate() {
                    let gap = pair[1].start - pair[0].end;
                    if (i + 1) % EXAMPLES as usize == 0 {
                        assert!(gap >= 3000, "{}/{seed}: between gestures {gap}", user.name);
                        assert_ne!(pair[0].name, pair[1].name);
                    } else {
                        assert!((1500..=3000).contains(&gap), "{}/{seed}: {gap}", user.name);
                        assert_eq!(pair[0].name, pair[1].name);
                        assert_eq!(pair[1].example, pair[0].example + 1);
                    }
                }
                for (k, g) in t.iter().enumerate() {
                    assert_eq!(g.name, gestures[k / EXAMPLES as usize]);
                    assert!(g.end > g.start);
                }
                let &[(start, end)] = &s.ordinary[..] else {
                    panic!("{:?}", s.ordinary)
                };
                assert!(start >= t.last().unwrap().end + 3000);
                assert!(end - start >= 60_000);
                // At 10 Hz the last sample is within 100 ms of the end.
                assert!(end - s.samples.last().unwrap().0 < 100);
            }
        }
    }

    #[test]
    fn practice_keeps_every_rule_for_every_user() {
        let gestures = GestureName::DEFAULT;
        let per = 3;
        let (mut orders, mut stretches) = (Vec::new(), 0);
        for user in ImuUser::all() {
            for seed in 1..=4 {
                let s = practice_session(&user.at_rate(10), &gestures, per, seed);
                let (t, who) = (&s.truth, format!("{}/{seed}", user.name));
                assert_eq!(t.len(), gestures.len() * per as usize, "{who}");
                for name in gestures {
                    let examples: Vec<u32> = t
                        .iter()
                        .filter(|g| g.name == name)
                        .map(|g| g.example)
                        .collect();
                    assert_eq!(examples, [1, 2, 3], "{who}: {name}");
                }
                let rest = |ms: Tick| (1500..=3000).contains(&ms);
                assert!(rest(t[0].start), "{who}: first {}", t[0].start);
                let last = s.samples.last().unwrap().0;
                // At 10 Hz the last sample is within 100 ms of the end.
                let end = last - t.last().unwrap().end;
                assert!((1400..=3000).contains(&end), "{who}: ends {end} after");
                let mut ordinary = s.ordinary.iter().peekable();
                for pair in t.windows(2) {
                    let (before, after) = (pair[0].end, pair[1].start);
                    assert!(after - before >= 3000, "{who}: {before}..{after}");
                    match ordinary.next_if(|&&(a, _)| a < after) {
                        Some(&(a, b)) => {
                            assert!(rest(a - before), "{who}: {before}, ordinary {a}");
                            assert!((5000..=15_000).contains(&(b - a)), "{who}: {a}..{b}");
                            assert!(rest(after - b), "{who}: ordinary to {b}, {after}");
                            stretches += 1;
                        }
                        None => assert!(after - before <= 6000, "{who}: {before}..{after}"),
                    }
                }
                assert!(ordinary.next().is_none(), "{who}: {:?}", s.ordinary);
                orders.push(t.iter().map(|g| g.name.name()).collect::<Vec<_>>());
            }
        }
        // Shuffled: no two sessions in the same order; now and then a
        // stretch of ordinary movement (0.3 of 17 gaps in 24 sessions).
        orders.sort();
        orders.dedup();
        assert_eq!(orders.len(), 24);
        assert!((60..=180).contains(&stretches), "{stretches}");
    }

    #[test]
    fn an_ideal_head_moves_only_in_gestures_and_ordinary_movement() {
        let user = typical().ideal();
        let s = use_session(&user, &GestureName::DEFAULT, 5, 3);
        assert!(s.truth.len() >= 3, "{:?}", s.truth);
        let inside = |tick: Tick| {
            s.truth.iter().any(|g| (g.start..=g.end).contains(&tick))
                || s.ordinary.iter().any(|&(a, b)| (a..=b).contains(&tick))
        };
        let mut moving = 0;
        for (tick, sample) in &s.samples {
            if sample.rate() != [0.0; 3] {
                moving += 1;
                assert!(inside(*tick), "moving at {tick}");
            }
        }
        assert!(moving > 1000);
        let ordinary: Tick = s.ordinary.iter().map(|(a, b)| b - a).sum();
        assert!(ordinary >= 180_000, "{ordinary}");
        let only = ordinary_session(&user, 3, 3);
        assert!(only.truth.is_empty());
        assert_eq!(
            only.ordinary.iter().map(|(a, b)| b - a).sum::<Tick>(),
            180_000
        );
    }
}
