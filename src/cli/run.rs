//! `sipnpuff run`: the main job.

use std::io;
use std::path::PathBuf;

use anyhow::Context;

use crate::arm::sim::SimArm;
use crate::arm::{Arm, ArmSpec};
use crate::cli::args::{
    ConfigArg, InterfaceArg, RtArgs, parse_seconds, with_interface, writable_dir,
};
use crate::cli::output::{self, StdoutEvents, invalid};
#[cfg(test)]
use crate::config::Config;
use crate::rt::control_loop::StopReason;
use crate::rt::report::RunReport;
use crate::rt::signals;
use crate::rt::stop::StopRequest;
use crate::rt::threads::{RunError, RunOptions, run as run_loop, run_recorded};
use crate::sensor::csv::CsvSensor;
use crate::sensor::synthetic::SyntheticSensor;
use crate::sensor::{Sensor, SensorSpec};
use crate::tools::recording::recorder::{RecordError, Recorder};
use crate::tools::recording::writer::{MIN_BYTES, RecordOptions};

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
    rt: RtArgs,
}

/// Runs the loop with the chosen sensor and arm; prints events as they
/// happen, then the report. Returns the exit status ([`output`]): 0
/// completed, 1 failed, 128 + N stopped by signal N, 141 stdout's reader
/// went away. If stdout fails, the arm is stopped safely and the report
/// goes to stderr.
pub fn run(args: RunArgs) -> anyhow::Result<u8> {
    let config = with_interface(args.config.load()?, args.interface)?;
    if let Some(dir) = &args.histogram_dir {
        writable_dir(dir)?;
    }
    let mut recorder = match &args.record {
        None => None,
        Some(dir) => {
            let options = RecordOptions {
                max_bytes: args.record_max_mb,
                ..RecordOptions::default()
            };
            match Recorder::create(dir, &config, options) {
                Ok(recorder) => Some(recorder),
                // A directory that cannot be used: refused at start.
                Err(e @ (RecordError::Exists(_) | RecordError::Io { .. })) => {
                    return invalid(Err(anyhow::Error::new(e).context("--record")));
                }
                Err(e) => return Err(e.into()),
            }
        }
    };
    let options = RunOptions {
        seconds: args.seconds,
        rt: args.rt.options()?,
        spin_margin_ns: args.rt.spin_margin_ns(),
        stop: stop_request()?,
    };
    // The backends, one line each.
    let arm: Box<dyn Arm> = match args.arm {
        ArmSpec::Sim => Box::new(SimArm::new(config.core())),
    };
    let mut events = StdoutEvents::default();
    let rec = recorder.as_mut();
    let mut report = match &args.sensor {
        SensorSpec::Synthetic => start(
            &config,
            SyntheticSensor::built_in_user(&config),
            arm,
            &options,
            &mut events,
            rec,
        )?,
        SensorSpec::Csv(path) => start(
            &config,
            CsvSensor::open(path)?,
            arm,
            &options,
            &mut events,
            rec,
        )?,
    };
    // The recording ends before the report is printed: its summary is in
    // the report (and its `report.json`).
    let recording_failed = recorder
        .map(|recorder| recorder.finish(&mut report))
        .is_some_and(|summary| summary.error.is_some());
    let text = if args.json {
        serde_json::to_string(&report)? + "\n"
    } else {
        report.to_text()
    };
    // The report on stdout while it works; on stderr, saying why, if not.
    let mut stdout_failed = events.failed;
    let why = match (&report.output_error, stdout_failed) {
        (Some(error), _) if report.stop_reason == StopReason::OutputFailed => Some(format!(
            "stdout failed ({error}): stopped printing and stopped the arm safely"
        )),
        (Some(error), _) => Some(format!("stdout failed ({error}): stopped printing")),
        (None, Some(kind)) => Some(format!("stdout failed ({kind})")),
        (None, None) => match output::stdout(&text) {
            Ok(()) => None,
            Err(e) => {
                stdout_failed = Some(e.kind());
                Some(format!("stdout failed ({e}) while printing the report"))
            }
        },
    };
    if let Some(why) = why {
        note!("sipnpuff: {why}; the report follows on stderr");
        output::progress(format_args!("{text}"));
    }
    let mut histograms_failed = false;
    if let Some(dir) = &args.histogram_dir {
        match report.write_histograms(dir) {
            Ok(paths) => {
                for path in paths {
                    note!("wrote {}", path.display());
                }
            }
            Err(e) => {
                note!("error: --histogram-dir {}: {e}", dir.display());
                histograms_failed = true;
            }
        }
    }
    let status = exit_status(&report, stdout_failed);
    Ok(
        if (histograms_failed || recording_failed) && status == output::COMPLETED {
            output::FAILED
        } else {
            status
        },
    )
}

