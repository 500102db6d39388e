//! `sipnpuff fit`: fits a user's settings from a calibration session and
//! writes their profile. With `--from`, a session recorded before; without
//! it, a live session: the real sensor path (any `--sensor`, re-zeroed as
//! `run` does) and the simulated arm (a fit never drives a real arm), the
//! user guided prompt by prompt on the page and in the terminal
//! ([`crate::fit::prompter`] on the telemetry side), the session recorded
//! as `run --record` records; once it is over, the recording is fitted
//! exactly as `--from` would fit it.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::Context;

use crate::arm::Arm;
use crate::arm::sim::SimArm;
use crate::cli::args::{ConfigArg, RtArgs};
use crate::cli::display::{Display, DisplayArgs, Showing};
use crate::cli::output::{self, invalid};
use crate::cli::run::{OnSensor, open_sensor, stop_request};
use crate::config::Config;
use crate::control::event::TimedEvent;
use crate::fit::check::{COLUMNS, ConfusionMatrix};
use crate::fit::drift;
use crate::fit::outcome::Outcome;
use crate::fit::predict::{KindRates, Rates};
use crate::fit::profile::{self, ProfileHeader};
use crate::fit::prompter::{Prompter, Say};
use crate::fit::protocol::{DEFAULT_COUNT, DEFAULT_HOLDS, Protocol};
use crate::fit::signal::FitError;
use crate::fit::signal::Signal;
use crate::fit::{self as fitting, Fit};
use crate::rt::control_loop::StopReason;
use crate::rt::recorder::SessionRecorder;
use crate::rt::report::RunReport;
use crate::rt::stop::{SignalName, StopRequest};
use crate::rt::telemetry::{TelemetryObserver, TickRecord};
use crate::rt::telemetry_thread::Watchers;
use crate::rt::threads::{self, LoopSettings, RunOptions};
use crate::sensor::{Sensor, SensorSpec};
use crate::sim::synthetic_sensor::SyntheticSensor;
use crate::tools::recording::read::Recording;
use crate::tools::recording::recorder::{Recorder, check_dir};
use crate::tools::recording::writer::RecordOptions;
use crate::tools::signal_file::{read_signal, recorded_signal};

/// The profile's name in a live session's directory (without `--out`).
pub const PROFILE: &str = "profile.toml";

/// The file a guided session leaves in its recording: the protocol it
/// followed (`Protocol` as JSON), written when the session starts. A
/// recording without it is ordinary use.
pub const CALIBRATION: &str = "calibration.json";

/// How long the page's summary may take to reach the open pages before
/// `fit` exits.
const SUMMARY_WAIT: Duration = Duration::from_secs(3);

/// `fit`'s options.
#[derive(clap::Args, Debug)]
pub struct FitArgs {
    /// The calibration to fit: a `tick,volts` CSV at 1 kHz or a `run
    /// --record` directory (a live session's too), breathed in the
    /// protocol's order (rest ≥ 5 s; short puffs, long puffs, short sips,
    /// long sips; then the holds). Without it: a live session, guided
    /// prompt by prompt, recorded, then fitted.
    #[arg(long)]
    from: Option<PathBuf>,
    /// Where to write the profile (a configuration file). Default: with
    /// `--from`, none (the report only); live, `profile.toml` in the
    /// session's directory.
    #[arg(long)]
    out: Option<PathBuf>,
    /// The settings in use, to compare with (default: built-in).
    #[command(flatten)]
    config: ConfigArg,
    /// Breaths per block.
    #[arg(long, default_value_t = DEFAULT_COUNT, value_parser = clap::value_parser!(u32).range(3..=50))]
    count: u32,
    /// The session ends with the longest comfortable puffs and sips
    /// (three of each).
    #[arg(long)]
    holds: bool,
    /// The user's label for the profile's header (and a live session's
    /// directory).
    #[arg(long, default_value = "user")]
    label: String,
    /// Write the profile even when short and long breaths overlap.
    #[arg(long)]
    force: bool,
    /// Print the fit as one JSON object instead of the report (a live
    /// session's prompts then go to stderr).
    #[arg(long)]
    json: bool,
    /// Live: where samples come from, as `run --sensor` (default: the
    /// built-in synthetic user, who breathes the protocol in time with
    /// the prompts).
    #[arg(long, default_value = "synthetic", value_parser = SensorSpec::parse, conflicts_with = "from")]
    sensor: SensorSpec,
    /// Live: record the session into this directory (created if needed;
    /// never over a recording). Default: `fit-LABEL-DATE` in the current
    /// directory (`-2`, `-3`… if taken). `fit --from DIR` fits it again.
    #[arg(long, value_name = "DIR", conflicts_with = "from")]
    record: Option<PathBuf>,
    #[command(flatten)]
    display: DisplayArgs,
    #[command(flatten)]
    rt: RtArgs,
}

