//! Skipping a step at exactly zero velocity once it is known to change
//! nothing. Integrating a pose over a tick at zero velocity leaves it as
//! it is but for the signs of zeros (`x + 0` is `x` for every `x` but
//! `−0`), so no step is skipped on that argument: a step is skipped only
//! where the very same step — zero velocity, this very pose, bit for bit —
//! was seen to change nothing. The step is a function of those alone, so
//! it would change nothing again.

use nalgebra::Isometry3;

/// A pose (and finger position) bit for bit.
pub type PoseBits = [u64; 8];

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

/// Every value is `+0.0` (not `−0.0`).
pub fn all_positive_zero(values: &[f64]) -> bool {
    values.iter().all(|v| v.to_bits() == 0)
}

/// `a == b`, without a call to `memcmp` for 64 bytes.
fn same(a: &PoseBits, b: &PoseBits) -> bool {
    a.iter().zip(b).fold(0, |differ, (x, y)| differ | (x ^ y)) == 0
}

/// The pose a zero-velocity step was seen to leave unchanged. `Copy`,
/// RT-safe.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StillPose {
    at: Option<PoseBits>,
}

impl StillPose {
    /// A zero-velocity step from `pose` is known to change nothing.
    pub fn known(&self, pose: &PoseBits) -> bool {
        self.at.is_some_and(|at| same(&at, pose))
    }

    /// A zero-velocity step went from `before` to `after`.
    pub fn observe(&mut self, before: &PoseBits, after: &PoseBits) {
        if same(before, after) {
            self.at = Some(*after);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{UnitQuaternion, Vector3};

    #[test]
    fn only_a_step_seen_to_change_nothing_is_known() {
        let pose = Isometry3::from_parts(
            Vector3::new(0.3, -0.0, 0.5).into(),
            UnitQuaternion::from_euler_angles(0.1, 0.0, -0.2),
        );
        let before = pose_bits(&pose, 0.0);
        let mut still = StillPose::default();
        assert!(!still.known(&before));
        let mut moved = pose;
        moved.translation.vector.y = 0.0; // −0 became +0: a change
        still.observe(&before, &pose_bits(&moved, 0.0));
        assert!(!still.known(&before));
        let after = pose_bits(&moved, 0.0);
        still.observe(&after, &after);
        assert!(still.known(&after) && !still.known(&before));
        assert!(all_positive_zero(&[0.0, 0.0]) && !all_positive_zero(&[0.0, -0.0]));
    }
}
