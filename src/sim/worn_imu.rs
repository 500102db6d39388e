//! What a simulated person's body adds to their head's moves (posture,
//! tremor, a wheelchair's vibration), and the IMU they wear: what it reads
//! of the head's state, with the session's gyro bias, its slow drift and
//! white noise. One session draws one bias and drift phase per axis.

use std::f64::consts::PI;

use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use crate::control::imu::ImuSample;
use crate::sim::head_motion::{Axis, Envelope, HeadMotion, HeadState, Step, Wave, ideal_reading};
use crate::sim::imu_user::ImuUser;
use crate::sim::ordinary_movement::vibration;

/// Adds what `user`'s body does all along to `motion`: their resting
/// posture, their tremor (mostly pitch and yaw, a little roll, one
/// modulation) and their wheelchair's vibration.
pub fn add_body(user: &ImuUser, motion: &mut HeadMotion, rng: &mut ChaCha8Rng) {
    let posture = [
        (Axis::Pitch, user.posture_pitch_deg),
        (Axis::Roll, user.posture_roll_deg),
    ];
    for (axis, degrees) in posture {
        motion.steps.push(Step {
            axis,
            start: -2.0,
            duration: 1.0,
            amount: degrees.to_radians(),
        });
    }
    if user.tremor_deg > 0.0 {
        let envelope = Envelope::Modulated {
            depth: user.tremor_modulation,
            hz: ImuUser::TREMOR_MODULATION_HZ,
            phase: rng.random_range(0.0..2.0 * PI),
        };
        for (axis, share) in [(Axis::Pitch, 1.0), (Axis::Yaw, 0.7), (Axis::Roll, 0.3)] {
            motion.waves.push(Wave {
                axis,
                amplitude: share * user.tremor_deg.to_radians(),
                hz: user.tremor_hz,
                phase: rng.random_range(0.0..2.0 * PI),
                envelope,
            });
        }
    }
    if user.wheelchair > 0.0 {
        motion
            .jolts
            .extend(vibration(user.wheelchair, (0.0, f64::INFINITY), rng));
    }
}

/// One session's sensor on `user`'s head.
#[derive(Debug, Clone)]
pub struct WornImu {
    /// The gyro's constant bias this session, rad/s, x y z.
    pub bias: [f64; 3],
    drift: f64,
    drift_period_s: f64,
    drift_phase: [f64; 3],
    accel_noise: Option<Normal<f64>>,
    gyro_noise: Option<Normal<f64>>,
}

impl WornImu {
    /// `user`'s sensor, its bias and drift phases drawn from `rng`.
    pub fn new(user: &ImuUser, rng: &mut ChaCha8Rng) -> WornImu {
        let bias = std::array::from_fn(|_| user.gyro_bias * rng.random_range(-1.0..=1.0));
        let drift_phase = std::array::from_fn(|_| rng.random_range(0.0..2.0 * PI));
        WornImu {
            bias,
            drift: user.gyro_drift,
            drift_period_s: user.drift_period_s,
            drift_phase,
            accel_noise: Normal::new(0.0, user.accel_noise).ok(),
            gyro_noise: Normal::new(0.0, user.gyro_noise).ok(),
        }
    }

    /// What it reads at `t` s of a head in `state`, its noise drawn from
    /// `rng`.
    pub fn read(&self, t: f64, state: &HeadState, rng: &mut ChaCha8Rng) -> ImuSample {
        let (accel, gyro) = ideal_reading(state);
        let mut values = [0.0; 6];
        for k in 0..3 {
            let drift =
                self.drift * (2.0 * PI * t / self.drift_period_s + self.drift_phase[k]).sin();
            values[k] = accel[k] + self.accel_noise.map_or(0.0, |n| n.sample(rng));
            values[k + 3] =
                gyro[k] + self.bias[k] + drift + self.gyro_noise.map_or(0.0, |n| n.sample(rng));
        }
        ImuSample { values }
    }
}