/// Fits, reports, and writes the profile if it reads the user reliably
/// (or `--force`). Exit 0 with a profile; 1 with the reason and nothing
/// written; a live session interrupted by signal N: 128 + N.
pub fn fit(args: FitArgs) -> anyhow::Result<u8> {
    let protocol = Protocol::new(args.count, if args.holds { DEFAULT_HOLDS } else { 0 });
    let current = args.config.load()?;
    let Some(from) = &args.from else {
        return live(&args, &current, &protocol);
    };
    let signal = read_signal(from).map_err(anyhow::Error::msg)?;
    let fitted = recorded(&args, from, &signal, &protocol, &current)?;
    let source = from.display().to_string();
    let (status, _) = conclude(&args, fitted, &current, &source, args.out.as_deref())?;
    Ok(status)
}

/// Fits a session recorded before: a calibration (a CSV; a recording of
/// a guided session, which says so; any recording whose breaths follow
/// the protocol block for block) or ordinary use (any other recording,
/// against the profile in use: `--config`, or what it recorded).
fn recorded(
    args: &FitArgs,
    from: &Path,
    signal: &Signal,
    protocol: &Protocol,
    current: &Config,
) -> anyhow::Result<Result<Fit, FitError>> {
    let as_protocol = fitting::fit(signal, protocol, current);
    let follows = as_protocol
        .as_ref()
        .is_ok_and(|f| f.answers.notes.is_empty());
    if !from.is_dir() || from.join(CALIBRATION).exists() || follows {
        return Ok(as_protocol);
    }
    let in_use = match &args.config.config {
        Some(_) => current.clone(),
        None => Recording::open(from)?.config,
    };
    note!(
        "{}: a session of ordinary use (it does not follow the protocol): its breaths split into short and long as you made them",
        from.display()
    );
    Ok(fitting::fit_use(signal, &in_use))
}

/// Reports a fit (from `source`, in words), and writes the profile to
/// `out` (if any) when it reads the user reliably or `--force`: what
/// `--from` and a live session share. The exit status, and the outcome
/// for the page.
fn conclude(
    args: &FitArgs,
    fitted: Result<Fit, FitError>,
    current: &Config,
    source: &str,
    out: Option<&Path>,
) -> anyhow::Result<(u8, Outcome)> {
    let fit = match fitted {
        Ok(fit) => fit,
        Err(e) => {
            note!("error: cannot fit {source}: {e}");
            let outcome = Outcome {
                problem: Some(format!("cannot fit the session: {e}")),
                ..Outcome::default()
            };
            return Ok((output::FAILED, outcome));
        }
    };
    if let Some(path) = &args.config.config {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        let then = drift::fitted(&text);
        if then.is_empty() {
            note!(
                "{} has no fitted measurements in its header: no drift to report",
                path.display()
            );
        }
        for line in drift::drift(&then, &fit.classes) {
            note!("drift: {line}");
        }
    }
    if args.json {
        output::stdout_line(&json(&fit)?).context("stdout")?;
    } else {
        output::stdout(&report(&fit)).context("stdout")?;
    }
    let mut outcome = Outcome::of(&fit, current);
    if let Some(overlap) = &fit.overlap
        && !args.force
    {
        note!("no profile written: {overlap} (--force writes it anyway)");
        outcome.problem = Some(format!("{overlap} (--force writes the profile anyway)"));
        return Ok((output::FAILED, outcome));
    }
    let Some(out) = out else {
        return Ok((output::COMPLETED, outcome));
    };
    let header = ProfileHeader {
        label: args.label.clone(),
        date: today(),
        source: source.to_string(),
    };
    let text = profile::text(&fit, &header);
    std::fs::write(out, &text).with_context(|| format!("cannot write {}", out.display()))?;
    note!("wrote the profile to {}", out.display());
    outcome.profile = Some(out.display().to_string());
    Ok((output::COMPLETED, outcome))
}

