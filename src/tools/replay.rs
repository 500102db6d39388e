//! What both replays give back, of a CSV of samples
//! ([`csv_replay`](super::csv_replay)) and of a recording
//! ([`recording_replay`](super::recording::recording_replay)): what the
//! replay did, or why it stopped.

use std::fmt;
use std::io::Write;

use crate::arm::sim::SimulatedJaco;
use crate::control::Tick;
use crate::control::core_config::CoreConfig;
use crate::control::event::TimedEvent;
use crate::control::pipeline::Pipeline;
use crate::control::tick::{TickInput, TickOutput};
use crate::sensor::csv::CsvError;
use crate::tools::recording::read::RecordingError;
use crate::tools::trace::{TRACE_HEADER, TraceRows};

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

/// A replay under way: a fresh core and simulated arm, each tick's events
/// written as JSON lines and, if asked for, its trace row.
pub struct ReplayRun<'a, 'b> {
    core: Pipeline,
    arm: SimulatedJaco,
    output: TickOutput,
    rows: TraceRows,
    summary: ReplaySummary,
    out: &'a mut dyn Write,
    trace: Option<&'b mut dyn Write>,
}

impl<'a, 'b> ReplayRun<'a, 'b> {
    /// Starts a replay through `config` (the trace's header written).
    pub fn new(
        config: &CoreConfig,
        out: &'a mut dyn Write,
        mut trace: Option<&'b mut dyn Write>,
    ) -> Result<ReplayRun<'a, 'b>, ReplayError> {
        if let Some(trace) = trace.as_deref_mut() {
            writeln!(trace, "{TRACE_HEADER}")?;
        }
        Ok(ReplayRun {
            core: Pipeline::new(config),
            arm: SimulatedJaco::new(config),
            output: TickOutput::default(),
            rows: TraceRows::default(),
            summary: ReplaySummary::default(),
            out,
            trace,
        })
    }

    /// Ticks replayed so far (the next tick, counting from 0).
    pub fn ticks(&self) -> Tick {
        self.summary.samples
    }

    /// One tick through the core and the arm.
    pub fn step(&mut self, input: &TickInput) -> Result<(), ReplayError> {
        self.core.step(input, &mut self.output);
        let output = &self.output;
        for &event in output.events.iter() {
            let line = TimedEvent {
                tick: output.tick,
                event,
            };
            serde_json::to_writer(&mut *self.out, &line).map_err(std::io::Error::from)?;
            self.out.write_all(b"\n")?;
            self.summary.events += 1;
        }
        self.summary.arm_commands += u64::from(output.motion.arm_command.is_some());
        self.arm.tick(output.motion.arm_command.as_ref());
        if !self.arm.inside_workspace() {
            self.summary.ticks_outside_workspace += 1;
        }
        if let Some(trace) = self.trace.as_deref_mut() {
            self.rows.write(trace, output, &self.arm)?;
        }
        self.summary.samples += 1;
        Ok(())
    }

    /// Flushes the files; what the replay did.
    pub fn finish(mut self) -> Result<ReplaySummary, ReplayError> {
        self.out.flush()?;
        if let Some(trace) = self.trace {
            trace.flush()?;
        }
        self.summary.set_arm_end(&self.arm);
        Ok(self.summary)
    }
}
