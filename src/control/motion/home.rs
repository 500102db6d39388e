//! Where the arm is at power-up.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use serde::Serialize;

/// The arm at power-up (`[arm]` in the config file).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HomeConfig {
    /// Tool position at power-up, m, base frame.
    pub home_position_m: [f64; 3],
    /// Tool orientation at power-up, as a rotation vector, rad.
    pub home_rotation_vector_rad: [f64; 3],
    /// Finger position at power-up, units.
    pub home_fingers: f64,
}

impl Default for HomeConfig {
    fn default() -> Self {
        HomeConfig {
            home_position_m: [0.21, -0.26, 0.48],
            home_rotation_vector_rad: [0.0, 0.0, 0.0],
            home_fingers: 0.0,
        }
    }
}

impl HomeConfig {
    /// The configured power-up pose.
    pub fn pose(&self) -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::from(Vector3::from(self.home_position_m)),
            UnitQuaternion::from_scaled_axis(Vector3::from(self.home_rotation_vector_rad)),
        )
    }
}
