//! The live calibration: the real sensor path (any `--sensor`, re-zeroed
//! as `run` does) and the simulated arm (a fit never drives a real arm),
//! the person guided prompt by prompt on the page and in the terminal
//! ([`Guide`] on the telemetry side), the session recorded as `run
//! --record` records, with the protocol beside it ([`CALIBRATION`]).
//! Once it is over, the recording is fitted exactly as a recorded
//! session would be ([`fitting`](super::fitting)).

use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::Context;

use crate::arm::Arm;
use crate::arm::sim::SimArm;
use crate::config::Config;
use crate::fit::outcome::Outcome;
use crate::fit::prompter::Prompter;
use crate::fit::protocol::Protocol;
use crate::rt::control_loop::StopReason;
use crate::rt::recorder::SessionRecorder;
use crate::rt::report::RunReport;
use crate::rt::stop::SignalName;
use crate::rt::telemetry_thread::Watchers;
use crate::rt::threads::{self, LoopSettings, RunOptions};
use crate::sensor::{Sensor, SensorSpec};
use crate::session::Console;
use crate::session::fitting::{CALIBRATION, FitEnd, FitRequest, SessionKind, conclude, today};
use crate::session::guide::Guide;
use crate::session::showing::{Display, DisplayChoice, Showing};
use crate::sim::synthetic_sensor::SyntheticSensor;
use crate::tools::recording::recorder::Recorder;
use crate::tools::recording::writer::RecordOptions;
use crate::tools::signal_file::recorded_signal;
use crate::wiring::sensor::{OnSensor, open_sensor};

/// How long the page's summary may take to reach the open pages before
/// the session ends.
const SUMMARY_WAIT: Duration = Duration::from_secs(3);

/// A live session's own settings, beside what the fit is asked for.
pub struct Live<'a> {
    /// Where samples come from (`synthetic`: the built-in user, who
    /// breathes the protocol in time with the prompts).
    pub sensor: &'a SensorSpec,
    /// The session's recording (a directory checked before).
    pub dir: &'a Path,
    /// Where the profile goes (its directory checked before).
    pub out: &'a Path,
    /// How the loop runs and what stops it.
    pub settings: &'a LoopSettings,
    /// The page (the terminal view is not offered).
    pub display: DisplayChoice,
}

/// A live session: guided, recorded, then fitted from its recording.
pub fn calibrate(
    request: &FitRequest,
    live: &Live,
    console: &dyn Console,
) -> anyhow::Result<FitEnd> {
    let protocol = &request.protocol();
    let current = request.current;
    let dir = live.dir;
    let display = Display::open(&live.display, console)?;
    console.note(&format!(
        "sipnpuff: fitting \"{}\": {}; the session is recorded in {}",
        request.label,
        protocol.describe(),
        dir.display()
    ));
    let session = Session {
        protocol,
        settings: live.settings,
        display: &display,
        dir,
        console,
        to_stderr: request.json,
    };
    let ran = open_sensor(
        live.sensor,
        current,
        |config, name| match name {
            None => Ok((
                config.clone(),
                SyntheticSensor::calibration_user(config, protocol, None),
            )),
            Some(name) => {
                let (config, breather) =
                    SyntheticSensor::breather_named(config, name).map_err(anyhow::Error::msg)?;
                let user = SyntheticSensor::calibration_user(&config, protocol, Some(&breather));
                Ok((config, user))
            }
        },
        session,
        &|line| console.note(line),
    )?;
    let Ran {
        report,
        prompter,
        mut showing,
    } = ran;
    let kept = dir.display().to_string();
    console.note(&format!(
        "sipnpuff: {} ticks, {} heap allocations on the control thread",
        report.stats.ticks_run, report.control_thread_allocations
    ));
    if let Some((end, why)) = unfinished(&report, &prompter) {
        console.note(&format!("sipnpuff: {why}"));
        console.note(&format!(
            "sipnpuff: no profile written; the session so far is kept in {kept}"
        ));
        let outcome = Outcome {
            problem: Some(why),
            recording: Some(kept),
            ..Outcome::default()
        };
        showing.conclude(&outcome, SUMMARY_WAIT);
        return Ok(end);
    }
    let (end, mut outcome) = match recorded_signal(dir) {
        Ok(signal) => {
            let source = format!("a guided session recorded in {kept}");
            let fitted = crate::fit::fit(&signal, protocol, current);
            conclude(
                request,
                fitted,
                SessionKind::Calibration,
                &source,
                Some(live.out),
                console,
            )?
        }
        Err(e) => {
            console.note(&format!("error: {e}"));
            let outcome = Outcome {
                problem: Some(e.to_string()),
                ..Outcome::default()
            };
            (FitEnd::Failed, outcome)
        }
    };
    console.note(&format!(
        "sipnpuff: the session is recorded in {kept}; `sipnpuff fit --from {kept} --count {}{}` fits it again",
        request.count,
        if request.holds { " --holds" } else { "" }
    ));
    outcome.recording = Some(kept);
    showing.conclude(&outcome, SUMMARY_WAIT);
    Ok(end)
}

