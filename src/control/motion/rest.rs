//! At rest, a tick asks nothing new and changes nothing: its work is
//! skipped where it is known to give the same result, bit for bit. A
//! channel resting since its last update, asked for nothing, skips its
//! update ([`Channel`](super::channel)); a rest tick that follows a rest
//! tick which left every velocity and the pose exactly as they were is
//! that tick again, and repeats its output ([`RestTicks`]). Both are
//! proven against the reference path, which skips nothing
//! (`tests/it/fast_paths.rs`).

use nalgebra::Isometry3;

use crate::control::skip_count::SkipCount;

/// A pose (and finger position) bit for bit.
pub type PoseBits = [u64; 8];

/// A step's seven velocities (linear, angular, fingers) bit for bit.
pub type VelocityBits = [u64; 7];

/// `pose` and `fingers`, bit for bit.
pub fn pose_bits(pose: &Isometry3<f64>, fingers: f64) -> PoseBits {
    let t = &pose.translation.vector;
    let q = &pose.rotation.coords;
    [t.x, t.y, t.z, q.x, q.y, q.z, q.w, fingers].map(f64::to_bits)
}

/// Seven velocities, bit for bit.
pub fn velocity_bits(velocity: &[f64; 7]) -> VelocityBits {
    velocity.map(f64::to_bits)
}

/// Every value is a zero, `+0.0` or `−0.0` (no NaN).
pub fn all_zero(values: &[f64]) -> bool {
    values.iter().all(|v| *v == 0.0)
}

/// Whether the next rest tick repeats the last one. `Copy`, RT-safe.
#[derive(Debug, Clone, Copy, Default)]
pub struct RestTicks {
    /// The last tick rested at zero velocity, its pose step changed
    /// nothing, and nothing has touched the motion since.
    repeat: bool,
    /// Never repeat: the reference path.
    reference_path: bool,
    /// Rest ticks repeated.
    repeats: SkipCount,
}

impl RestTicks {
    /// Never repeat a tick.
    #[cfg(any(test, feature = "testing"))]
    pub fn use_reference_path(&mut self) {
        self.reference_path = true;
    }

    /// Rest ticks repeated so far.
    #[cfg(any(test, feature = "testing"))]
    pub fn repeats(&self) -> SkipCount {
        self.repeats
    }

    /// Something other than a rest tick changed the motion.
    pub fn touched(&mut self) {
        self.repeat = false;
    }

    /// The coming rest tick repeats the last one (counted if so).
    pub fn repeats_last(&mut self) -> bool {
        if self.repeat {
            self.repeats.add();
        }
        self.repeat
    }

    /// A rest tick ended at `twist`, its pose step `unchanged` or not. The
    /// channels rest, so the next rest tick has the same twist, and its
    /// mean velocity, the mean of two equal twists, is that twist too
    /// (zeros' signs included): it steps the same way from the same pose,
    /// and repeats this tick if this tick's step changed nothing.
    pub fn rested(&mut self, twist: &[f64; 7], unchanged: bool) {
        self.repeat = !self.reference_path && unchanged && all_zero(twist);
    }
}
