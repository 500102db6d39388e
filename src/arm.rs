//! The arm, at the runtime's edge: the backend trait real arms will
//! implement, and the simulated JACO (the default arm).
//!
//! A backend receives the core's 100 Hz [`ArmCommand`] stream. Like the
//! JACO2, the simulated arm executes each command for one 10 ms cycle and
//! stops when the stream stops.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use crate::config::Config;
use crate::motion::stream::{ARM_STREAM_PERIOD_TICKS, ArmCommand};
use crate::motion::workspace;

/// What an arm reports.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmState {
    /// Tool pose in the base frame.
    pub pose: Isometry3<f64>,
    /// Finger position, units (0 open).
    pub fingers: f64,
    /// The command being executed (zero when none).
    pub executing: ArmCommand,
}

/// Why an arm refused a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ArmError {
    /// The arm is not connected or not powered.
    Unavailable,
}

/// An arm that takes the 100 Hz Cartesian velocity stream. Called from the
/// thread that owns the arm, never the control thread.
pub trait ArmBackend {
    /// Queues one command for the next cycle.
    fn send(&mut self, command: &ArmCommand) -> Result<(), ArmError>;
    /// The arm's latest state.
    fn state(&self) -> ArmState;
    /// Ends the stream: the arm stops.
    fn stop(&mut self);
}

/// A simulated JACO2: integrates each command over its 10 ms cycle, in
/// 1 ms steps ([`SimulatedJaco::advance_ms`]); with no command for a cycle
/// it stands still. It never limits itself: the core keeps it inside the
/// workspace, and [`SimulatedJaco::inside_workspace`] lets tests check.
#[derive(Debug, Clone)]
pub struct SimulatedJaco {
    pose: Isometry3<f64>,
    fingers: f64,
    current: ArmCommand,
    /// Milliseconds the current command has left.
    remaining_ms: u32,
    workspace: crate::config::WorkspaceConfig,
}

impl SimulatedJaco {
    /// An arm at the configured home pose.
    pub fn new(config: &Config) -> Self {
        let arm = config.arm();
        SimulatedJaco {
            pose: home_pose(config),
            fingers: arm.home_fingers,
            current: ArmCommand::default(),
            remaining_ms: 0,
            workspace: *config.workspace(),
        }
    }

    /// Moves the simulation on by 1 ms.
    pub fn advance_ms(&mut self) {
        if self.remaining_ms == 0 {
            self.current = ArmCommand {
                seq: self.current.seq,
                tick: self.current.tick,
                ..ArmCommand::default()
            };
            return;
        }
        self.remaining_ms -= 1;
        let dt = 0.001;
        let c = &self.current;
        let v = Vector3::from(c.linear);
        let w = Vector3::from(c.angular);
        self.pose.translation.vector += v * dt;
        self.pose.rotation = UnitQuaternion::from_scaled_axis(w * dt) * self.pose.rotation;
        self.fingers += c.fingers * dt;
    }

    /// Whether the tool is inside the workspace and the fingers in range.
    pub fn inside_workspace(&self) -> bool {
        let w = &self.workspace;
        workspace::contains(&self.pose.translation.vector, w)
            && self.fingers >= 0.0
            && self.fingers <= w.finger_closed
    }
}

impl ArmBackend for SimulatedJaco {
    fn send(&mut self, command: &ArmCommand) -> Result<(), ArmError> {
        self.current = *command;
        self.remaining_ms = ARM_STREAM_PERIOD_TICKS;
        Ok(())
    }

    fn state(&self) -> ArmState {
        ArmState {
            pose: self.pose,
            fingers: self.fingers,
            executing: self.current,
        }
    }

    fn stop(&mut self) {
        self.remaining_ms = 0;
        self.current = ArmCommand::default();
    }
}

/// The configured power-up pose.
pub fn home_pose(config: &Config) -> Isometry3<f64> {
    let arm = config.arm();
    Isometry3::from_parts(
        Translation3::from(Vector3::from(arm.home_position_m)),
        UnitQuaternion::from_scaled_axis(Vector3::from(arm.home_rotation_vector_rad)),
    )
}
