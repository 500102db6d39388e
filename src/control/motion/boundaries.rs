//! Keeping the tool inside its workspace and orientation limits and the
//! fingers inside their travel: a request is held off when braking one
//! tick later could no longer stop short of a limit.
//!
//! The linear room is the distance along the line of travel to the
//! workspace shrunk by the stop margin (plus a rounding guard): the margin
//! holds as a normal distance to every boundary, whatever the direction of
//! travel. The angular room is the turn about the axis to the first
//! orientation limit (see [`orientation`](super::orientation)).

use nalgebra::Vector3;

use crate::control::motion::workspace::{self, Boundary};
use crate::control::motion::{
    ANGULAR, CYCLE_S, FINGER_MARGIN, LINEAR, MIN_START_M, MIN_START_RAD, Motion, ROUNDING_GUARD,
    braking, get,
};

/// The fingers' channel of [`Motion::brake_room`] (after the arm's two).
const FINGERS: usize = 2;

impl Motion {
    /// Distance along the unit `u` from the current position to the
    /// workspace shrunk by the margin, and which boundary is there.
    pub(super) fn linear_room(&self, u: &Vector3<f64>) -> (f64, Option<Boundary>) {
        let inner = workspace::shrunk(
            &self.workspace,
            self.workspace.stop_margin_m + ROUNDING_GUARD,
        );
        workspace::distance_to_boundary(&self.pose.translation.vector, u, &inner)
    }

    /// Turn about the unit `u` from the current orientation to the first
    /// orientation limit (less the rounding guard), and which one.
    pub(super) fn angular_room(&self, u: &Vector3<f64>) -> (f64, Option<Boundary>) {
        let (room, limit) = self.orientation_room.room(&self.pose.rotation, u);
        ((room - ROUNDING_GUARD).max(0.0), limit)
    }

    /// Whether the linear channel, about to be driven along `u` (its axis
    /// times `sign`), must brake now to stop inside the margin.
    pub(super) fn linear_must_brake(&mut self, u: &Vector3<f64>, sign: f64) -> Option<Boundary> {
        let (room, boundary) = self.linear_room(u);
        let l = &self.limits;
        let need = self.room_needed(
            LINEAR,
            sign,
            l.linear_acceleration_mps2,
            l.linear_jerk_mps3,
            MIN_START_M,
        );
        (need >= room).then_some(boundary).flatten()
    }

    /// Whether the angular channel, about to be driven about `u`, must
    /// brake now to stop inside the orientation limits.
    pub(super) fn angular_must_brake(&mut self, u: &Vector3<f64>, sign: f64) -> Option<Boundary> {
        let (room, boundary) = self.angular_room(u);
        let l = &self.limits;
        let need = self.room_needed(
            ANGULAR,
            sign,
            l.angular_acceleration_radps2,
            l.angular_jerk_radps3,
            MIN_START_RAD,
        );
        (need >= room).then_some(boundary).flatten()
    }

    /// Room needed ahead (in the direction `sign` along the channel's
    /// axis) to keep going one more tick and still stop: the worst case
    /// of full jerk ahead for a tick, then braking; `min_start` from rest.
    fn room_needed(
        &mut self,
        dof: usize,
        sign: f64,
        a_max: f64,
        j_max: f64,
        min_start: f64,
    ) -> f64 {
        let v = get(&self.input.current_velocity, dof) * sign;
        let a = get(&self.input.current_acceleration, dof) * sign;
        if v.abs() < 1e-9 && a <= 0.0 {
            min_start
        } else {
            self.brake_room(dof, v, a, a_max, j_max)
        }
    }

    /// [`braking::room_to_brake_next_cycle`] for channel `channel`
    /// (linear, angular, fingers), the last answer given again to the
    /// same question (computed every time with
    /// [`Motion::always_update`]).
    fn brake_room(&mut self, channel: usize, v: f64, a: f64, a_max: f64, j_max: f64) -> f64 {
        let memo = self.brake_rooms.get_mut(channel);
        let Some(memo) = memo.filter(|_| !self.always_update) else {
            return braking::room_to_brake_next_cycle(v, a, a_max, j_max, CYCLE_S);
        };
        let (room, repeated) = memo.room(v, a, a_max, j_max, CYCLE_S);
        self.brake_room_repeats += u64::from(repeated);
        room
    }

    /// Zeroes a finger request that would run past an end.
    pub(super) fn hold_fingers_at_end(&mut self, fingers: &mut f64) -> Option<Boundary> {
        let request = *fingers;
        if request == 0.0 {
            self.finger_blocked = None;
            return None;
        }
        let wanted = request.signum();
        if self.finger_blocked == Some(wanted) {
            *fingers = 0.0;
            return None;
        }
        self.finger_blocked = None;
        let (v, a) = (
            get(&self.finger_input.current_velocity, 0) * wanted,
            get(&self.finger_input.current_acceleration, 0) * wanted,
        );
        let (room, boundary) = if wanted > 0.0 {
            (
                self.workspace.finger_closed - FINGER_MARGIN - self.fingers,
                Boundary::FingersClosed,
            )
        } else {
            (self.fingers - FINGER_MARGIN, Boundary::FingersOpen)
        };
        let (a_max, j_max) = (self.limits.finger_acceleration, self.limits.finger_jerk);
        let needed = if v.abs() < 1e-9 && a <= 0.0 {
            1.0 // do not start with less than one unit of room
        } else {
            self.brake_room(FINGERS, v, a, a_max, j_max)
        };
        if needed < room {
            return None;
        }
        *fingers = 0.0;
        self.finger_blocked = Some(wanted);
        Some(boundary)
    }
}