/// Why a live session ended without every block breathed, and how it
/// ended; `None` if it was all breathed and recorded.
fn unfinished(report: &RunReport, prompter: &Prompter) -> Option<(FitEnd, String)> {
    if let Some(stop) = prompter.stopped() {
        return Some((FitEnd::Failed, stop.words()));
    }
    let errors = if report.errors.is_empty() {
        String::new()
    } else {
        format!(" ({})", report.errors.join("; "))
    };
    if !prompter.is_finished() {
        let why = match report.stop_reason {
            StopReason::Signal(n) => {
                return Some((
                    FitEnd::Interrupted(n),
                    format!("interrupted ({}) before the session's end", SignalName(n)),
                ));
            }
            StopReason::SensorEnded => {
                format!("the sensor ended before the session's end{errors}")
            }
            reason => format!("the run stopped ({reason}) before the session's end{errors}"),
        };
        return Some((FitEnd::Failed, why));
    }
    let recording = report.recording.as_ref()?;
    recording
        .error
        .as_ref()
        .map(|e| (FitEnd::Failed, format!("the recording failed: {e}")))
}

/// `fit-LABEL-DATE` in the current directory, or with `-2`, `-3`… the
/// first that does not exist yet: a live session's directory when none
/// is given.
pub fn default_dir(label: &str) -> PathBuf {
    let label: String = label
        .chars()
        .map(|c| {
            if c.is_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '-'
            }
        })
        .collect();
    let base = format!("fit-{label}-{}", today());
    (1..)
        .map(|n| {
            PathBuf::from(if n == 1 {
                base.clone()
            } else {
                format!("{base}-{n}")
            })
        })
        .find(|dir| !dir.exists())
        .unwrap_or_else(|| PathBuf::from(base.clone()))
}

/// A live session on the sensor opened.
struct Session<'a> {
    protocol: &'a Protocol,
    settings: &'a LoopSettings,
    display: &'a Display<'a>,
    dir: &'a Path,
    console: &'a dyn Console,
    /// The prompts go to stderr (stdout holds the JSON).
    to_stderr: bool,
}

/// What a live session leaves: the run's report (its recording
/// finished), the guide as the session left it, and the page, still up
/// for the summary.
struct Ran {
    report: RunReport,
    prompter: Prompter,
    showing: Showing,
}

impl OnSensor for Session<'_> {
    type Output = Ran;

    fn on<S: Sensor>(self, config: &Config, sensor: S) -> anyhow::Result<Ran> {
        let mut recorder = Recorder::create(self.dir, config, RecordOptions::default())
            .map_err(|e| anyhow::Error::new(e).context("--record"))?;
        // The recording says it is a calibration, and which protocol.
        let marker = self.dir.join(CALIBRATION);
        let protocol = serde_json::to_string_pretty(self.protocol)? + "\n";
        std::fs::write(&marker, protocol)
            .with_context(|| format!("cannot write {}", marker.display()))?;
        // A fit never drives a real arm: the core's output goes to the
        // simulated one.
        let arm: Box<dyn Arm> = Box::new(SimArm::new(config.core()));
        let mut showing = self.display.start_fit(config.core(), &arm.describe())?;
        let mut guide = Guide::new(
            Prompter::new(self.protocol),
            &mut showing,
            self.settings.stop.clone(),
            self.console,
            self.to_stderr,
        );
        let options = RunOptions {
            watchers: Watchers {
                events: None,
                recorder: Some(&mut recorder as &mut dyn SessionRecorder),
                observer: Some(&mut guide),
            },
            ..RunOptions::new(sensor, arm, self.settings.clone())
        };
        let mut result = threads::run(config.core(), options);
        let prompter = guide.prompter;
        showing.finish(result.as_mut().ok());
        let mut report = result?;
        recorder.finish(&mut report);
        Ok(Ran {
            report,
            prompter,
            showing,
        })
    }
}
