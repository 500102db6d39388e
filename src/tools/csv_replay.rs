//! Replaying a CSV of samples (`replay FILE.csv`): the core runs over
//! them as fast as the machine allows, drives the simulated JACO with its
//! 100 Hz stream, and writes events as JSON Lines and, optionally, the
//! per-tick trace.

use std::io::{Read, Write};

use crate::control::core_config::CoreConfig;
use crate::control::tick::TickInput;
use crate::sensor::csv::CsvSignal;
use crate::tools::replay::{ReplayError, ReplayRun, ReplaySummary};

/// Replays every sample of `signal` through a fresh core and the simulated
/// arm, writing one JSON line per event to `out` and, if given, one trace
/// row per tick. Stops at the first malformed row, with its line.
pub fn replay<R: Read>(
    config: &CoreConfig,
    signal: &mut CsvSignal<R>,
    out: &mut dyn Write,
    trace: Option<&mut dyn Write>,
) -> Result<ReplaySummary, ReplayError> {
    let mut run = ReplayRun::new(config, out, trace)?;
    while let Some(volts) = signal.next_sample()? {
        run.step(&TickInput::volts(run.ticks(), volts))?;
    }
    run.finish()
}
