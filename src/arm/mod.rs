//! The arm seam: where the core's 100 Hz Cartesian-velocity stream goes.
//!
//! A backend's life: **connect** ([`Arm::connect`]) → **commands**
//! ([`Arm::send`], one per 10 ms cycle, from the arm thread, never the
//! control thread) → **feedback** ([`Arm::feedback`]: the measured pose and
//! fingers, when the backend has them) → **stop** ([`end_stream`]: a zero
//! command, then [`Arm::stop`]). Every stop path ends the stream with a
//! zero command, so an arm that keeps executing its last command (a Gen3's
//! twist runs until `Stop()`) is told to stand still.
//!
//! Backends: [`sim`] (the simulated JACO).

pub mod sim;

use std::fmt;

use nalgebra::Isometry3;
use serde::{Serialize, Serializer};

use crate::control::motion::stream::ArmCommand;

/// Which arm to drive: the `--arm` values, a contract documented in
/// `--help` and `docs/commands.md`. A new backend adds its value here and
/// one line where the command line opens it (`cli/run.rs`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ArmSpec {
    /// The simulated JACO2.
    Sim,
}

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

/// Written as position (m), rotation vector (rad), fingers and command.
impl Serialize for ArmState {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        #[derive(Serialize)]
        struct Fields {
            position_m: [f64; 3],
            rotation_vector_rad: [f64; 3],
            fingers: f64,
            executing: ArmCommand,
        }
        Fields {
            position_m: self.pose.translation.vector.into(),
            rotation_vector_rad: self.pose.rotation.scaled_axis().into(),
            fingers: self.fingers,
            executing: self.executing,
        }
        .serialize(serializer)
    }
}

/// Why an arm refused or failed.
#[derive(Debug)]
#[non_exhaustive]
pub enum ArmError {
    /// The arm is not connected or not powered.
    Unavailable {
        /// Which arm and what to check.
        detail: String,
    },
    /// The arm refused a command.
    Rejected {
        /// Why.
        detail: String,
    },
    /// The connection failed while running.
    Disconnected {
        /// What happened.
        detail: String,
    },
}

impl fmt::Display for ArmError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ArmError::Unavailable { detail } => write!(f, "arm unavailable: {detail}"),
            ArmError::Rejected { detail } => write!(f, "arm refused a command: {detail}"),
            ArmError::Disconnected { detail } => write!(f, "arm disconnected: {detail}"),
        }
    }
}

impl std::error::Error for ArmError {}

/// An arm that takes the 100 Hz Cartesian velocity stream. Called from the
/// thread that owns the arm, never the control thread.
pub trait Arm: Send {
    /// What this arm is, for the report (e.g. `sim`).
    fn describe(&self) -> String;

    /// Connects (and, for a real arm, takes control). Called once, before
    /// the first command.
    fn connect(&mut self) -> Result<(), ArmError>;

    /// Sends one command, to be executed over the next 10 ms cycle.
    fn send(&mut self, command: &ArmCommand) -> Result<(), ArmError>;

    /// The latest measured state, if the backend measures one.
    fn feedback(&mut self) -> Option<ArmState>;

    /// Ends the stream and releases the arm. Call through [`end_stream`],
    /// which sends the zero command first.
    fn stop(&mut self) -> Result<(), ArmError>;
}

/// Ends a stream: a zero command numbered after `last` (so the arm stands
/// still whatever it was doing), then [`Arm::stop`]. Both are attempted;
/// the first error is returned.
pub fn end_stream(arm: &mut dyn Arm, last: Option<&ArmCommand>) -> Result<(), ArmError> {
    let zero = ArmCommand {
        seq: last.map_or(0, |c| c.seq + 1),
        tick: last.map_or(0, |c| c.tick + 10),
        ..ArmCommand::default()
    };
    let sent = arm.send(&zero);
    let stopped = arm.stop();
    sent.and(stopped)
}
