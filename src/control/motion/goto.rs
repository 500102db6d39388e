//! Go to the saved point: from rest, a straight line and a turn about one
//! fixed axis, on the arm channel's position interface (the distance and
//! the angle arrive together); released or blocked, it brakes along the
//! same line in the velocity plan.

use crate::control::motion::boundaries::ROUNDING_GUARD;
use crate::control::motion::workspace::Boundary;
use crate::control::motion::{ANGULAR, AT_POINT, Goto, LINEAR, Motion, MotionEvent, Plan};

impl Motion {
    /// With `goto_point` held: says there is nothing saved, waits for what
    /// still moves to brake, or — from rest — starts moving to the saved
    /// pose. Starting only from rest keeps the plan inside the limits (no
    /// state Ruckig could refuse) and the path on one line.
    pub(super) fn try_start_goto(&mut self) -> Option<MotionEvent> {
        let Some(goal) = self.saved else {
            self.goto = Goto::Done;
            return Some(MotionEvent::NoSavedPoint);
        };
        if !(self.arm.at_rest(LINEAR) && self.arm.at_rest(ANGULAR)) {
            return None; // the velocity plan's zero targets brake it first
        }
        let start = self.pose;
        let delta_p = goal.translation.vector - start.translation.vector;
        // Base-frame rotation from here to the goal.
        let delta_r = (goal.rotation * start.rotation.inverse()).scaled_axis();
        let (distance, angle) = (delta_p.norm(), delta_r.norm());
        if distance < AT_POINT.0 && angle < AT_POINT.1 {
            self.goto = Goto::Done;
            return Some(MotionEvent::AlreadyAtSavedPoint);
        }
        self.goto = Goto::Idle;
        let [linear_axis, angular_axis] = &mut self.axes;
        if distance > 0.0 {
            *linear_axis = delta_p / distance;
        }
        if angle > 0.0 {
            *angular_axis = delta_r / angle;
        }
        self.arm.go_to([distance, angle]);
        self.plan = Plan::Goto;
        Some(MotionEvent::GotoStarted {
            distance_m: distance,
            angle_rad: angle,
        })
    }

    /// Whether going on towards the saved pose would cross a boundary or
    /// an orientation limit before reaching it (the straight line may pass
    /// near the base; the turn may leave the tilt cone).
    pub(super) fn goto_blocked(&self) -> Option<Boundary> {
        let [linear_axis, angular_axis] = self.axes;
        let remaining = |dof| self.arm.remaining(dof) + ROUNDING_GUARD;
        let (room, _) = self.bounds.linear_room(&self.pose, &linear_axis);
        if room < remaining(LINEAR)
            && let Some(boundary) = self.must_brake(LINEAR, &linear_axis, 1.0)
        {
            return Some(boundary);
        }
        let (room, _) = self.bounds.angular_room(&self.pose, &angular_axis);
        if room < remaining(ANGULAR)
            && let Some(boundary) = self.must_brake(ANGULAR, &angular_axis, 1.0)
        {
            return Some(boundary);
        }
        None
    }

    /// Leaves the go-to: the speeds along the line and about the axis
    /// carry over into the velocity plan, which brakes them to rest.
    pub(super) fn brake_goto(&mut self) {
        self.use_velocity_plan();
        self.arm.ask_velocities([0.0; 2]);
    }
}
