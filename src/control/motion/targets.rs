//! Each tick's request (a signed unit direction and a speed) becomes the
//! channels' targets: the speed along the current axis or, from rest, a
//! new one, clamped to the limits; zero where braking one tick later
//! could no longer stop short of a boundary.

use nalgebra::Vector3;

use crate::control::modes::ModeOutput;
use crate::control::motion::boundaries::Braking;
use crate::control::motion::workspace::Boundary;
use crate::control::motion::{LINEAR, Motion, finite_or_zero};

/// From rest, the tool does not start towards a boundary with less room
/// than this past the stop margin, m (no creeping by fractions of a mm).
pub const MIN_START_M: f64 = 0.002;
/// From rest, the tool does not start turning towards an orientation limit
/// with less room than this, rad.
pub const MIN_START_RAD: f64 = 0.002;
/// Directions this close to parallel are the same line.
const SAME_LINE: f64 = 1.0 - 1e-9;

impl Motion {
    /// The fraction of full speed for a command: proportional to the
    /// head's tilt past its dead zone; for a breath `strength_volts` past
    /// its threshold with proportional control, else 1.
    pub(super) fn speed_scale(&self, command: &ModeOutput) -> f64 {
        let l = &self.limits;
        let fraction = match command.speed_fraction {
            Some(fraction) => fraction,
            None if l.proportional_speed => {
                command.strength_volts / l.proportional_full_scale_volts
            }
            None => return 1.0,
        };
        l.proportional_min_fraction + (1.0 - l.proportional_min_fraction) * fraction.clamp(0.0, 1.0)
    }

    /// The arm channel's target on `dof` for a request (signed unit
    /// direction, speed): the speed along the current axis or — only from
    /// rest — a new one, clamped to the limit; zero while braking before
    /// a new direction, or where a boundary is too close (said once).
    pub(super) fn arm_target(
        &mut self,
        dof: usize,
        request: Option<(Vector3<f64>, f64)>,
    ) -> (f64, Option<Boundary>) {
        let Some((wanted, speed)) = request else {
            self.arm.block(dof, None);
            return (0.0, None);
        };
        if let Some(blocked) = self.arm.blocked(dof) {
            if blocked.dot(&wanted) > SAME_LINE {
                return (0.0, None); // still held off: said once
            }
            self.arm.block(dof, None);
        }
        let max = if dof == LINEAR {
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
        let boundary = self.must_brake(dof, &(self.axis(dof) * sign), sign);
        if boundary.is_some() {
            self.arm.block(dof, Some(wanted));
            return (0.0, boundary);
        }
        (target, None)
    }

    /// The signed target speed along the channel's axis for `wanted`:
    /// along the axis if `wanted` is on its line; else, from rest, the
    /// axis becomes `wanted`; else `None` (brake first).
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
        let along = wanted.dot(&self.axis(dof));
        if along.abs() > SAME_LINE {
            return Some(speed * along.signum());
        }
        if self.arm.at_rest(dof) {
            if let Some(axis) = self.axes.get_mut(dof) {
                *axis = wanted;
            }
            self.arm.restart_from_rest(dof);
            return Some(speed);
        }
        None
    }

    /// The arm channel's axis for `dof`.
    fn axis(&self, dof: usize) -> Vector3<f64> {
        self.axes.get(dof).copied().unwrap_or_else(Vector3::x)
    }

    /// Whether the arm channel, about to be driven along the unit `u` (its
    /// axis for `dof` times `sign`), must brake now to stop inside the
    /// margin or the orientation limits, and at which limit.
    pub(super) fn must_brake(&self, dof: usize, u: &Vector3<f64>, sign: f64) -> Option<Boundary> {
        let l = &self.limits;
        let ((room, boundary), braking) = if dof == LINEAR {
            let braking = Braking {
                max_acceleration: l.linear_acceleration_mps2,
                max_jerk: l.linear_jerk_mps3,
                min_start: MIN_START_M,
            };
            (self.bounds.linear_room(&self.pose, u), braking)
        } else {
            let braking = Braking {
                max_acceleration: l.angular_acceleration_radps2,
                max_jerk: l.angular_jerk_radps3,
                min_start: MIN_START_RAD,
            };
            (self.bounds.angular_room(&self.pose, u), braking)
        };
        let (v, a) = (
            self.arm.velocity(dof) * sign,
            self.arm.acceleration(dof) * sign,
        );
        braking.must_brake(v, a, room).then_some(boundary).flatten()
    }

    /// Zeroes a finger request that would run past an end.
    pub(super) fn hold_fingers_at_end(&mut self, fingers: &mut f64) -> Option<Boundary> {
        let request = *fingers;
        if request == 0.0 {
            self.fingers.block(0, None);
            return None;
        }
        let wanted = request.signum();
        let direction = Vector3::x() * wanted;
        if self.fingers.blocked(0) == Some(direction) {
            *fingers = 0.0;
            return None;
        }
        self.fingers.block(0, None);
        let (v, a) = (
            self.fingers.velocity(0) * wanted,
            self.fingers.acceleration(0) * wanted,
        );
        let (room, boundary) = self.bounds.finger_room(self.finger_position, wanted);
        let braking = Braking {
            max_acceleration: self.limits.finger_acceleration,
            max_jerk: self.limits.finger_jerk,
            min_start: 1.0, // do not start with less than one unit of room
        };
        if !braking.must_brake(v, a, room) {
            return None;
        }
        *fingers = 0.0;
        self.fingers.block(0, Some(direction));
        Some(boundary)
    }
}
