//! A request becomes Ruckig's target speeds: clamped to the speed limits,
//! scaled for proportional control, along the current axis or — only from
//! rest — a new one, and held off where a boundary or an orientation limit
//! is too close.

use nalgebra::Vector3;

use crate::control::motion::workspace::Boundary;
use crate::control::motion::{ANGULAR, LINEAR, Motion, finite_or_zero, get, put};

/// Below these the speed and acceleration of a channel count as rest (the
/// last ulps of a finished brake), in the channel's units.
const REST: (f64, f64) = (1e-12, 1e-9);

/// Directions this close to parallel are the same line.
const SAME_LINE: f64 = 1.0 - 1e-9;

impl Motion {
    pub(super) fn speed_scale(&self, strength_volts: f64) -> f64 {
        let l = &self.limits;
        if !l.proportional_speed {
            return 1.0;
        }
        let fraction = (strength_volts / l.proportional_full_scale_volts).clamp(0.0, 1.0);
        l.proportional_min_fraction + (1.0 - l.proportional_min_fraction) * fraction
    }

    /// Whether the linear and angular channels are both at rest.
    pub(super) fn at_rest(&self) -> bool {
        self.channel_at_rest(LINEAR) && self.channel_at_rest(ANGULAR)
    }

    fn channel_at_rest(&self, dof: usize) -> bool {
        get(&self.input.current_velocity, dof).abs() < REST.0
            && get(&self.input.current_acceleration, dof).abs() < REST.1
    }

    /// The target speed along the linear axis for `request` (signed unit
    /// direction, speed), and the boundary if one starts holding it off.
    pub(super) fn linear_target(
        &mut self,
        request: Option<(Vector3<f64>, f64)>,
    ) -> (f64, Option<Boundary>) {
        self.channel_target(LINEAR, request)
    }

    /// The target rate about the angular axis, as [`Motion::linear_target`].
    pub(super) fn angular_target(
        &mut self,
        request: Option<(Vector3<f64>, f64)>,
    ) -> (f64, Option<Boundary>) {
        self.channel_target(ANGULAR, request)
    }

    /// One channel's target: held off once per request by a limit, braked
    /// to rest before a new direction, zero where a limit is too close.
    fn channel_target(
        &mut self,
        dof: usize,
        request: Option<(Vector3<f64>, f64)>,
    ) -> (f64, Option<Boundary>) {
        let linear = dof == LINEAR;
        let Some((wanted, speed)) = request else {
            *self.blocked(linear) = None;
            return (0.0, None);
        };
        if let Some(blocked) = *self.blocked(linear) {
            if blocked.dot(&wanted) > SAME_LINE {
                return (0.0, None); // still held off: said once
            }
            *self.blocked(linear) = None;
        }
        let max = if linear {
            self.limits.linear_speed_mps
        } else {
            self.limits.angular_speed_radps
        };
        let Some(target) = self.line_target(dof, wanted, speed, max) else {
            return (0.0, None); // braking to rest before the new direction
        };
        if target == 0.0 {
            return (0.0, None);
        }
        let sign = target.signum();
        let boundary = if linear {
            self.linear_must_brake(&(self.linear_axis * sign), sign)
        } else {
            self.angular_must_brake(&(self.angular_axis * sign), sign)
        };
        if boundary.is_some() {
            *self.blocked(linear) = Some(wanted);
            return (0.0, boundary);
        }
        (target, None)
    }

    /// The request held off by a limit, for the linear or angular channel.
    fn blocked(&mut self, linear: bool) -> &mut Option<Vector3<f64>> {
        if linear {
            &mut self.linear_blocked
        } else {
            &mut self.angular_blocked
        }
    }

    /// The signed target along the channel's axis for a request along
    /// `wanted`; `None` while the channel still moves along another line
    /// (it brakes first: an axis changes only from rest, so the velocity
    /// vector stays on one line and its limits hold as a vector).
    fn line_target(
        &mut self,
        dof: usize,
        wanted: Vector3<f64>,
        speed: f64,
        max: f64,
    ) -> Option<f64> {
        let speed = finite_or_zero(speed).clamp(0.0, max);
        if !wanted.iter().all(|x| x.is_finite()) || wanted.norm() < 0.5 {
            return Some(0.0);
        }
        let axis = if dof == LINEAR {
            &mut self.linear_axis
        } else {
            &mut self.angular_axis
        };
        let along = wanted.dot(axis);
        if along.abs() > SAME_LINE {
            return Some(speed * along.signum());
        }
        if get(&self.input.current_velocity, dof).abs() < REST.0
            && get(&self.input.current_acceleration, dof).abs() < REST.1
        {
            *axis = wanted;
            self.arm_rest = false;
            put(&mut self.input.current_velocity, dof, 0.0);
            put(&mut self.input.current_acceleration, dof, 0.0);
            return Some(speed);
        }
        None
    }
}
