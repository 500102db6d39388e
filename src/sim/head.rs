//! Synthetic head motion as a head-worn IMU sees it, for the gesture
//! front end's tests and benches: smooth gestures (nods, shakes, tilts,
//! looks, turns), ordinary looking around, twitches, and the sensor's
//! and the world's noise (white noise, gyro bias, 5 Hz head tremor,
//! 12 Hz wheelchair vibration on the accelerometer). Seeded, so the same
//! script gives the same samples. Set-up code: it allocates.
//!
//! Axes: x forward, y left, z up; roll about x (tilt), pitch about y
//! (nod, look), yaw about z (shake, turn). At rest the accelerometer
//! reads gravity on +z; rolled by φ and pitched by θ it reads
//! `g·(−sin θ, sin φ·cos θ, cos φ·cos θ)`.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::control::Tick;
use crate::control::gesture::features::GRAVITY;
use crate::control::gesture::{GestureConfig, GestureId, GestureTemplates, segments};
use crate::control::imu::ImuSample;

/// A kind of head movement.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Head {
    /// Pitch down and back up (600 ms, 0.35 rad).
    Nod,
    /// Yaw left-right-left-right (800 ms, ±0.3 rad).
    Shake,
    /// Roll left, held, back (300 ms out, hold, 300 ms back; 0.35 rad).
    TiltLeft,
    /// Roll right, held, back.
    TiltRight,
    /// Pitch up, held, back.
    LookUp,
    /// Pitch down, held, back.
    LookDown,
    /// Yaw left, held, back.
    TurnLeft,
    /// Ordinary looking around: slow yaw and pitch wandering (3 s).
    LookAround,
    /// A short involuntary jerk of roll (120 ms, 0.05 rad).
    Twitch,
}

/// One movement as a person makes it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Move {
    /// What.
    pub head: Head,
    /// Speed factor (1 = nominal; 1.4 is 40 % faster).
    pub speed: f64,
    /// Amplitude factor (1 = nominal).
    pub amplitude: f64,
    /// How long a tilt, look or turn is held, ms.
    pub hold_ms: u64,
}

impl Move {
    /// `head` at nominal speed and amplitude, held 500 ms if it holds.
    pub fn new(head: Head) -> Move {
        Move {
            head,
            speed: 1.0,
            amplitude: 1.0,
            hold_ms: 500,
        }
    }

    /// This move `speed` times as fast and `amplitude` times as large.
    pub fn varied(self, speed: f64, amplitude: f64) -> Move {
        Move {
            speed,
            amplitude,
            ..self
        }
    }

    /// This move held `hold_ms`.
    pub fn held(self, hold_ms: u64) -> Move {
        Move { hold_ms, ..self }
    }

    /// How long it lasts, ms.
    pub fn duration_ms(&self) -> u64 {
        let scaled = |ms: f64| (ms / self.speed).round() as u64;
        match self.head {
            Head::Nod => scaled(600.0),
            Head::Shake => scaled(800.0),
            Head::TiltLeft | Head::TiltRight | Head::LookUp | Head::LookDown | Head::TurnLeft => {
                2 * scaled(300.0) + self.hold_ms
            }
            Head::LookAround => scaled(3000.0),
            Head::Twitch => scaled(120.0),
        }
    }

    /// Roll, pitch and yaw (rad) `t` ms into the move.
    fn angles(&self, t: f64) -> [f64; 3] {
        let a = self.amplitude;
        let d = self.duration_ms() as f64;
        let bump = |t: f64, d: f64| (1.0 - (std::f64::consts::TAU * t / d).cos()) / 2.0;
        // Out over `ramp`, held, back over `ramp`.
        let hold = |t: f64| {
            let ramp = (300.0 / self.speed).round();
            let step = |x: f64| (1.0 - (std::f64::consts::PI * x.clamp(0.0, 1.0)).cos()) / 2.0;
            step(t / ramp) - step((t - (d - ramp)) / ramp)
        };
        match self.head {
            Head::Nod => [0.0, 0.35 * a * bump(t, d), 0.0],
            Head::Shake => {
                let envelope = (std::f64::consts::PI * t / d).sin();
                [
                    0.0,
                    0.0,
                    0.3 * a * envelope * (4.0 * std::f64::consts::PI * t / d).sin(),
                ]
            }
            Head::TiltLeft => [0.35 * a * hold(t), 0.0, 0.0],
            Head::TiltRight => [-0.35 * a * hold(t), 0.0, 0.0],
            Head::LookUp => [0.0, -0.3 * a * hold(t), 0.0],
            Head::LookDown => [0.0, 0.3 * a * hold(t), 0.0],
            Head::TurnLeft => [0.0, 0.0, 0.6 * a * hold(t)],
            Head::LookAround => {
                let s = t / d;
                [
                    0.0,
                    0.08 * a * (std::f64::consts::TAU * 0.7 * s).sin() * bump(t, d),
                    0.9 * a * (std::f64::consts::TAU * 0.5 * s).sin(),
                ]
            }
            Head::Twitch => [0.05 * a * bump(t, d), 0.0, 0.0],
        }
    }
}

/// What disturbs the signal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Noise {
    /// White noise on each rate, rad/s (σ).
    pub gyro_sigma: f64,
    /// White noise on each acceleration, m/s² (σ).
    pub accel_sigma: f64,
    /// Gyro bias on x, y, z, rad/s.
    pub gyro_bias: [f64; 3],
    /// Head tremor at 5 Hz, rad/s amplitude on every rate.
    pub tremor_rad_s: f64,
    /// Wheelchair vibration at 12 Hz, m/s² amplitude on every acceleration.
    pub vibration_m_s2: f64,
}

