//! One Ruckig channel: a trajectory of `N` degrees of freedom shaped by
//! rsruckig every control cycle. The arm's channel carries the speed along
//! a line and the rate about an axis (on a go-to, the distance along the
//! line and the angle about the axis, arriving together); the fingers'
//! carries their one speed.
//!
//! A channel at rest whose last update changed nothing (every velocity and
//! acceleration, now and asked, zero, and Ruckig's own state the same)
//! would compute nothing again while it is asked for nothing: that update
//! is skipped ([`rest`](super::rest)) until something else touches the
//! channel. Debug builds check every skip against Ruckig's own comparison
//! of its inputs.

use nalgebra::Vector3;
use rsruckig::prelude::*;

use crate::control::motion::braking;
use crate::control::skip_count::SkipCount;

/// The control cycle, s.
pub const CYCLE_S: f64 = 0.001;

/// Below these (speed, acceleration) a degree of freedom counts as at rest.
const REST: (f64, f64) = (1e-12, 1e-9);

/// What a channel's update did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Update {
    /// At rest and asked for nothing: not run.
    Skipped,
    /// Under way.
    Working,
    /// At its target (settled exactly there).
    Finished,
    /// Ruckig failed (unreachable with validated limits).
    Failed,
}

/// One trajectory, its planner and what it was asked. RT-safe after
/// [`Channel::new`].
pub struct Channel<const N: usize> {
    otg: Ruckig<N, ThrowErrorHandler>,
    input: InputParameter<N>,
    output: OutputParameter<N>,
    /// Per degree of freedom, the direction asked for and held off by a
    /// limit: said once, until the request changes.
    blocked: [Option<Vector3<f64>>; N],
    /// At rest, and untouched since the update that found it so.
    resting: bool,
    /// Never skip an update: the reference path the skips are proven
    /// against.
    reference_path: bool,
    /// The inputs of the update that found the channel at rest (debug
    /// builds check every skip against them).
    #[cfg(debug_assertions)]
    rest_input: InputParameter<N>,
    /// Updates skipped.
    skipped: SkipCount,
}

impl<const N: usize> Channel<N> {
    /// At rest, in the velocity interface, with these limits per degree of
    /// freedom. Not RT-safe (call at start-up).
    pub fn new(max_velocity: [f64; N], max_acceleration: [f64; N], max_jerk: [f64; N]) -> Self {
        let mut input = InputParameter::new(None);
        input.control_interface = ControlInterface::Velocity;
        input.synchronization = Synchronization::None;
        set(&mut input.max_velocity, max_velocity);
        set(&mut input.max_acceleration, max_acceleration);
        set(&mut input.max_jerk, max_jerk);
        Channel {
            otg: Ruckig::new(None, CYCLE_S),
            #[cfg(debug_assertions)]
            rest_input: input.clone(),
            input,
            output: OutputParameter::new(None),
            blocked: [None; N],
            resting: false,
            reference_path: false,
            skipped: SkipCount::default(),
        }
    }

    /// Runs every update, at rest too.
    #[cfg(any(test, feature = "testing"))]
    pub fn use_reference_path(&mut self) {
        self.reference_path = true;
    }

    /// Updates skipped so far.
    #[cfg(any(test, feature = "testing"))]
    pub fn skipped(&self) -> SkipCount {
        self.skipped
    }

    /// The direction held off on `dof`, if any.
    pub fn blocked(&self, dof: usize) -> Option<Vector3<f64>> {
        self.blocked.get(dof).copied().flatten()
    }

    /// Holds `direction` off on `dof` (or nothing).
    pub fn block(&mut self, dof: usize, direction: Option<Vector3<f64>>) {
        if let Some(blocked) = self.blocked.get_mut(dof) {
            *blocked = direction;
        }
    }

    /// The velocity of degree of freedom `dof` (0 past the end).
    pub fn velocity(&self, dof: usize) -> f64 {
        self.input.current_velocity.get(dof).copied().unwrap_or(0.0)
    }

    /// The acceleration of degree of freedom `dof` (0 past the end).
    pub fn acceleration(&self, dof: usize) -> f64 {
        self.input
            .current_acceleration
            .get(dof)
            .copied()
            .unwrap_or(0.0)
    }

    /// Degree of freedom `dof` is at rest (to the last rounding).
    pub fn at_rest(&self, dof: usize) -> bool {
        self.velocity(dof).abs() < REST.0 && self.acceleration(dof).abs() < REST.1
    }

    /// Every degree of freedom at rest, asked for nothing, and untouched
    /// since the update that found it so: a tick asking nothing of it
    /// changes nothing.
    pub fn resting(&self) -> bool {
        self.resting
    }

    /// The target of the go-to still ahead on `dof` (position interface).
    pub fn remaining(&self, dof: usize) -> f64 {
        let at = |values: &[f64]| values.get(dof).copied().unwrap_or(0.0);
        at(&self.input.target_position) - at(&self.input.current_position)
    }

    /// Ruckig computed a new trajectory on its last update.
    pub fn recalculated(&self) -> bool {
        self.output.new_calculation
    }

    /// Asks for these velocities (zero acceleration there).
    pub fn ask_velocities(&mut self, velocities: [f64; N]) {
        set(&mut self.input.target_velocity, velocities);
        set(&mut self.input.target_acceleration, [0.0; N]);
    }

