//! `sipnpuff replay`: a recording through the core and the simulated arm,
//! as fast as the machine allows: a CSV signal, or a session recorded by
//! `run --record`, compared with what was recorded
//! ([`crate::tools::replay_files`]).

use std::path::PathBuf;

use crate::cli::args::{ConfigArg, InterfaceArg, with_interface};
use crate::cli::output;
use crate::config::Config;
use crate::session::gestures;
use crate::tools::imu_csv::is_imu_csv;
use crate::tools::recording::recording_replay::ReplayVerdict;
use crate::tools::replay::ReplaySummary;
use crate::tools::replay_files::{self, ReplayTo};

/// `replay`'s options.
#[derive(clap::Args, Debug)]
pub struct ReplayArgs {
    /// CSV with a header row and a `volts` column, one row per 1 ms
    /// sample; an IMU recording (header `tick,ax,ay,az,gx,gy,gz`), read
    /// with the gesture set the configuration names; or a directory
    /// written by `run --record`, replayed with its own configuration and
    /// compared with what was recorded.
    signal: PathBuf,
    #[command(flatten)]
    config: ConfigArg,
    /// With an IMU recording: the person's gesture set (made by `gestures
    /// record`), in place of the configuration's `[gestures] set`. Each
    /// recognised gesture is a `gesture` event line; the library's
    /// entries that name gestures select as they would live.
    #[arg(long, value_name = "SET.toml")]
    gestures: Option<PathBuf>,
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
    let mut config = with_interface(args.config.load()?, args.interface)?;
    if let Some(set) = &args.gestures {
        if !is_imu_csv(&args.signal) {
            return output::invalid(Err(anyhow::anyhow!(
                "--gestures is for an IMU recording (header `tick,ax,…`); {} is not one",
                args.signal.display()
            )));
        }
        config = output::invalid(
            config
                .with_gesture_set(set.clone())
                .map_err(anyhow::Error::from),
        )?;
    }
    let replayed = if is_imu_csv(&args.signal) {
        let core = gestures::imu_core(&config)?;
        replay_files::replay_imu_csv(&core, &args.signal, to(&args), std::io::stdout().lock())?
    } else {
        replay_files::replay_csv(
            config.core(),
            &args.signal,
            to(&args),
            std::io::stdout().lock(),
        )?
    };
    let summary = &replayed.summary;
    let signal_seconds = summary.samples as f64 / 1000.0;
    note!(
        "replayed {} samples ({signal_seconds:.1} s of signal) in {:.3} s: {:.0}x real time, {} events",
        summary.samples,
        replayed.seconds,
        signal_seconds / replayed.seconds.max(1e-9),
        summary.events
    );
    arm_note(summary);
    Ok(output::COMPLETED)
}

/// Where `--events` and `--trace` say to write.
fn to(args: &ReplayArgs) -> ReplayTo<'_> {
    ReplayTo {
        events: args.events.as_deref(),
        trace: args.trace.as_deref(),
    }
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
    let other = match (args.config.given(), args.interface) {
        (false, None) => None,
        (true, _) => {
            let files: Vec<String> = (args.config.config.iter())
                .map(|path| format!("--config {}", path.display()))
                .collect();
            Some(files.join(" "))
        }
        (false, Some(_)) => Some("--interface".to_string()),
    };
    let config = |recorded: &Config| {
        if args.config.given() {
            with_interface(args.config.load()?, args.interface)
        } else {
            with_interface(recorded.clone(), args.interface)
        }
    };
    let replayed = replay_files::replay_recording(
        &args.signal,
        config,
        other.is_none(),
        to(args),
        std::io::stdout().lock(),
    )?;
    let (verdict, seconds) = (&replayed.verdict, replayed.seconds);
    let dir = args.signal.display();
    let meta = &replayed.recording.meta;
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
    Ok(say_verdict(verdict, other.as_deref()))
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