/// Today, `YYYY-MM-DD` (UTC).
fn today() -> String {
    crate::tools::recording::meta::utc_now()[..10].to_string()
}

/// A live session: guided, recorded, then fitted from its recording.
fn live(args: &FitArgs, current: &Config, protocol: &Protocol) -> anyhow::Result<u8> {
    if args.display.tui {
        return invalid(Err(anyhow::anyhow!(
            "fit has no terminal view (--tui): its prompts are printed, and shown on the page"
        )));
    }
    let dir = match &args.record {
        Some(dir) => dir.clone(),
        None => default_dir(&args.label),
    };
    // Where the profile goes is checked now, not after the session.
    if let Some(out) = &args.out
        && let Some(parent) = out.parent().filter(|p| !p.as_os_str().is_empty())
        && !parent.is_dir()
    {
        return invalid(Err(anyhow::anyhow!(
            "--out {}: {} is not a directory",
            out.display(),
            parent.display()
        )));
    }
    invalid(check_dir(&dir).map_err(|e| anyhow::Error::new(e).context("--record")))?;
    let out = args.out.clone().unwrap_or_else(|| dir.join(PROFILE));
    let settings = LoopSettings {
        seconds: None,
        rt: args.rt.options()?,
        spin_margin_ns: args.rt.spin_margin_ns(),
        stop: stop_request()?,
    };
    let display = Display::open(&args.display)?;
    note!(
        "sipnpuff: fitting \"{}\": {}; the session is recorded in {}",
        args.label,
        protocol.describe(),
        dir.display()
    );
    let session = Session {
        protocol,
        settings: &settings,
        display: &display,
        dir: &dir,
        to_stderr: args.json,
    };
    let ran = open_sensor(
        &args.sensor,
        current,
        || SyntheticSensor::calibration_user(current, protocol),
        session,
    )?;
    let Ran {
        report,
        prompter,
        mut showing,
    } = ran;
    let kept = dir.display().to_string();
    note!(
        "sipnpuff: {} ticks, {} heap allocations on the control thread",
        report.stats.ticks_run,
        report.control_thread_allocations
    );
    if let Some((status, why)) = unfinished(&report, &prompter) {
        note!("sipnpuff: {why}");
        note!("sipnpuff: no profile written; the session so far is kept in {kept}");
        let outcome = Outcome {
            problem: Some(why),
            recording: Some(kept),
            ..Outcome::default()
        };
        showing.conclude(&outcome, SUMMARY_WAIT);
        return Ok(status);
    }
    let (status, mut outcome) = match recorded_signal(&dir) {
        Ok(signal) => {
            let source = format!("a guided session recorded in {kept}");
            let fitted = fitting::fit(&signal, protocol, current);
            conclude(args, fitted, current, &source, Some(&out))?
        }
        Err(e) => {
            note!("error: {e}");
            let outcome = Outcome {
                problem: Some(e.to_string()),
                ..Outcome::default()
            };
            (output::FAILED, outcome)
        }
    };
    note!(
        "sipnpuff: the session is recorded in {kept}; `sipnpuff fit --from {kept} --count {}{}` fits it again",
        args.count,
        if args.holds { " --holds" } else { "" }
    );
    outcome.recording = Some(kept);
    showing.conclude(&outcome, SUMMARY_WAIT);
    Ok(status)
}

