//! Keeping the tool inside its workspace and the fingers inside their
//! travel: a request is held off when braking one tick later could no
//! longer stop short of a boundary by the margin.

use nalgebra::Vector3;

use crate::control::motion::workspace::{self, Boundary};
use crate::control::motion::{CYCLE_S, FINGER_MARGIN, MIN_START_M, Motion, braking, vec3};

impl Motion {
    /// Whether the tool, moving along `u` at `speed` with acceleration
    /// `accel`, must brake now to stop short of a boundary by the margin,
    /// and which boundary.
    pub(super) fn must_brake(
        &self,
        u: &Vector3<f64>,
        speed: f64,
        accel: f64,
        a_max: f64,
        j_max: f64,
    ) -> Option<Boundary> {
        let (distance, boundary) =
            workspace::distance_to_boundary(&self.pose.translation.vector, u, &self.workspace);
        let room = distance - self.workspace.stop_margin_m;
        let dt = CYCLE_S;
        let needed = if speed < 1e-9 && accel <= 0.0 {
            MIN_START_M
        } else {
            braking::room_to_brake_next_cycle(speed, accel, a_max, j_max, dt)
        };
        (needed >= room).then_some(boundary).flatten()
    }

    /// Zeroes a linear request that would cross a boundary. Returns the
    /// boundary when it starts holding the request off.
    pub(super) fn hold_linear_at_boundary(
        &mut self,
        linear: &mut Vector3<f64>,
    ) -> Option<Boundary> {
        let request = *linear;
        if request == Vector3::zeros() {
            self.linear_blocked = None;
            return None;
        }
        let wanted = request.normalize();
        if let Some(blocked) = self.linear_blocked {
            if blocked.dot(&wanted) > 0.0 {
                *linear = Vector3::zeros();
                return None;
            }
            self.linear_blocked = None;
        }
        let v = vec3(&self.input.current_velocity, 0);
        let a = vec3(&self.input.current_acceleration, 0);
        let speed = v.norm();
        let u = if speed > 1e-9 { v / speed } else { wanted };
        if u.dot(&wanted) <= 0.0 {
            return None; // reversing: already braking harder than a stop
        }
        let l = &self.limits;
        let boundary = self.must_brake(
            &u,
            v.dot(&u),
            a.dot(&u),
            l.linear_acceleration_mps2,
            l.linear_jerk_mps3,
        )?;
        *linear = Vector3::zeros();
        self.linear_blocked = Some(wanted);
        Some(boundary)
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
        let first = |values: &[f64]| values.first().copied().unwrap_or(0.0);
        let (v, a) = (
            first(&self.finger_input.current_velocity) * wanted,
            first(&self.finger_input.current_acceleration) * wanted,
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
        let dt = CYCLE_S;
        let needed = if v.abs() < 1e-9 && a <= 0.0 {
            1.0 // do not start with less than one unit of room
        } else if v < 0.0 {
            return None; // reversing
        } else {
            braking::room_to_brake_next_cycle(v, a, a_max, j_max, dt)
        };
        if needed < room {
            return None;
        }
        *fingers = 0.0;
        self.finger_blocked = Some(wanted);
        Some(boundary)
    }
}