impl Noise {
    /// None at all.
    pub const NONE: Noise = Noise {
        gyro_sigma: 0.0,
        accel_sigma: 0.0,
        gyro_bias: [0.0; 3],
        tremor_rad_s: 0.0,
        vibration_m_s2: 0.0,
    };

    /// A consumer IMU on a person in a wheelchair.
    pub const TYPICAL: Noise = Noise {
        gyro_sigma: 0.03,
        accel_sigma: 0.08,
        gyro_bias: [0.02, -0.015, 0.01],
        tremor_rad_s: 0.08,
        vibration_m_s2: 0.3,
    };
}

/// A recording being scripted: rests and moves, one after another.
#[derive(Debug, Clone)]
pub struct HeadScript {
    /// (first tick, move) of every move.
    moves: Vec<(Tick, Move)>,
    length_ms: Tick,
}

impl Default for HeadScript {
    fn default() -> Self {
        HeadScript::new()
    }
}

impl HeadScript {
    /// An empty script.
    pub fn new() -> HeadScript {
        HeadScript {
            moves: Vec::new(),
            length_ms: 0,
        }
    }

    /// Rest for `ms`.
    pub fn rest(mut self, ms: u64) -> HeadScript {
        self.length_ms += ms;
        self
    }

    /// Then `m`.
    pub fn then(mut self, m: Move) -> HeadScript {
        self.moves.push((self.length_ms, m));
        self.length_ms += m.duration_ms();
        self
    }

    /// Each move's (start tick, end tick, move).
    pub fn moves(&self) -> impl Iterator<Item = (Tick, Tick, Move)> + '_ {
        self.moves
            .iter()
            .map(|&(start, m)| (start, start + m.duration_ms(), m))
    }

    /// How long the script lasts, ms.
    pub fn length_ms(&self) -> Tick {
        self.length_ms
    }

    /// Roll, pitch and yaw at tick `t` (ms).
    fn angles(&self, t: f64) -> [f64; 3] {
        self.moves
            .iter()
            .find(|(start, m)| t >= *start as f64 && t <= (*start + m.duration_ms()) as f64)
            .map_or([0.0; 3], |(start, m)| m.angles(t - *start as f64))
    }

    /// The IMU's samples, one every `every_ms` ticks from tick 0, with
    /// `noise` drawn from `seed`.
    pub fn samples(&self, every_ms: u64, noise: Noise, seed: u64) -> Vec<(Tick, ImuSample)> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let phase: f64 = rng.random_range(0.0..std::f64::consts::TAU);
        (0..=self.length_ms)
            .step_by(every_ms.max(1) as usize)
            .map(|tick| {
                let t = tick as f64;
                let [roll, pitch, _] = self.angles(t);
                let (before, after) = (self.angles(t - 0.5), self.angles(t + 0.5));
                let seconds = t / 1000.0;
                let tremor =
                    noise.tremor_rad_s * (std::f64::consts::TAU * 5.0 * seconds + phase).sin();
                let vibration = noise.vibration_m_s2
                    * (std::f64::consts::TAU * 12.0 * seconds + 2.0 * phase).sin();
                let gravity = [
                    -GRAVITY * pitch.sin(),
                    GRAVITY * roll.sin() * pitch.cos(),
                    GRAVITY * roll.cos() * pitch.cos(),
                ];
                let mut values = [0.0; 6];
                for (k, v) in values.iter_mut().enumerate() {
                    *v = if k < 3 {
                        gravity[k] + vibration + noise.accel_sigma * normal(&mut rng)
                    } else {
                        let axis = k - 3;
                        (after[axis] - before[axis]) * 1000.0
                            + noise.gyro_bias[axis]
                            + tremor
                            + noise.gyro_sigma * normal(&mut rng)
                    };
                }
                (tick, ImuSample { values })
            })
            .collect()
    }
}

/// Ten gestures: the seven kinds, then a nod, a shake and a tilt made
/// larger and slower (a second set of gestures for the same person).
pub fn ten_gestures() -> [Move; 10] {
    let big = |head| Move::new(head).varied(0.7, 1.8);
    [
        Move::new(Head::Nod),
        Move::new(Head::Shake),
        Move::new(Head::TiltLeft),
        Move::new(Head::TiltRight),
        Move::new(Head::LookUp),
        Move::new(Head::LookDown),
        Move::new(Head::TurnLeft),
        big(Head::Nod),
        big(Head::Shake),
        big(Head::TiltLeft).held(300),
    ]
}

/// A template set: `per_gesture` examples of each of `moves` (gesture
/// `i` is `moves[i]`), their speed and amplitude spread over ±30 %, each
/// cut from its own noisy recording by [`segments`]; every threshold
/// `threshold`.
pub fn example_templates(
    config: &GestureConfig,
    moves: &[Move],
    per_gesture: usize,
    threshold: f64,
    seed: u64,
) -> GestureTemplates {
    let mut set = GestureTemplates::new();
    for (id, m) in moves.iter().enumerate() {
        let gesture = GestureId(id as u8);
        for k in 0..per_gesture {
            let spread = if per_gesture > 1 {
                -0.3 + 0.6 * k as f64 / (per_gesture - 1) as f64
            } else {
                0.0
            };
            let example = m.varied(m.speed * (1.0 + spread), m.amplitude * (1.0 - spread));
            let script = HeadScript::new().rest(1000).then(example).rest(1000);
            let samples = script.samples(10, Noise::TYPICAL, seed + (id * 100 + k) as u64);
            for segment in segments(config, samples).iter().take(1) {
                set.add(gesture, &segment.frames)
                    .expect("a gesture's example is a valid template");
            }
        }
        set.set_threshold(gesture, threshold);
    }
    set
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}
