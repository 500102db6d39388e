//! Replaying a CSV of samples (`replay FILE.csv`): the core runs over
//! them as fast as the machine allows, drives the simulated JACO with its
//! 100 Hz stream, and writes events as JSON Lines and, optionally, the
//! per-tick trace.

use std::io::{Read, Write};

use crate::arm::sim::SimulatedJaco;
use crate::control::core_config::CoreConfig;
use crate::control::event::TimedEvent;
use crate::control::pipeline::Pipeline;
use crate::control::tick::{TickInput, TickOutput};
use crate::sensor::csv::CsvSignal;
use crate::tools::replay::{ReplayError, ReplaySummary};
use crate::tools::trace::{TRACE_HEADER, TraceRows};

/// Replays every sample of `signal` through a fresh core and the simulated
/// arm, writing one JSON line per event to `out` and, if given, one trace
/// row per tick. Stops at the first malformed row, with its line.
pub fn replay<R: Read>(
    config: &CoreConfig,
    signal: &mut CsvSignal<R>,
    out: &mut dyn Write,
    mut trace: Option<&mut dyn Write>,
) -> Result<ReplaySummary, ReplayError> {
    let mut core: Pipeline = Pipeline::new(config);
    let mut arm = SimulatedJaco::new(config);
    let mut summary = ReplaySummary::default();
    if let Some(trace) = trace.as_deref_mut() {
        writeln!(trace, "{TRACE_HEADER}")?;
    }
    let mut output = TickOutput::default();
    let mut rows = TraceRows::default();
    while let Some(volts) = signal.next_sample()? {
        core.step(&TickInput::volts(summary.samples, volts), &mut output);
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
    summary.set_arm_end(&arm);
    Ok(summary)
}
