//! Simulated people wearing a head IMU: how fast and how far they move,
//! and what their sensor and body add (white noise, a gyro bias that
//! drifts, a head tremor, a wheelchair's vibration, a resting posture a
//! few degrees off level). Their gestures are in
//! [`crate::sim::head_gesture`], their sessions in
//! [`crate::sim::imu_session`].

use serde::Serialize;

/// A simulated IMU user's true parameters. Angles in degrees, rates in
/// rad/s, accelerations in m/s².
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ImuUser {
    /// Name of a built-in user (`generate --imu-user`).
    pub name: &'static str,
    /// Movement speed factor: every gesture's and movement's duration is
    /// divided by it (0.6–1.4: the issue's ±40 %).
    pub speed: f64,
    /// Movement amplitude factor: every gesture's angles are multiplied
    /// by it (0.7–1.3: ±30 %).
    pub amplitude: f64,
    /// Each gesture example's duration and amplitude vary uniformly by
    /// ± this fraction (the same person never does it twice alike).
    pub within_person: f64,
    /// Standard deviation of the accelerometer's white noise, per axis.
    pub accel_noise: f64,
    /// Standard deviation of the gyro's white noise, per axis.
    pub gyro_noise: f64,
    /// Largest gyro bias, per axis: each session draws one uniformly in ±.
    pub gyro_bias: f64,
    /// Amplitude of the bias's slow sinusoidal drift, per axis.
    pub gyro_drift: f64,
    /// Period of that drift, s.
    pub drift_period_s: f64,
    /// Head tremor frequency, Hz (4–6 Hz; pitch and yaw mostly).
    pub tremor_hz: f64,
    /// Head tremor amplitude, degrees (0: none).
    pub tremor_deg: f64,
    /// How deeply the tremor's amplitude is modulated (0–1), at
    /// [`ImuUser::TREMOR_MODULATION_HZ`].
    pub tremor_modulation: f64,
    /// RMS of the wheelchair's vibration felt all the time, m/s²
    /// (0: none; the ordinary movement's rides come on top).
    pub wheelchair: f64,
    /// Resting head pitch, degrees (positive nose down).
    pub posture_pitch_deg: f64,
    /// Resting head roll, degrees (positive right ear down).
    pub posture_roll_deg: f64,
    /// Samples per second (1–1000; ticks are ms, rounded).
    pub rate_hz: u32,
}

impl ImuUser {
    /// The built-in users' names.
    pub const NAMES: [&'static str; 6] = [
        "typical",
        "slow_small",
        "fast_large",
        "tremor",
        "wheelchair",
        "drifting",
    ];

    /// How fast a tremor's amplitude waxes and wanes, Hz.
    pub const TREMOR_MODULATION_HZ: f64 = 0.2;

    /// The default sample rate, Hz.
    pub const DEFAULT_RATE_HZ: u32 = 100;

    /// The typical user: the others differ from it in a few fields.
    const TYPICAL: ImuUser = ImuUser {
        name: "typical",
        speed: 1.0,
        amplitude: 1.0,
        within_person: 0.15,
        accel_noise: 0.02,
        gyro_noise: 0.003,
        gyro_bias: 0.01,
        gyro_drift: 0.002,
        drift_period_s: 300.0,
        tremor_hz: 5.0,
        tremor_deg: 0.05,
        tremor_modulation: 0.3,
        wheelchair: 0.0,
        posture_pitch_deg: 3.0,
        posture_roll_deg: -2.0,
        rate_hz: ImuUser::DEFAULT_RATE_HZ,
    };

    /// Every built-in user, in the order of [`ImuUser::NAMES`].
    pub fn all() -> [ImuUser; 6] {
        let t = ImuUser::TYPICAL;
        [
            t,
            ImuUser {
                name: "slow_small",
                speed: 0.6,
                amplitude: 0.7,
                posture_pitch_deg: 6.0,
                posture_roll_deg: 3.0,
                ..t
            },
            ImuUser {
                name: "fast_large",
                speed: 1.4,
                amplitude: 1.3,
                posture_pitch_deg: -2.0,
                posture_roll_deg: 1.0,
                ..t
            },
            ImuUser {
                name: "tremor",
                speed: 0.85,
                amplitude: 0.9,
                tremor_hz: 4.5,
                tremor_deg: 1.0,
                tremor_modulation: 0.5,
                posture_pitch_deg: 8.0,
                ..t
            },
            ImuUser {
                name: "wheelchair",
                wheelchair: 0.5,
                accel_noise: 0.03,
                posture_roll_deg: 4.0,
                ..t
            },
            ImuUser {
                name: "drifting",
                speed: 1.15,
                amplitude: 1.1,
                gyro_bias: 0.03,
                gyro_drift: 0.02,
                drift_period_s: 120.0,
                gyro_noise: 0.005,
                ..t
            },
        ]
    }

    /// The built-in user named `name`; the error lists the names.
    pub fn builtin(name: &str) -> Result<ImuUser, String> {
        ImuUser::all()
            .into_iter()
            .find(|u| u.name == name)
            .ok_or_else(|| format!("no IMU user {name:?}: one of {}", ImuUser::NAMES.join(", ")))
    }

    /// The same user, sampled at `rate_hz`.
    pub fn at_rate(self, rate_hz: u32) -> ImuUser {
        ImuUser { rate_hz, ..self }
    }

    /// The same user with a perfect sensor and a still body: no noise,
    /// bias, drift, tremor or vibration (for tests of the physics).
    pub fn ideal(self) -> ImuUser {
        ImuUser {
            accel_noise: 0.0,
            gyro_noise: 0.0,
            gyro_bias: 0.0,
            gyro_drift: 0.0,
            tremor_deg: 0.0,
            wheelchair: 0.0,
            ..self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn built_in_users_span_the_issues_ranges() {
        let all = ImuUser::all();
        let names: Vec<&str> = all.iter().map(|u| u.name).collect();
        assert_eq!(names, ImuUser::NAMES);
        let speeds = all.iter().map(|u| u.speed);
        assert_eq!(speeds.clone().fold(f64::MAX, f64::min), 0.6);
        assert_eq!(speeds.fold(0.0, f64::max), 1.4);
        let amplitudes = all.iter().map(|u| u.amplitude);
        assert_eq!(amplitudes.clone().fold(f64::MAX, f64::min), 0.7);
        assert_eq!(amplitudes.fold(0.0, f64::max), 1.3);
        for u in all {
            assert!((4.0..=6.0).contains(&u.tremor_hz), "{}", u.name);
        }
        let e = ImuUser::builtin("nobody").unwrap_err();
        assert_eq!(
            e,
            "no IMU user \"nobody\": one of typical, slow_small, fast_large, tremor, wheelchair, drifting"
        );
        assert_eq!(ImuUser::builtin("tremor").unwrap().tremor_deg, 1.0);
    }
}
