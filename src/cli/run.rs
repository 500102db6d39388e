//! `sipnpuff run`: the main job. The session itself is
//! [`crate::session::run`]'s; here its options, its report and its exit
//! status.

use std::path::PathBuf;

use crate::cli::args::{
    BackendArgs, ConfigArg, InterfaceArg, RtArgs, parse_seconds, record_dir, with_interface,
    writable_dir,
};
use crate::cli::display::DisplayArgs;
use crate::cli::output::{StdoutEvents, Terminal};
use crate::cli::run_report;
use crate::session::run::{self as session, Record, RunPlan};
use crate::tools::recording::writer::{MIN_BYTES, RecordOptions};

/// `run`'s options.
#[derive(clap::Args, Debug)]
pub struct RunArgs {
    #[command(flatten)]
    config: ConfigArg,
    /// Run this long, s (default: until the sensor ends: the scripted user
    /// or the recording runs out, or a device is lost for good).
    #[arg(long, value_parser = parse_seconds)]
    seconds: Option<f64>,
    #[command(flatten)]
    backends: BackendArgs,
    /// Selection interface (default: the config's `interface.kind`).
    #[arg(long, value_enum)]
    interface: Option<InterfaceArg>,
    /// Write each histogram in HdrHistogram's `.hgrm` text format here.
    #[arg(long, value_name = "DIR")]
    histogram_dir: Option<PathBuf>,
    /// Print the final report as one JSON object (after the event lines).
    #[arg(long)]
    json: bool,
    /// Record the session into this directory (created if needed; never
    /// over an existing recording): what the control loop saw, the
    /// configuration, the events, the arm commands and the report, for
    /// `sipnpuff replay DIR`.
    #[arg(long, value_name = "DIR")]
    record: Option<PathBuf>,
    /// Cap on the recording's samples, commands and events, MB (10^6
    /// bytes); past it recording stops and the run goes on.
    #[arg(long, value_name = "MB", default_value = "200", requires = "record", value_parser = parse_megabytes)]
    record_max_mb: u64,
    #[command(flatten)]
    display: DisplayArgs,
    #[command(flatten)]
    rt: RtArgs,
}

/// Runs the loop with the chosen sensor and arm; prints events as they
/// happen, then the report. Returns the exit status
/// ([`run_report::exit_status`]). If stdout fails, the arm is stopped
/// safely and the report goes to stderr.
pub fn run(args: RunArgs) -> anyhow::Result<u8> {
    let setup = args.config.layered()?;
    let max_hold_origin = setup.source("detector.max_hold_ms").map(|l| l.path.clone());
    let config = with_interface(setup.into_config(), args.interface)?;
    if let Some(dir) = &args.histogram_dir {
        writable_dir(dir)?;
    }
    // The directory is checked now; the recording starts with the
    // configuration the core gets (a device's measured neutral in it).
    if let Some(dir) = &args.record {
        record_dir(dir)?;
    }
    let settings = args.rt.loop_settings(args.seconds, config.rt())?;
    let plan = RunPlan {
        sensor: &args.backends.sensor,
        imu: args.backends.imu.as_ref(),
        arm: &args.backends.arm,
        outputs: &args.backends.outputs,
        settings: &settings,
        record: args.record.as_deref().map(|dir| Record {
            dir,
            options: RecordOptions {
                max_bytes: args.record_max_mb,
                ..RecordOptions::default()
            },
        }),
        display: args.display.choice(),
        max_hold_set_in: max_hold_origin.as_deref(),
    };
    let mut events = StdoutEvents {
        quiet: args.display.tui,
        ..StdoutEvents::default()
    };
    let report = session::run(&config, &plan, &mut events, &Terminal)?;
    run_report::conclude(
        &report,
        events.failed,
        args.json,
        args.histogram_dir.as_deref(),
    )
}

/// `--record-max-mb`: a positive number of megabytes (10^6 bytes), at
/// least 0.001 (the streams' headers and ends), as bytes.
fn parse_megabytes(text: &str) -> Result<u64, String> {
    let mb: f64 = text
        .parse()
        .map_err(|_| format!("{text:?} is not a number of megabytes"))?;
    let bytes = mb * 1e6;
    if bytes.is_finite() && bytes >= MIN_BYTES as f64 && bytes <= u64::MAX as f64 {
        Ok(bytes.round() as u64)
    } else {
        Err(format!(
            "{text} MB: must be at least {} MB",
            MIN_BYTES as f64 / 1e6
        ))
    }
}
