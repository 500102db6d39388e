//! What both replays give back, of a CSV of samples
//! ([`csv_replay`](super::csv_replay)) and of a recording
//! ([`recording_replay`](super::recording::recording_replay)): what the
//! replay did, or why it stopped.

use std::fmt;

use crate::arm::sim::SimulatedJaco;
use crate::sensor::csv::CsvError;
use crate::tools::recording::read::RecordingError;

/// Why a replay stopped early.
#[derive(Debug)]
pub enum ReplayError {
    /// A row of the CSV is not a sample (its line is named).
    Csv(CsvError),
    /// The recording is damaged (its file and offset or line named).
    Recording(RecordingError),
    /// The events or the trace could not be written.
    Write(std::io::Error),
}

impl fmt::Display for ReplayError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ReplayError::Csv(e) => write!(f, "{e}"),
            ReplayError::Recording(e) => write!(f, "{e}"),
            ReplayError::Write(e) => write!(f, "cannot write the output: {e}"),
        }
    }
}

impl std::error::Error for ReplayError {}

impl From<CsvError> for ReplayError {
    fn from(e: CsvError) -> Self {
        ReplayError::Csv(e)
    }
}

impl From<RecordingError> for ReplayError {
    fn from(e: RecordingError) -> Self {
        ReplayError::Recording(e)
    }
}

impl From<std::io::Error> for ReplayError {
    fn from(e: std::io::Error) -> Self {
        ReplayError::Write(e)
    }
}

/// What a replay did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ReplaySummary {
    /// Samples (ticks) processed.
    pub samples: u64,
    /// Events written.
    pub events: u64,
    /// Commands sent to the arm (100 Hz).
    pub arm_commands: u64,
    /// Ticks on which the simulated arm was outside its workspace.
    pub ticks_outside_workspace: u64,
    /// The simulated arm's final position, m.
    pub final_position: [f64; 3],
    /// Its final orientation as a rotation vector, rad.
    pub final_rotation_vector: [f64; 3],
    /// Its final finger position, units.
    pub final_fingers: f64,
}

impl ReplaySummary {
    /// Takes the simulated arm's final pose and fingers.
    pub fn set_arm_end(&mut self, arm: &SimulatedJaco) {
        let pose = arm.state().pose;
        self.final_position = pose.translation.vector.into();
        self.final_rotation_vector = pose.rotation.scaled_axis().into();
        self.final_fingers = arm.fingers();
    }
}
