//! `sipnpuff run`: the main job.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use crate::arm::sim::SimArm;
use crate::arm::{Arm, ArmSpec};
use crate::cli::args::{
    ConfigArg, InterfaceArg, RtArgs, parse_seconds, with_interface, writable_dir,
};
use crate::config::Config;
use crate::control::event::TimedEvent;
use crate::rt::report::RunReport;
use crate::rt::threads::{RunOptions, run as run_loop};
use crate::sensor::csv::CsvSensor;
use crate::sensor::synthetic::SyntheticSensor;
use crate::sensor::{Sensor, SensorSpec};

/// `run`'s options.
#[derive(clap::Args, Debug)]
pub struct RunArgs {
    #[command(flatten)]
    config: ConfigArg,
    /// Run this long, s (default: until the scripted user or recording ends).
    #[arg(long, value_parser = parse_seconds)]
    seconds: Option<f64>,
    /// Where samples come from: `synthetic` (the built-in scripted user)
    /// or `csv:PATH` (a recording played in real time).
    #[arg(long, default_value = "synthetic", value_parser = SensorSpec::parse)]
    sensor: SensorSpec,
    /// The arm.
    #[arg(long, value_enum, default_value = "sim")]
    arm: ArmSpec,
    /// Selection interface (default: the config's `interface.kind`).
    #[arg(long, value_enum)]
    interface: Option<InterfaceArg>,
    /// Write each histogram in HdrHistogram's `.hgrm` text format here.
    #[arg(long)]
    histogram_dir: Option<PathBuf>,
    /// Print the final report as one JSON object (after the event lines).
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    rt: RtArgs,
}

/// Runs the loop with the chosen sensor and arm; prints events as they
/// happen, then the report. Fails if the sensor or arm failed on the way.
pub fn run(args: RunArgs) -> anyhow::Result<ExitCode> {
    let config = with_interface(args.config.load()?, args.interface)?;
    if let Some(dir) = &args.histogram_dir {
        writable_dir(dir)?;
    }
    let options = RunOptions {
        seconds: args.seconds,
        rt: args.rt.options()?,
        spin_margin_ns: args.rt.spin_margin_ns(),
        stop: stop_flag()?,
    };
    // The backends, one line each.
    let arm: Box<dyn Arm> = match args.arm {
        ArmSpec::Sim => Box::new(SimArm::new(config.core())),
    };
    let report = match &args.sensor {
        SensorSpec::Synthetic => run_on(
            &config,
            SyntheticSensor::built_in_user(&config),
            arm,
            &options,
        )?,
        SensorSpec::Csv(path) => run_on(&config, CsvSensor::open(path)?, arm, &options)?,
    };
    if args.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        print!("{}", report.to_text());
    }
    if let Some(dir) = &args.histogram_dir {
        for path in report.write_histograms(dir)? {
            eprintln!("wrote {}", path.display());
        }
    }
    Ok(if report.errors.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// The loop on one sensor, printing each event as a JSON line.
fn run_on(
    config: &Config,
    sensor: impl Sensor,
    arm: Box<dyn Arm>,
    options: &RunOptions,
) -> anyhow::Result<RunReport> {
    let print = |event: &TimedEvent| match serde_json::to_string(event) {
        Ok(line) => println!("{line}"),
        Err(e) => eprintln!("cannot write an event: {e}"),
    };
    Ok(run_loop(config.core(), sensor, arm, options, print)?)
}

/// SIGINT and SIGTERM request a safe stop; a second one exits at once.
pub fn stop_flag() -> anyhow::Result<Arc<AtomicBool>> {
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register_conditional_shutdown(signal, 130, stop.clone())?;
        signal_hook::flag::register(signal, stop.clone())?;
    }
    Ok(stop)
}