/// Why a live session ended without every block breathed, and the exit
/// status; `None` if it was all breathed and recorded.
fn unfinished(report: &RunReport, prompter: &Prompter) -> Option<(u8, String)> {
    if let Some(stop) = prompter.stopped() {
        return Some((output::FAILED, stop.words()));
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
                    output::interrupted(n),
                    format!("interrupted ({}) before the session's end", SignalName(n)),
                ));
            }
            StopReason::SensorEnded => {
                format!("the sensor ended before the session's end{errors}")
            }
            reason => format!("the run stopped ({reason}) before the session's end{errors}"),
        };
        return Some((output::FAILED, why));
    }
    let recording = report.recording.as_ref()?;
    recording
        .error
        .as_ref()
        .map(|e| (output::FAILED, format!("the recording failed: {e}")))
}

/// `fit-LABEL-DATE` in the current directory, or with `-2`, `-3`… the
/// first that does not exist yet.
fn default_dir(label: &str) -> PathBuf {
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
    display: &'a Display,
    dir: &'a Path,
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
        let mut guide = Guide {
            prompter: Prompter::new(self.protocol),
            showing: &mut showing,
            stop: self.settings.stop.clone(),
            to_stderr: self.to_stderr,
            held: None,
            told_rest: false,
        };
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

/// The session's guide on the telemetry thread: each tick's sample (what
/// the core was given, as recorded) to the [`Prompter`], what it says to
/// the terminal and the page; the run stopped once the session is over.
/// The page's hub watches the run behind it.
struct Guide<'a> {
    prompter: Prompter,
    showing: &'a mut Showing,
    stop: StopRequest,
    to_stderr: bool,
    /// The breath held, as last shown.
    held: Option<crate::control::action::Breath>,
    /// The rest's level was printed.
    told_rest: bool,
}

impl Guide<'_> {
    /// A line for the terminal; a failed stdout does not stop the
    /// session (the report will say it).
    fn print(&self, line: &str) {
        if self.to_stderr {
            note!("{line}");
        } else {
            let _ = output::stdout_line(line);
        }
    }

    fn said(&mut self, say: &Say) {
        if let (Say::Prompt(_), false, Some(band)) = (say, self.told_rest, self.prompter.band()) {
            self.told_rest = true;
            self.print(&format!(
                "rest: {:.3} V; a breath is {:.3} V or more away from it",
                band.level, band.outside
            ));
        }
        self.print(&say.line());
    }
}

impl TelemetryObserver for Guide<'_> {
    fn record(&mut self, record: &TickRecord) {
        if !record.reference && !self.prompter.is_over() {
            let tick = record.input.tick;
            let said = self.prompter.step(tick, record.input.sample);
            if let Some(say) = &said {
                self.said(say);
            }
            let view = self.prompter.view();
            if said.is_some() || view.held != self.held {
                self.held = view.held;
                self.showing.calibrate(tick, &view, said.as_ref());
            }
            if self.prompter.is_over() {
                self.stop.finished();
            }
        }
        if let Some(observer) = self.showing.observer() {
            observer.record(record);
        }
    }

    fn event(&mut self, event: &TimedEvent) {
        if let Some(observer) = self.showing.observer() {
            observer.event(event);
        }
    }

    fn drained(&mut self) {
        if let Some(observer) = self.showing.observer() {
            observer.drained();
        }
    }
}

/// The fit as JSON.
fn json(fit: &Fit) -> anyhow::Result<String> {
    let value = serde_json::json!({
        "rest": {
            "level_volts": fit.found.rest.level,
            "noise_sd_volts": fit.found.rest.sd,
            "excursion_up_volts": fit.found.rest.excursion_up,
            "excursion_down_volts": fit.found.rest.excursion_down,
            "spikes": fit.found.rest.spikes,
            "ms": fit.found.rest.ms,
        },
        "classes": fit.classes,
        "gaps_ms": fit.gaps,
        "notes": fit.answers.notes,
        "proposed": fit.proposal.settings,
        "predicted": { "current": fit.predicted[0], "proposed": fit.predicted[1] },
        "replayed": { "current": fit.replayed[0], "proposed": fit.replayed[1] },
        "overlap": fit.overlap,
        "worse": fit.worse,
    });
    Ok(serde_json::to_string(&value)?)
}

