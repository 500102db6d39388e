//! `sipnpuff replay`: a recording through the core and the simulated arm,
//! as fast as the machine allows: a CSV signal, or a session recorded by
//! `run --record`, compared with what was recorded.

use std::io::{BufWriter, Write};
use std::path::PathBuf;
use std::time::Instant;

use crate::cli::args::{ConfigArg, InterfaceArg, create, with_interface};
use crate::cli::output;
use crate::sensor::csv::CsvSignal;
use crate::tools::csv_replay;
use crate::tools::recording::read::Recording;
use crate::tools::recording::recording_replay::{self, ReplayVerdict};
use crate::tools::replay::{ReplayError, ReplaySummary};

/// `replay`'s options.
#[derive(clap::Args, Debug)]
pub struct ReplayArgs {
    /// CSV with a header row and a `volts` column, one row per 1 ms
    /// sample; or a directory written by `run --record`, replayed with its
    /// own configuration and compared with what was recorded.
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

/// Replays the recording; a summary goes to standard error. Returns the
/// exit status: for a recorded session, 1 if the replay differs from the
/// recording or the recording is incomplete.
pub fn replay(args: ReplayArgs) -> anyhow::Result<u8> {
    if args.signal.is_dir() {
        return replay_recording(&args);
    }
    let config = with_interface(args.config.load()?, args.interface)?;
    let signal = &args.signal;
    let mut input = CsvSignal::open(signal)?;
    let mut out: Box<dyn Write> = match &args.events {
        Some(path) => Box::new(create(path)?),
        None => Box::new(BufWriter::new(std::io::stdout().lock())),
    };
    let mut trace_file = args.trace.as_deref().map(create).transpose()?;
    let started = Instant::now();
    let result = csv_replay::replay(
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
    arm_note(&summary);
    Ok(output::COMPLETED)
}

/// The simulated arm's line of the summary.
fn arm_note(summary: &ReplaySummary) {
    let [x, y, z] = summary.final_position;
    let [rx, ry, rz] = summary.final_rotation_vector;
    note!(
        "simulated arm: {} commands at 100 Hz, final position ({x:.4}, {y:.4}, {z:.4}) m, rotation vector ({rx:.4}, {ry:.4}, {rz:.4}) rad, fingers {:.0}, ticks outside the workspace: {}",
        summary.arm_commands,
        summary.final_fingers,
        summary.ticks_outside_workspace
    );
}

/// `replay DIR`: a recorded session through a fresh core, compared with
/// the recording (unless `--config` or `--interface` asks for another
/// configuration: then it is only replayed).
fn replay_recording(args: &ReplayArgs) -> anyhow::Result<u8> {
    let recording = Recording::open(&args.signal)?;
    let other = match (&args.config.config, args.interface) {
        (None, None) => None,
        (Some(path), _) => Some(format!("--config {}", path.display())),
        (None, Some(_)) => Some("--interface".to_string()),
    };
    let config = match &args.config.config {
        Some(_) => with_interface(args.config.load()?, args.interface)?,
        None => with_interface(recording.config.clone(), args.interface)?,
    };
    let mut out: Box<dyn Write> = match &args.events {
        Some(path) => Box::new(create(path)?),
        None => Box::new(BufWriter::new(std::io::stdout().lock())),
    };
    let mut trace_file = args.trace.as_deref().map(create).transpose()?;
    let started = Instant::now();
    let result = recording_replay::replay(
        &recording,
        &config,
        other.is_none(),
        &mut out,
        trace_file.as_mut().map(|t| t as &mut dyn Write),
    );
    let seconds = started.elapsed().as_secs_f64();
    let dir = args.signal.display();
    let verdict = match result {
        Ok(verdict) => verdict,
        Err(ReplayError::Write(e)) => {
            return Err(anyhow::Error::new(e).context(format!("{dir}: cannot write the output")));
        }
        Err(e) => return Err(e.into()),
    };
    let meta = &recording.meta;
    let span = match (verdict.first_tick, verdict.last_tick) {
        (Some(first), Some(last)) => format!(
            "ticks {first}–{last}, {} skipped",
            last.saturating_sub(first)
                .saturating_add(1)
                .saturating_sub(verdict.ticks)
        ),
        _ => "no ticks".into(),
    };
    note!(
        "replayed recording {dir} ({}; started {}): {} ticks ({span}) in {seconds:.3} s, {} events, {} arm commands",
        meta.sensor,
        meta.start_time,
        verdict.ticks,
        verdict.summary.events,
        verdict.summary.arm_commands
    );
    arm_note(&verdict.summary);
    if meta.sipnpuff_version != env!("CARGO_PKG_VERSION") {
        note!(
            "note: recorded by sipnpuff {}, replayed by {}: a difference may come from a change in the core",
            meta.sipnpuff_version,
            env!("CARGO_PKG_VERSION")
        );
    }
    Ok(say_verdict(&verdict, other.as_deref()))
}

/// Says what the comparison found; the exit status.
fn say_verdict(v: &ReplayVerdict, other: Option<&str>) -> u8 {
    let stop = v.stop_tick.map_or_else(
        || "no safe stop recorded".to_string(),
        |t| format!("safe stop begun at tick {t}"),
    );
    if let Some(other) = other {
        note!("not compared: replayed with {other} instead of the recorded configuration");
        return output::COMPLETED;
    }
    if v.identical() {
        note!(
            "identical to the recording, bit for bit: {} events and {} arm commands ({stop})",
            v.summary.events,
            v.summary.arm_commands
        );
        return output::COMPLETED;
    }
    if v.complete {
        if let Some(d) = &v.difference {
            note!("DIFFERENT from the recording: first difference: {d}");
        }
        return output::FAILED;
    }
    let through = v.compared_through.map_or_else(
        || "nothing compared".to_string(),
        |t| format!("compared up to tick {t}"),
    );
    let so_far = match &v.difference {
        Some(d) => format!("first difference (perhaps where it lost items): {d}"),
        None => "identical so far".into(),
    };
    note!(
        "NOT VERIFIED: the recording is incomplete ({}); {through}: {so_far}",
        v.problems.join("; ")
    );
    output::FAILED
}
