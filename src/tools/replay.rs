//! `replay`: runs the core over a recording as fast as the machine allows,
//! drives the simulated JACO with the core's 100 Hz stream, writes events
//! as JSON Lines and, optionally, a per-tick motion trace as CSV.

use std::io::{Read, Write};

use crate::arm::sim::SimulatedJaco;
use crate::control::core_config::CoreConfig;
use crate::control::event::TimedEvent;
use crate::control::motion::still::{PoseBits, VelocityBits, pose_bits, velocity_bits};
use crate::control::pipeline::{Pipeline, TickOutput};
use crate::control::sample::Sample;
use crate::sensor::csv::{CsvError, CsvSignal};
use crate::tools::float_text::push_f64;

/// Why a replay stopped early.
#[derive(Debug)]
pub enum ReplayError {
    /// A row of the recording is not a sample (its line is named).
    Recording(CsvError),
    /// The events or the trace could not be written.
    Write(std::io::Error),
}

impl std::fmt::Display for ReplayError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ReplayError::Recording(e) => write!(f, "{e}"),
            ReplayError::Write(e) => write!(f, "cannot write the output: {e}"),
        }
    }
}

impl std::error::Error for ReplayError {}

impl From<CsvError> for ReplayError {
    fn from(e: CsvError) -> Self {
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

/// Header of the `--trace` CSV.
pub const TRACE_HEADER: &str = "tick,mode,vx,vy,vz,wx,wy,wz,fingers_vel,x,y,z,rx,ry,rz,fingers";

/// Writes trace rows: the core's 1 kHz commanded twist (base frame) and
/// the simulated arm's pose, one row a tick (also for recordings,
/// `tools::recording`). The numbers are written as `format!("{}")`
/// writes them ([`push_f64`]). One line is reused from row to row, and
/// the twist's and the pose's columns are laid out again only when they
/// changed: at rest, and at a steady speed, they are the previous row's,
/// the same bits giving the same text.
#[derive(Debug, Default)]
pub struct TraceRows {
    line: Vec<u8>,
    /// The last twist laid out (its bits), and its text.
    twist: Option<VelocityBits>,
    twist_text: Vec<u8>,
    /// The last pose laid out (its bits and fingers), and its text.
    pose: Option<PoseBits>,
    pose_text: Vec<u8>,
}

impl TraceRows {
    /// Writes the row of the tick `output` belongs to, `arm` having taken
    /// its command.
    pub fn write(
        &mut self,
        out: &mut dyn Write,
        output: &TickOutput,
        arm: &SimulatedJaco,
    ) -> std::io::Result<()> {
        let line = &mut self.line;
        line.clear();
        line.extend_from_slice(itoa::Buffer::new().format(output.tick).as_bytes());
        line.push(b',');
        line.extend_from_slice(output.command.state.name().as_bytes());
        let twist = output.motion.velocity();
        let bits = velocity_bits(&twist);
        if self.twist != Some(bits) {
            self.twist = Some(bits);
            let text = &mut self.twist_text;
            text.clear();
            for value in twist {
                text.push(b',');
                push_f64(text, value);
            }
        }
        line.extend_from_slice(&self.twist_text);
        let pose = arm.state().pose;
        let bits = pose_bits(&pose, arm.fingers());
        if self.pose != Some(bits) {
            self.pose = Some(bits);
            let text = &mut self.pose_text;
            text.clear();
            let r = pose.rotation.scaled_axis();
            let values = pose.translation.vector.iter().chain(r.iter());
            for &value in values.chain(std::iter::once(&arm.fingers())) {
                text.push(b',');
                push_f64(text, value);
            }
        }
        line.extend_from_slice(&self.pose_text);
        line.push(b'\n');
        out.write_all(line)
    }
}

/// Replays every sample of `signal` through a fresh core and the simulated
/// arm, writing one JSON line per event to `out` and, if given, one trace
/// row per tick. Stops at the first malformed row, with its line.
pub fn replay<R: Read>(
    config: &CoreConfig,
    signal: &mut CsvSignal<R>,
    out: &mut dyn Write,
    mut trace: Option<&mut dyn Write>,
) -> Result<ReplaySummary, ReplayError> {
    let mut core = Pipeline::new(config);
    let mut arm = SimulatedJaco::new(config);
    let mut summary = ReplaySummary::default();
    if let Some(trace) = trace.as_deref_mut() {
        writeln!(trace, "{TRACE_HEADER}")?;
    }
    let mut output = TickOutput::default();
    let mut rows = TraceRows::default();
    while let Some(volts) = signal.next_sample()? {
        core.step(summary.samples, Sample::Volts(volts), &mut output);
        let output = &output;
        for &event in output.events.iter() {
            let line = TimedEvent {
                tick: output.tick,
                event,
            };
            serde_json::to_writer(&mut *out, &line).map_err(std::io::Error::from)?;
            out.write_all(b"\n")?;
            summary.events += 1;
        }
        summary.arm_commands += u64::from(output.motion.arm_command.is_some());
        arm.tick(output.motion.arm_command.as_ref());
        if !arm.inside_workspace() {
            summary.ticks_outside_workspace += 1;
        }
        if let Some(trace) = trace.as_deref_mut() {
            rows.write(trace, output, &arm)?;
        }
        summary.samples += 1;
    }
    out.flush()?;
    if let Some(trace) = trace {
        trace.flush()?;
    }
    let state = arm.state();
    summary.final_position = state.pose.translation.vector.into();
    summary.final_rotation_vector = state.pose.rotation.scaled_axis().into();
    summary.final_fingers = arm.fingers();
    Ok(summary)
}
