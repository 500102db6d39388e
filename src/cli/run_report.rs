//! The end of `run`: its report printed (on stderr, saying why, when
//! stdout failed), the histograms written, and the exit status that says
//! what stopped the run.

use std::io;
use std::path::Path;

use crate::cli::output;
use crate::rt::control_loop::StopReason;
use crate::rt::report::RunReport;

/// Prints `report` (as one JSON object if `json`) after the events, whose
/// printing failed with `events_failed` if it did; writes its histograms
/// into `histogram_dir` if given. Returns the exit status: 0 completed, 1
/// failed (a histogram or the recording too), 128 + N stopped by signal
/// N, 141 stdout's reader went away.
pub fn conclude(
    report: &RunReport,
    events_failed: Option<io::ErrorKind>,
    json: bool,
    histogram_dir: Option<&Path>,
) -> anyhow::Result<u8> {
    let text = if json {
        serde_json::to_string(report)? + "\n"
    } else {
        report.to_text()
    };
    // The report on stdout while it works; on stderr, saying why, if not.
    let mut stdout_failed = events_failed;
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
    if let Some(dir) = histogram_dir {
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
    let recording_failed = report.recording.as_ref().is_some_and(|r| r.error.is_some());
    let status = exit_status(report, stdout_failed);
    Ok(
        if (histograms_failed || recording_failed) && status == output::COMPLETED {
            output::FAILED
        } else {
            status
        },
    )
}

/// The exit status of a finished run whose stdout failed with
/// `stdout_failed`, if it did. A fault, or a safe stop that did not end
/// the stream with a zero command, or a sensor fault (the arm stopped
/// mid-run) other than a disconnection the sensor came back from, is a
/// failure whatever stopped the run;
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
    if !report.errors.is_empty() || !report.stream_ended_with_zero || report.faults.failing() > 0 {
        return output::FAILED;
    }
    match report.stop_reason {
        StopReason::Signal(n) => output::interrupted(n),
        StopReason::ArmFault | StopReason::Running => output::FAILED,
        StopReason::OutputFailed => match stdout_failed {
            None => output::FAILED,
            kind => output_status(kind),
        },
        StopReason::Time | StopReason::SensorEnded | StopReason::Finished => {
            output_status(stdout_failed)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::arm::sim::SimArm;
    use crate::config::Config;
    use crate::rt::control_loop::SensorFaults;
    use crate::rt::threads::{self, LoopSettings, RunOptions};
    use crate::sim::synthetic_sensor::SyntheticSensor;

    /// A real report of a short run, to vary.
    fn report() -> RunReport {
        let config = Config::default();
        let settings = LoopSettings::plain(0.05);
        let sensor = SyntheticSensor::built_in_user(&config);
        let arm = Box::new(SimArm::new(config.core()));
        threads::run(config.core(), RunOptions::new(sensor, arm, settings)).unwrap()
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
        // Sensor faults fail the run, and the report counts them, naming
        // the hold limit and where it came from.
        let faulted = RunReport {
            faults: SensorFaults {
                held_too_long: 3,
                other: 1,
                ..SensorFaults::default()
            },
            max_hold: Some("1000 ms, set in anna.toml".into()),
            ..with(StopReason::SensorEnded, &[], true)
        };
        assert_eq!(exit_status(&faulted, None), 1);
        assert_eq!(
            faulted.faults_line().unwrap(),
            "FAULTS: 4 sensor faults, each stopped the arm; 3 were a breath held past detector.max_hold_ms (1000 ms, set in anna.toml): if the person meant them, raise max_hold_ms\n"
        );
        assert!(faulted.to_text().contains("\nFAULTS: 4 sensor faults"));
        assert_eq!(base.faults_line(), None);
        // A disconnection the sensor came back from (`reconnect = true`)
        // is reported but is what the setup asked for; one it did not
        // come back from fails the run.
        let reconnected = |back: u64| RunReport {
            faults: SensorFaults {
                disconnected: 2,
                reconnected: back,
                ..SensorFaults::default()
            },
            ..with(StopReason::Time, &[], true)
        };
        assert_eq!(exit_status(&reconnected(2), None), 0);
        assert_eq!(exit_status(&reconnected(1), None), 1);
        assert_eq!(
            reconnected(1).faults_line().unwrap(),
            "FAULTS: 2 sensor faults, each stopped the arm; 2 were the sensor disconnected, 1 of them reconnected (detection resumed)\n"
        );
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