/// Runs the loop on `sensor`, recording if a recorder is given.
fn start<S: Sensor>(
    config: &crate::config::Config,
    sensor: S,
    arm: Box<dyn Arm>,
    options: &RunOptions,
    events: &mut StdoutEvents,
    recorder: Option<&mut Recorder>,
) -> Result<RunReport, RunError> {
    match recorder {
        Some(recorder) => run_recorded(config.core(), sensor, arm, options, events, recorder),
        None => run_loop(config.core(), sensor, arm, options, events),
    }
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

/// The exit status of a finished run whose stdout failed with
/// `stdout_failed`, if it did. A fault, or a safe stop that did not end
/// the stream with a zero command, is a failure whatever stopped the run;
/// otherwise the status says what stopped it: a signal (128 + N), the
/// reader of stdout gone (141), another failed output (1), or the run's
/// own end (0, or the output's status if the report could not be
/// printed).
pub fn exit_status(report: &RunReport, stdout_failed: Option<io::ErrorKind>) -> u8 {
    let output_status = |kind: Option<io::ErrorKind>| match kind {
        Some(io::ErrorKind::BrokenPipe) => output::BROKEN_PIPE,
        Some(_) => output::FAILED,
        None => output::COMPLETED,
    };
    if !report.errors.is_empty() || !report.stream_ended_with_zero {
        return output::FAILED;
    }
    match report.stop_reason {
        StopReason::Signal(n) => output::interrupted(n),
        StopReason::ArmFault | StopReason::Running => output::FAILED,
        StopReason::OutputFailed => match stdout_failed {
            None => output::FAILED,
            kind => output_status(kind),
        },
        StopReason::Time | StopReason::SensorEnded => output_status(stdout_failed),
    }
}

/// A stop request that every stop signal sets ([`signals`]): from here on
/// SIGINT, SIGTERM, SIGHUP, SIGQUIT and the others stop the run safely;
/// a repeated signal does not cut the safe stop short.
pub fn stop_request() -> anyhow::Result<StopRequest> {
    let stop = StopRequest::new();
    signals::install(&stop).context("cannot install the signal handlers")?;
    Ok(stop)
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::arm::sim::SimArm;
    use crate::rt::threads::RunOptions;

    /// A real report of a short run, to vary.
    fn report() -> RunReport {
        let config = Config::default();
        let options = RunOptions {
            seconds: Some(0.05),
            rt: crate::rt::setup::RtOptions::NONE,
            spin_margin_ns: None,
            stop: StopRequest::new(),
        };
        let sensor = SyntheticSensor::built_in_user(&config);
        let arm = Box::new(SimArm::new(config.core()));
        run_loop(config.core(), sensor, arm, &options, &mut |_: &_| {}).unwrap()
    }

    #[test]
    fn exit_statuses_say_what_stopped_the_run_and_faults_win() {
        let base = report();
        assert_eq!(base.stop_reason, StopReason::Time);
        let with = |reason: StopReason, errors: &[&str], zero: bool| RunReport {
            stop_reason: reason,
            errors: errors.iter().map(|e| e.to_string()).collect(),
            stream_ended_with_zero: zero,
            ..base.clone()
        };
        let pipe = Some(io::ErrorKind::BrokenPipe);
        let full = Some(io::ErrorKind::StorageFull);
        let table = [
            (with(StopReason::Time, &[], true), None, 0),
            (with(StopReason::SensorEnded, &[], true), None, 0),
            (
                with(StopReason::SensorEnded, &["sensor: bad row"], true),
                None,
                1,
            ),
            (with(StopReason::ArmFault, &["arm refused"], true), None, 1),
            (with(StopReason::Signal(libc::SIGHUP), &[], true), None, 129),
            (with(StopReason::Signal(libc::SIGINT), &[], true), full, 130),
            (
                with(StopReason::Signal(libc::SIGQUIT), &[], true),
                None,
                131,
            ),
            (
                with(StopReason::Signal(libc::SIGTERM), &[], true),
                None,
                143,
            ),
            (
                with(StopReason::Signal(libc::SIGTERM), &["arm"], true),
                None,
                1,
            ),
            (with(StopReason::Signal(libc::SIGTERM), &[], false), None, 1),
            (with(StopReason::OutputFailed, &[], true), pipe, 141),
            (with(StopReason::OutputFailed, &[], true), full, 1),
            (with(StopReason::Time, &[], true), pipe, 141),
            (with(StopReason::Time, &[], true), full, 1),
        ];
        for (report, failed, status) in table {
            assert_eq!(
                exit_status(&report, failed),
                status,
                "{} {:?} {:?}",
                report.stop_reason,
                report.errors,
                failed
            );
        }
    }
}
