//! The simulated JACO2: the default arm, and the arm of `replay`, the
//! study and the tests.
//!
//! Like the JACO2 it executes each 100 Hz command for one 10 ms cycle and
//! stands still when the stream stops. It never limits itself: the core
//! keeps it inside the workspace, and [`SimulatedJaco::inside_workspace`]
//! lets the tests and `replay` check.

use nalgebra::{Isometry3, UnitQuaternion, Vector3};

use crate::arm::{Arm, ArmError, ArmState};
use crate::control::core_config::CoreConfig;
use crate::control::motion::rest::{all_zero, pose_bits, velocity_bits};
use crate::control::motion::stream::{ARM_STREAM_PERIOD_TICKS, ArmCommand};
use crate::control::motion::workspace::{self, WorkspaceConfig};
use crate::control::skip_count::SkipCount;

/// The simulation, stepped 1 ms at a time ([`SimulatedJaco::advance_ms`]).
#[derive(Debug, Clone)]
pub struct SimulatedJaco {
    pose: Isometry3<f64>,
    fingers: f64,
    current: ArmCommand,
    /// Milliseconds the current command has left.
    remaining_ms: u32,
    workspace: WorkspaceConfig,
    /// A millisecond at the current command's velocity (zero) left the
    /// pose exactly as it was, and neither has changed since: the next
    /// would too, so it is skipped.
    still: bool,
    /// Milliseconds skipped standing still.
    skipped_ms: SkipCount,
    /// Step every millisecond, standing still too: the reference path the
    /// skipped steps are proven against.
    reference_path: bool,
}

impl SimulatedJaco {
    /// An arm at the configured home pose.
    pub fn new(config: &CoreConfig) -> Self {
        SimulatedJaco {
            pose: config.home().pose(),
            fingers: config.home().home_fingers,
            current: ArmCommand::default(),
            remaining_ms: 0,
            workspace: *config.workspace(),
            still: false,
            skipped_ms: SkipCount::default(),
            reference_path: false,
        }
    }

    /// Steps every millisecond, standing still too.
    #[cfg(any(test, feature = "testing"))]
    pub fn use_reference_path(&mut self) {
        self.reference_path = true;
    }

    /// Takes a command for the next 10 ms cycle.
    pub fn command(&mut self, command: &ArmCommand) {
        // The same velocity, bit for bit, steps the same way.
        self.still &= velocity_bits(&velocity(command)) == velocity_bits(&velocity(&self.current));
        self.current = *command;
        self.remaining_ms = ARM_STREAM_PERIOD_TICKS;
    }

    /// One millisecond in step with the core: takes the tick's command, if
    /// the core produced one, then moves on by 1 ms.
    pub fn tick(&mut self, command: Option<&ArmCommand>) {
        if let Some(command) = command {
            self.command(command);
        }
        self.advance_ms();
    }

    /// Moves the simulation on by 1 ms.
    pub fn advance_ms(&mut self) {
        if self.remaining_ms == 0 {
            self.still = false;
            self.current = ArmCommand {
                seq: self.current.seq,
                tick: self.current.tick,
                ..ArmCommand::default()
            };
            return;
        }
        self.remaining_ms -= 1;
        if self.still {
            self.skipped_ms.add();
            return;
        }
        if self.reference_path || !all_zero(&velocity(&self.current)) {
            self.step_ms();
            return;
        }
        let before = pose_bits(&self.pose, self.fingers);
        self.step_ms();
        self.still = pose_bits(&self.pose, self.fingers) == before;
    }

    /// Milliseconds skipped standing still.
    #[cfg(any(test, feature = "testing"))]
    pub fn skipped_ms(&self) -> u64 {
        self.skipped_ms.get()
    }

    fn step_ms(&mut self) {
        let dt = 0.001;
        let c = &self.current;
        let v = Vector3::from(c.linear);
        let w = Vector3::from(c.angular);
        self.pose.translation.vector += v * dt;
        self.pose.rotation = UnitQuaternion::from_scaled_axis(w * dt) * self.pose.rotation;
        self.fingers += c.fingers * dt;
    }

    /// The stream ended: stand still.
    pub fn halt(&mut self) {
        self.still = false;
        self.remaining_ms = 0;
        self.current = ArmCommand::default();
    }

    /// Where the arm is and what it executes.
    pub fn state(&self) -> ArmState {
        ArmState {
            pose: self.pose,
            fingers: Some(self.fingers),
            executing: self.current,
        }
    }

    /// Puts the tool at `pose` (a recording's measured start).
    pub fn move_to(&mut self, pose: Isometry3<f64>) {
        self.still = false;
        self.pose = pose;
    }

    /// The finger position, JACO2 units.
    pub fn fingers(&self) -> f64 {
        self.fingers
    }

    /// Whether the tool is inside the workspace and the fingers in range.
    pub fn inside_workspace(&self) -> bool {
        let w = &self.workspace;
        workspace::contains(&self.pose.translation.vector, w)
            && self.fingers >= 0.0
            && self.fingers <= w.finger_closed
    }
}

/// A command's seven velocities (linear, angular, fingers).
fn velocity(command: &ArmCommand) -> [f64; 7] {
    let [vx, vy, vz] = command.linear;
    let [wx, wy, wz] = command.angular;
    [vx, vy, vz, wx, wy, wz, command.fingers]
}

/// The simulated JACO as the runtime's arm: each command is executed over
/// its whole 10 ms cycle as it arrives (simulated time needs no waiting).
#[derive(Debug, Clone)]
pub struct SimArm {
    jaco: SimulatedJaco,
}

impl SimArm {
    /// An arm at the configured home pose.
    pub fn new(config: &CoreConfig) -> SimArm {
        SimArm {
            jaco: SimulatedJaco::new(config),
        }
    }
}

impl Arm for SimArm {
    fn describe(&self) -> String {
        "sim (the simulated JACO2)".into()
    }

    fn connect(&mut self) -> Result<(), ArmError> {
        Ok(())
    }

    fn send(&mut self, command: &ArmCommand) -> Result<(), ArmError> {
        self.jaco.command(command);
        for _ in 0..ARM_STREAM_PERIOD_TICKS {
            self.jaco.advance_ms();
        }
        Ok(())
    }

    fn feedback(&mut self) -> Option<ArmState> {
        Some(self.jaco.state())
    }

    fn stop(&mut self) -> Result<(), ArmError> {
        self.jaco.halt();
        Ok(())
    }
}
