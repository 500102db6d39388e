//! Skipping a step at zero velocity once it is known to change nothing.
//! Integrating a pose over a tick at zero velocity leaves it as it is but
//! for the signs of zeros (`x + 0` is `x` for every `x` but `−0`, and a
//! velocity's zeros may be either sign: an axis with a negative component
//! times a speed of `+0` is `−0`), so no step is skipped on that argument:
//! a step is skipped only where the very same step — these velocities and
//! this very pose, bit for bit — was seen to change nothing. The step is a
//! function of those alone, so it would change nothing again.

use nalgebra::Isometry3;

/// A pose (and finger position) bit for bit.
pub type PoseBits = [u64; 8];

/// A step's seven velocities (linear, angular, fingers) bit for bit.
pub type VelocityBits = [u64; 7];

/// `pose` and `fingers`, bit for bit.
pub fn pose_bits(pose: &Isometry3<f64>, fingers: f64) -> PoseBits {
    let t = &pose.translation.vector;
    let q = &pose.rotation.coords;
    [
        t.x.to_bits(),
        t.y.to_bits(),
        t.z.to_bits(),
        q.x.to_bits(),
        q.y.to_bits(),
        q.z.to_bits(),
        q.w.to_bits(),
        fingers.to_bits(),
    ]
}

/// Seven velocities, bit for bit.
pub fn velocity_bits(velocity: &[f64; 7]) -> VelocityBits {
    velocity.map(f64::to_bits)
}

/// Every value is a zero, `+0.0` or `−0.0` (no NaN).
pub fn all_zero(values: &[f64]) -> bool {
    values.iter().all(|v| *v == 0.0)
}

/// `a == b`, without a call to `memcmp`.
fn same<const N: usize>(a: &[u64; N], b: &[u64; N]) -> bool {
    a.iter().zip(b).fold(0, |differ, (x, y)| differ | (x ^ y)) == 0
}

/// The zero-velocity step seen to leave its pose unchanged: the
/// velocities (their zeros' signs) and the pose. `Copy`, RT-safe.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StillStep {
    at: Option<(VelocityBits, PoseBits)>,
}

impl StillStep {
    /// A step at `velocity` from `pose` is known to change nothing.
    pub fn known(&self, velocity: &VelocityBits, pose: &PoseBits) -> bool {
        self.at
            .is_some_and(|(v, at)| same(&v, velocity) && same(&at, pose))
    }

    /// A step at `velocity` (all zeros) went from `before` to `after`.
    pub fn observe(&mut self, velocity: &VelocityBits, before: &PoseBits, after: &PoseBits) {
        if same(before, after) {
            self.at = Some((*velocity, *after));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{UnitQuaternion, Vector3};

    const PLUS: [f64; 7] = [0.0; 7];

    #[test]
    fn only_a_step_seen_to_change_nothing_is_known() {
        let pose = Isometry3::from_parts(
            Vector3::new(0.3, -0.0, 0.5).into(),
            UnitQuaternion::from_euler_angles(0.1, 0.0, -0.2),
        );
        let plus = velocity_bits(&PLUS);
        let before = pose_bits(&pose, 0.0);
        let mut still = StillStep::default();
        assert!(!still.known(&plus, &before));
        let mut moved = pose;
        moved.translation.vector.y = 0.0; // −0 became +0: a change
        still.observe(&plus, &before, &pose_bits(&moved, 0.0));
        assert!(!still.known(&plus, &before));
        let after = pose_bits(&moved, 0.0);
        still.observe(&plus, &after, &after);
        assert!(still.known(&plus, &after) && !still.known(&plus, &before));
        assert!(all_zero(&[0.0, -0.0]) && !all_zero(&[0.0, f64::NAN]));
        assert!(!all_zero(&[f64::MIN_POSITIVE]));
    }

    #[test]
    fn a_step_is_known_only_with_the_signs_of_its_zeros() {
        // Moving along −x, then stopped: the velocity is −1 × (+0) = −0.
        let minus_x = [-0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let pose = Isometry3::from_parts(
            Vector3::new(0.3, -0.26, 0.48).into(),
            UnitQuaternion::from_euler_angles(0.1, 0.0, -0.2),
        );
        let bits = pose_bits(&pose, 0.0);
        let mut still = StillStep::default();
        still.observe(&velocity_bits(&minus_x), &bits, &bits);
        assert!(still.known(&velocity_bits(&minus_x), &bits));
        // The same pose at +0 everywhere is another step, not yet seen.
        assert!(!still.known(&velocity_bits(&PLUS), &bits));
    }
}