    /// Degree of freedom `dof` starts anew from rest (a new line or axis).
    pub fn restart_from_rest(&mut self, dof: usize) {
        self.resting = false;
        for values in [
            &mut self.input.current_velocity,
            &mut self.input.current_acceleration,
        ] {
            if let Some(value) = values.get_mut(dof) {
                *value = 0.0;
            }
        }
    }

    /// The velocity interface, each degree of freedom on its own.
    pub fn use_velocity_interface(&mut self) {
        self.resting = false;
        self.input.control_interface = ControlInterface::Velocity;
        self.input.synchronization = Synchronization::None;
    }

    /// From rest at position 0 to `targets`, every degree of freedom
    /// arriving at once (position interface, time-synchronized).
    pub fn go_to(&mut self, targets: [f64; N]) {
        self.resting = false;
        let input = &mut self.input;
        input.current_position.fill(0.0);
        input.current_velocity.fill(0.0);
        input.current_acceleration.fill(0.0);
        set(&mut input.target_position, targets);
        input.target_velocity.fill(0.0);
        input.target_acceleration.fill(0.0);
        input.control_interface = ControlInterface::Position;
        input.synchronization = Synchronization::Time;
    }

    /// The mechanism stopped on its own: at rest now, asked for nothing.
    pub fn halt(&mut self) {
        self.resting = false;
        self.input.current_velocity.fill(0.0);
        self.input.current_acceleration.fill(0.0);
        self.input.target_velocity.fill(0.0);
    }

    /// One cycle of Ruckig, its output fed back (settled exactly at the
    /// target once finished); skipped while [`Channel::resting`] and
    /// `asked_nothing`.
    // Ruckig's working state is some 10 KB of stack: out of line, a caller
    // that mostly skips this (the pointer's step) does not set it up.
    #[inline(never)]
    pub fn update(&mut self, asked_nothing: bool) -> Update {
        if self.resting && asked_nothing {
            self.skip();
            return Update::Skipped;
        }
        self.resting = false;
        let update = match self.otg.update(&self.input, &mut self.output) {
            Ok(RuckigResult::Working) => Update::Working,
            Ok(RuckigResult::Finished) => Update::Finished,
            _ => return Update::Failed,
        };
        self.output.pass_to_input(&mut self.input);
        if update == Update::Finished {
            self.settle();
            self.resting = !self.reference_path
                && self.input.control_interface == ControlInterface::Velocity
                && !self.output.new_calculation
                && self.is_still()
                && self.comes_out_still();
            #[cfg(debug_assertions)]
            if self.resting {
                self.rest_input.copy_from(&self.input);
            }
        }
        update
    }

    /// The update of a channel [`Channel::resting`] and asked for nothing,
    /// not run.
    pub fn skip(&mut self) {
        #[cfg(debug_assertions)]
        debug_assert!(
            self.resting && self.input == self.rest_input,
            "an update skipped at rest would have seen new inputs"
        );
        self.skipped.add();
    }

    /// One cycle of braking every degree of freedom on the time-optimal
    /// jerk-limited profile (the planner failed), asked for nothing.
    /// Whether it is at rest.
    pub fn brake_without_planner(
        &mut self,
        max_acceleration: [f64; N],
        max_jerk: [f64; N],
    ) -> bool {
        self.resting = false;
        let input = &mut self.input;
        for (((v, a), a_max), j_max) in input
            .current_velocity
            .iter_mut()
            .zip(input.current_acceleration.iter_mut())
            .zip(max_acceleration)
            .zip(max_jerk)
        {
            (*v, *a) = braking::brake_step(*v, *a, a_max, j_max, CYCLE_S);
        }
        input.target_velocity.fill(0.0);
        let zero = |values: &[f64]| values.iter().all(|x| *x == 0.0);
        zero(&input.current_velocity) && zero(&input.current_acceleration)
    }

    /// Limits Ruckig refuses: every update fails from now on.
    #[cfg(test)]
    pub fn break_planner(&mut self) {
        self.input.max_jerk.fill(f64::NAN);
    }

    /// A finished trajectory is at its target: the last ulps of rounding
    /// go, so that "stopped" means exactly zero velocity.
    fn settle(&mut self) {
        let input = &mut self.input;
        if let ControlInterface::Position = input.control_interface {
            copy(&mut input.current_position, &input.target_position);
        }
        copy(&mut input.current_velocity, &input.target_velocity);
        copy(&mut input.current_acceleration, &input.target_acceleration);
    }

    /// No velocity or acceleration, now or asked.
    fn is_still(&self) -> bool {
        let input = &self.input;
        [
            &input.current_velocity,
            &input.current_acceleration,
            &input.target_velocity,
            &input.target_acceleration,
        ]
        .iter()
        .all(|values| values.iter().all(|v| *v == 0.0))
    }

    /// Ruckig's own state after the update is still, as ours is (had
    /// settling zeroed a leftover velocity or acceleration, Ruckig would
    /// recalculate on the next update).
    fn comes_out_still(&self) -> bool {
        [&self.output.new_velocity, &self.output.new_acceleration]
            .iter()
            .all(|values| values.iter().all(|v| v.to_bits() == 0))
    }
}

/// Fills `slots` with `values` (as many as both have).
fn set<const N: usize>(slots: &mut [f64], values: [f64; N]) {
    for (slot, value) in slots.iter_mut().zip(values) {
        *slot = value;
    }
}

/// Copies `from` into `to` (as many as both have).
fn copy(to: &mut [f64], from: &[f64]) {
    for (t, f) in to.iter_mut().zip(from) {
        *t = *f;
    }
}
