//! Go to the saved point: a straight line with Ruckig's position
//! interface, and the way back to the velocity plan when it ends.

use rsruckig::prelude::*;

use crate::control::motion::workspace::Boundary;
use crate::control::motion::{AT_POINT, Motion, MotionEvent, Plan, set_all, vec3};

impl Motion {
    /// Starts moving to the saved pose, or says why not.
    pub(super) fn start_goto(&mut self) -> Option<MotionEvent> {
        let Some(goal) = self.saved else {
            self.goto_done = true;
            return Some(MotionEvent::NoSavedPoint);
        };
        let start = self.pose.rotation;
        let delta_p = goal.translation.vector - self.pose.translation.vector;
        let delta_r = (start.inverse() * goal.rotation).scaled_axis();
        let (distance, angle) = (delta_p.norm(), delta_r.norm());
        if distance < AT_POINT.0 && angle < AT_POINT.1 {
            self.goto_done = true;
            return Some(MotionEvent::AlreadyAtSavedPoint);
        }
        let share = |v: f64, n: f64| if n > 0.0 { v.abs() / n } else { 0.0 };
        self.set_axis_limits([
            share(delta_p.x, distance),
            share(delta_p.y, distance),
            share(delta_p.z, distance),
            share(delta_r.x, angle),
            share(delta_r.y, angle),
            share(delta_r.z, angle),
        ]);
        let (p, g) = (self.pose.translation.vector, goal.translation.vector);
        let input = &mut self.input;
        // The velocity-plan state (ω in the tool frame) is the rate of the
        // rotation vector relative to the current orientation.
        set_all(&mut input.current_position, [p.x, p.y, p.z, 0.0, 0.0, 0.0]);
        set_all(
            &mut input.target_position,
            [g.x, g.y, g.z, delta_r.x, delta_r.y, delta_r.z],
        );
        input.target_velocity.fill(0.0);
        input.target_acceleration.fill(0.0);
        input.control_interface = ControlInterface::Position;
        input.synchronization = Synchronization::Time;
        self.plan = Plan::Goto { start };
        Some(MotionEvent::GotoStarted {
            distance_m: distance,
            angle_rad: angle,
        })
    }

    /// Whether going on towards the saved pose would cross a boundary
    /// (the straight line may pass near the base).
    pub(super) fn goto_blocked(&self) -> Option<Boundary> {
        let v = vec3(&self.input.current_velocity, 0);
        let speed = v.norm();
        if speed < 1e-9 {
            return None;
        }
        let a = vec3(&self.input.current_acceleration, 0);
        let u = v / speed;
        let l = &self.limits;
        self.must_brake(
            &u,
            speed,
            a.dot(&u),
            l.linear_acceleration_mps2,
            l.linear_jerk_mps3,
        )
    }

    /// Leaves the goto: brake to rest along the line.
    pub(super) fn brake_goto(&mut self) {
        self.switch_to_velocity_plan();
        self.input.target_velocity.fill(0.0);
        self.input.target_acceleration.fill(0.0);
    }

    /// Switches the trajectory state to the velocity plan, converting the
    /// angular state from rotation-vector rates to the tool frame.
    pub(super) fn switch_to_velocity_plan(&mut self) {
        if let Plan::Goto { start } = self.plan {
            let to_tool = self.pose.rotation.inverse() * start;
            for state in [
                &mut self.input.current_velocity,
                &mut self.input.current_acceleration,
            ] {
                let w = to_tool * vec3(state, 3);
                for (slot, value) in state.iter_mut().skip(3).zip(w.iter()) {
                    *slot = *value;
                }
            }
        }
        self.plan = Plan::Velocity;
        self.input.control_interface = ControlInterface::Velocity;
        self.input.synchronization = Synchronization::None;
    }
}