/// The report a clinician reads.
pub fn report(fit: &Fit) -> String {
    let mut out = String::new();
    let rest = &fit.found.rest;
    let _ = writeln!(
        out,
        "rest: {:.3} V over {:.1} s, noise sd {:.3} V, largest excursion +{:.3} / −{:.3} V, {} spikes",
        rest.level,
        rest.ms as f64 / 1000.0,
        rest.sd,
        rest.excursion_up,
        rest.excursion_down,
        rest.spikes
    );
    for note in &fit.answers.notes {
        let _ = writeln!(out, "note: {note}");
    }
    let _ = writeln!(out, "\nmeasured (durations at the proposed thresholds):");
    for c in &fit.classes {
        let _ = writeln!(
            out,
            "  {:<26} {:>2}  {}",
            c.ask.words(),
            c.breaths,
            c.measured()
        );
    }
    let _ = writeln!(
        out,
        "  pauses between breaths: {:.0} ± {:.0} ms",
        fit.gaps.mean, fit.gaps.sd
    );
    let _ = writeln!(out, "\nproposed settings:");
    for s in &fit.proposal.settings {
        let _ = writeln!(out, "  {} = {}\n      {}", s.key, s.value, s.reason);
    }
    let _ = writeln!(out, "\npredicted misreadings        current  proposed");
    rates(&mut out, &fit.predicted[0], &fit.predicted[1]);
    let _ = writeln!(
        out,
        "\nthe session replayed through the detector (rows: asked or, in ordinary use, as you meant them; columns: read)"
    );
    for (name, c) in [
        ("current", &fit.replayed[0]),
        ("proposed", &fit.replayed[1]),
    ] {
        matrix(&mut out, name, c);
    }
    for w in &fit.worse {
        let _ = writeln!(out, "worse than the current settings: {w}");
    }
    if let Some(overlap) = &fit.overlap {
        let _ = writeln!(out, "\n{overlap}");
    }
    out
}

fn rates(out: &mut String, now: &Rates, new: &Rates) {
    let pct = |v: f64| format!("{:>6.1} %", 100.0 * v);
    type Rate = fn(&KindRates) -> f64;
    let rows: [(&str, Rate); 3] = [
        ("missed", |k| k.missed),
        ("short read as long", |k| k.short_as_long),
        ("long read as short", |k| k.long_as_short),
    ];
    for (kind, a, b) in [
        ("puffs", &now.puff, &new.puff),
        ("sips", &now.sip, &new.sip),
    ] {
        for (what, f) in rows {
            let _ = writeln!(
                out,
                "  {:<26} {} {}",
                format!("{kind} {what}"),
                pct(f(a)),
                pct(f(b))
            );
        }
    }
    let _ = writeln!(
        out,
        "  {:<26} {:>6.2}/h {:>6.2}/h",
        "false bursts at rest", now.false_per_hour, new.false_per_hour
    );
}

fn matrix(out: &mut String, name: &str, c: &ConfusionMatrix) {
    let (right, asked) = c.right();
    let _ = writeln!(
        out,
        "  {name}: {right}/{asked} read right, {} bursts nobody was asked for, {} faults",
        c.unprompted, c.faults
    );
    let header: Vec<String> = COLUMNS.iter().map(|c| format!("{c:>10}")).collect();
    let _ = writeln!(out, "    {:<26}{}", "", header.join(""));
    for row in &c.rows {
        let cells: Vec<String> = row.counts.iter().map(|n| format!("{n:>10}")).collect();
        let _ = writeln!(out, "    {:<26}{}", row.ask.words(), cells.join(""));
    }
}
