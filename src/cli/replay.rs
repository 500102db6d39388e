//! `sipnpuff replay`: a recording through the core and the simulated arm,
//! as fast as the machine allows.

use std::io::{BufWriter, Write};
use std::path::PathBuf;
use std::time::Instant;

use crate::cli::args::{ConfigArg, InterfaceArg, create, with_interface};
use crate::sensor::csv::CsvSignal;
use crate::tools::replay::{ReplayError, replay as replay_signal};

/// `replay`'s options.
#[derive(clap::Args, Debug)]
pub struct ReplayArgs {
    /// CSV with a header row and a `volts` column, one row per 1 ms sample.
    signal: PathBuf,
    #[command(flatten)]
    config: ConfigArg,
    /// Write events here instead of standard output.
    #[arg(long)]
    events: Option<PathBuf>,
    /// Write a per-tick motion trace here (CSV: tick, mode, commanded
    /// twist in the base frame, simulated arm pose, fingers).
    #[arg(long)]
    trace: Option<PathBuf>,
    /// Selection interface (default: the config's `interface.kind`).
    #[arg(long, value_enum)]
    interface: Option<InterfaceArg>,
}

/// Replays the recording; a summary goes to standard error.
pub fn replay(args: ReplayArgs) -> anyhow::Result<()> {
    let config = with_interface(args.config.load()?, args.interface)?;
    let signal = &args.signal;
    let mut input = CsvSignal::open(signal)?;
    let mut out: Box<dyn Write> = match &args.events {
        Some(path) => Box::new(create(path)?),
        None => Box::new(BufWriter::new(std::io::stdout().lock())),
    };
    let mut trace_file = args.trace.as_deref().map(create).transpose()?;
    let started = Instant::now();
    let result = replay_signal(
        config.core(),
        &mut input,
        &mut out,
        trace_file.as_mut().map(|t| t as &mut dyn Write),
    );
    let seconds = started.elapsed().as_secs_f64();
    // A write error keeps its `io::Error` in the chain (a closed stdout:
    // exit status 141).
    let summary = match result {
        Ok(summary) => summary,
        Err(ReplayError::Write(e)) => {
            return Err(anyhow::Error::new(e)
                .context(format!("{}: cannot write the output", signal.display())));
        }
        Err(e) => return Err(anyhow::Error::new(e).context(signal.display().to_string())),
    };
    let signal_seconds = summary.samples as f64 / 1000.0;
    note!(
        "replayed {} samples ({signal_seconds:.1} s of signal) in {seconds:.3} s: {:.0}x real time, {} events",
        summary.samples,
        signal_seconds / seconds.max(1e-9),
        summary.events
    );
    let [x, y, z] = summary.final_position;
    let [rx, ry, rz] = summary.final_rotation_vector;
    note!(
        "simulated arm: {} commands at 100 Hz, final position ({x:.4}, {y:.4}, {z:.4}) m, rotation vector ({rx:.4}, {ry:.4}, {rz:.4}) rad, fingers {:.0}, ticks outside the workspace: {}",
        summary.arm_commands,
        summary.final_fingers,
        summary.ticks_outside_workspace
    );
    Ok(())
}
