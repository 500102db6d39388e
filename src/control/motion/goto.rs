//! Go to the saved point: from rest, a straight line and a turn about one
//! fixed axis, with Ruckig's position interface on the distance and the
//! angle (both arrive together); and the way back to the velocity plan.

use rsruckig::prelude::*;

use crate::control::motion::workspace::Boundary;
use crate::control::motion::{
    ANGULAR, AT_POINT, LINEAR, Motion, MotionEvent, Plan, ROUNDING_GUARD, get, set_all,
};

impl Motion {
    /// With `goto_point` held: says there is nothing saved, brakes what
    /// still moves, or — from rest — starts moving to the saved pose.
    /// Starting only from rest keeps the plan inside the limits (no state
    /// Ruckig could refuse) and the path on one line.
    pub(super) fn try_start_goto(&mut self) -> Option<MotionEvent> {
        let Some(goal) = self.saved else {
            self.goto_pending = false;
            self.goto_done = true;
            return Some(MotionEvent::NoSavedPoint);
        };
        if !self.at_rest() {
            return None; // the velocity plan's zero targets brake it first
        }
        self.goto_pending = false;
        let start = self.pose;
        let delta_p = goal.translation.vector - start.translation.vector;
        // Base-frame rotation from here to the goal.
        let delta_r = (goal.rotation * start.rotation.inverse()).scaled_axis();
        let (distance, angle) = (delta_p.norm(), delta_r.norm());
        if distance < AT_POINT.0 && angle < AT_POINT.1 {
            self.goto_done = true;
            return Some(MotionEvent::AlreadyAtSavedPoint);
        }
        if distance > 0.0 {
            self.linear_axis = delta_p / distance;
        }
        if angle > 0.0 {
            self.angular_axis = delta_r / angle;
        }
        self.arm_rest = false;
        let input = &mut self.input;
        input.current_position.fill(0.0);
        input.current_velocity.fill(0.0);
        input.current_acceleration.fill(0.0);
        set_all(&mut input.target_position, [distance, angle]);
        input.target_velocity.fill(0.0);
        input.target_acceleration.fill(0.0);
        input.control_interface = ControlInterface::Position;
        input.synchronization = Synchronization::Time;
        self.plan = Plan::Goto;
        Some(MotionEvent::GotoStarted {
            distance_m: distance,
            angle_rad: angle,
        })
    }

    /// Whether going on towards the saved pose would cross a boundary or
    /// an orientation limit before reaching it (the straight line may pass
    /// near the base; the turn may leave the tilt cone).
    pub(super) fn goto_blocked(&mut self) -> Option<Boundary> {
        let input = &self.input;
        let remaining = [LINEAR, ANGULAR].map(|dof| {
            get(&input.target_position, dof) - get(&input.current_position, dof) + ROUNDING_GUARD
        });
        let (linear_axis, angular_axis) = (self.linear_axis, self.angular_axis);
        let (room, _) = self.linear_room(&linear_axis);
        if room < remaining[LINEAR]
            && let Some(boundary) = self.linear_must_brake(&linear_axis, 1.0)
        {
            return Some(boundary);
        }
        let (room, _) = self.angular_room(&angular_axis);
        if room < remaining[ANGULAR]
            && let Some(boundary) = self.angular_must_brake(&angular_axis, 1.0)
        {
            return Some(boundary);
        }
        None
    }

    /// Leaves the goto: brake to rest along the line.
    pub(super) fn brake_goto(&mut self) {
        self.switch_to_velocity_plan();
        self.input.target_velocity.fill(0.0);
        self.input.target_acceleration.fill(0.0);
    }

    /// Switches Ruckig to the velocity interface; the speeds along the
    /// line and about the axis carry over as they are.
    pub(super) fn switch_to_velocity_plan(&mut self) {
        self.arm_rest = false;
        self.plan = Plan::Velocity;
        self.input.control_interface = ControlInterface::Velocity;
        self.input.synchronization = Synchronization::None;
    }
}
