//! A request becomes Ruckig's targets and limits: target velocities
//! clamped to the speed limits, per-axis limits (scaled for a go-to), and
//! the speed scale of proportional control.

use nalgebra::Vector3;

use crate::control::motion::{Motion, set_all};

impl Motion {
    /// Per-axis limits: the configured ones scaled by `share` (1 = full).
    pub(super) fn set_axis_limits(&mut self, share: [f64; 6]) {
        let l = &self.limits;
        let input = &mut self.input;
        let axes = share
            .into_iter()
            .zip(input.max_velocity.iter_mut())
            .zip(input.max_acceleration.iter_mut())
            .zip(input.max_jerk.iter_mut())
            .enumerate();
        for (i, (((s, max_v), max_a), max_j)) in axes {
            // Never exactly zero: Ruckig needs positive limits.
            let s = s.max(1e-6);
            let (v, a, j) = if i < 3 {
                (
                    l.linear_speed_mps,
                    l.linear_acceleration_mps2,
                    l.linear_jerk_mps3,
                )
            } else {
                (
                    l.angular_speed_radps,
                    l.angular_acceleration_radps2,
                    l.angular_jerk_radps3,
                )
            };
            (*max_v, *max_a, *max_j) = (v * s, a * s, j * s);
        }
        self.scaled_limits = share != [1.0; 6];
    }

    pub(super) fn speed_scale(&self, strength_volts: f64) -> f64 {
        let l = &self.limits;
        if !l.proportional_speed {
            return 1.0;
        }
        let fraction = (strength_volts / l.proportional_full_scale_volts).clamp(0.0, 1.0);
        l.proportional_min_fraction + (1.0 - l.proportional_min_fraction) * fraction
    }

    /// Sets the velocity-interface targets, clamped to the speed limits.
    pub(super) fn set_velocity_target(&mut self, linear: Vector3<f64>, angular: Vector3<f64>) {
        let l = self.limits;
        let moving = linear != Vector3::zeros() || angular != Vector3::zeros();
        if moving && self.scaled_limits {
            self.set_axis_limits([1.0; 6]); // back from a goto's scaled limits
        }
        let v = linear.map(|x| x.clamp(-l.linear_speed_mps, l.linear_speed_mps));
        let w = angular.map(|x| x.clamp(-l.angular_speed_radps, l.angular_speed_radps));
        let finite = |x: f64| if x.is_finite() { x } else { 0.0 };
        set_all(
            &mut self.input.target_velocity,
            [v.x, v.y, v.z, w.x, w.y, w.z].map(finite),
        );
        self.input.target_acceleration.fill(0.0);
    }
}
