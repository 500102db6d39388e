//! Fitting what a session leaves: a calibration (a CSV; a guided
//! session's recording, which says so; any recording whose breaths follow
//! the protocol block for block) or ordinary use (any other recording,
//! against the profile in use); the fit reported, compared with the
//! profile in use, and written as a profile when it reads the person
//! reliably.

use std::path::{Path, PathBuf};

use anyhow::Context;

use crate::config::Config;
use crate::config::invalid::invalid;
use crate::config::layers::Layered;
use crate::fit::outcome::Outcome;
use crate::fit::profile::{self, ProfileHeader};
use crate::fit::protocol::{DEFAULT_HOLDS, Protocol};
use crate::fit::signal::{FitError, Signal};
use crate::fit::{self, Fit, breaths, drift, report};
use crate::session::Console;
use crate::tools::recording::read::Recording;
use crate::tools::signal_file::read_signal;

/// The profile's name in a live session's directory (without `--out`).
pub const PROFILE: &str = "profile.toml";

/// The file a guided session leaves in its recording: the protocol it
/// followed (`Protocol` as JSON), written when the session starts. A
/// recording without it is ordinary use.
pub const CALIBRATION: &str = "calibration.json";

/// What a fit is asked for.
pub struct FitRequest<'a> {
    /// Breaths per block of the protocol.
    pub count: u32,
    /// The protocol ends with the longest comfortable puffs and sips.
    pub holds: bool,
    /// The settings in use, to compare with.
    pub current: &'a Config,
    /// Their file, if given: its header's fitted measurements, for the
    /// drift; in ordinary use, the profile in use.
    pub current_file: Option<&'a Path>,
    /// The whole setup in use (`--config` files, later over earlier): the
    /// profile keeps every setting of it the fit does not measure.
    pub setup: &'a Layered,
    /// The person's label, for the profile's header.
    pub label: &'a str,
    /// Write the profile even when short and long breaths overlap.
    pub force: bool,
    /// Print the fit as one JSON object instead of the report.
    pub json: bool,
}

impl FitRequest<'_> {
    /// The protocol asked for.
    pub fn protocol(&self) -> Protocol {
        Protocol::new(self.count, if self.holds { DEFAULT_HOLDS } else { 0 })
    }
}

/// How a fit ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FitEnd {
    /// Fitted (and the profile written, if one was asked for).
    Completed,
    /// No profile: the reason was said.
    Failed,
    /// A live session stopped by this signal, its recording kept.
    Interrupted(i32),
}

/// Fits the session recorded at `from` (a CSV or a recording's
/// directory), reports it and writes the profile to `out`, if any, when
/// it reads the person reliably (or `force`).
pub fn fit_recorded(
    request: &FitRequest,
    from: &Path,
    out: Option<&Path>,
    console: &dyn Console,
) -> anyhow::Result<FitEnd> {
    guided_as_asked(request, from)?;
    let signal = read_signal(from).map_err(anyhow::Error::msg)?;
    in_volts(from, &signal, request.setup)?;
    let (fitted, kind) = recorded(request, from, &signal, console)?;
    let source = from.display().to_string();
    let (end, _) = conclude(request, fitted, kind, &source, out, console)?;
    Ok(end)
}

/// The sensor's range, volts: every level the settings hold is in it.
const SENSOR_VOLTS: std::ops::RangeInclusive<f64> = 0.0..=5.0;

/// Refuses a session that starts at a level no sensor in volts gives
/// (ADC counts, most likely): nothing in it could be read with settings
/// in volts.
fn in_volts(from: &Path, signal: &Signal, setup: &Layered) -> anyhow::Result<()> {
    let key = "detector.neutral_volts";
    match breaths::opening_level(signal) {
        Some(rest) if !SENSOR_VOLTS.contains(&rest) => Err(anyhow::anyhow!(
            "{}: its rest is at {rest:.0}, which looks like ADC counts, but {key} is {} V ({}): the settings are volts at the sensor (0–5 V); convert the recording to volts (counts / full scale × 5)",
            from.display(),
            setup.config().core().detector().neutral_volts,
            setup.origin(key)
        )),
        _ => Ok(()),
    }
}

/// When `files` hold a level outside the sensor's volts (ADC counts,
/// from a profile of another sensor) and the session at `from` is in
/// volts: the one line that says so, naming the key and both scales.
/// `None` otherwise (the files' own errors say the rest).
pub fn settings_on_another_scale(from: &Path, files: &[PathBuf]) -> Option<String> {
    let mut levels: Vec<(&Path, &str, toml::Value)> = Vec::new();
    for file in files {
        let Some(detector) = std::fs::read_to_string(file)
            .ok()
            .and_then(|text| text.parse::<toml::Table>().ok())
            .and_then(|mut table| table.remove("detector"))
        else {
            continue;
        };
        for key in [
            "neutral_volts",
            "puff_threshold_volts",
            "sip_threshold_volts",
        ] {
            if let Some(value) = detector.get(key) {
                levels.retain(|(_, k, _)| *k != key);
                levels.push((file, key, value.clone()));
            }
        }
    }
    let volts = |v: &toml::Value| v.as_float().or(v.as_integer().map(|i| i as f64));
    let (file, key, value) = levels
        .iter()
        .find(|(_, _, v)| volts(v).is_some_and(|v| v > *SENSOR_VOLTS.end()))?;
    let rest = breaths::opening_level(&read_signal(from).ok()?)?;
    SENSOR_VOLTS.contains(&rest).then(|| {
        format!(
            "{}: detector.{key} = {value} looks like ADC counts, but {} is in volts (its rest is at {rest:.2} V): the settings are volts at the sensor (0–5 V); give a profile fitted with this sensor, or none",
            file.display(),
            from.display()
        )
    })
}

/// Refuses to fit a guided session's recording with another protocol
/// than the one its guide followed (`calibration.json`): every block
/// would read as miscounted.
fn guided_as_asked(request: &FitRequest, from: &Path) -> anyhow::Result<()> {
    let path = from.join(CALIBRATION);
    if !path.is_file() {
        return Ok(());
    }
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("cannot read {}", path.display()))?;
    let guided: Protocol = serde_json::from_str(&text)
        .with_context(|| format!("{}: not a calibration's protocol", path.display()))?;
    let asked = request.protocol();
    if guided == asked {
        return Ok(());
    }
    let count = |p: &Protocol| p.blocks.first().map_or(0, |b| b.count);
    let words = |p: &Protocol| {
        let holds = if p.has_holds() {
            ", then the holds"
        } else {
            ""
        };
        format!("{} breaths a block{holds}", count(p))
    };
    let options = |p: &Protocol| {
        let holds = if p.has_holds() { " --holds" } else { "" };
        format!("--count {}{holds}", count(p))
    };
    invalid(Err(anyhow::anyhow!(
        "{}: the session was guided through {} ({CALIBRATION}), where fit asks for {} ({}): fit it with {}",
        from.display(),
        words(&guided),
        words(&asked),
        options(&asked),
        options(&guided)
    )))
}

/// What kind of session was fitted: the verdict's words differ.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SessionKind {
    /// A calibration: breaths asked for.
    Calibration,
    /// Ordinary use: breaths as the person made them.
    OrdinaryUse,
}

/// Fits a session recorded before: as a calibration, or, if it is a
/// recording that neither says it is one nor follows the protocol, as
/// ordinary use, read with the settings it was recorded with (as the run
/// read it), whatever `--config` says.
fn recorded(
    request: &FitRequest,
    from: &Path,
    signal: &Signal,
    console: &dyn Console,
) -> anyhow::Result<(Result<Fit, FitError>, SessionKind)> {
    let as_protocol = fit::fit(signal, &request.protocol(), request.current);
    let follows = as_protocol
        .as_ref()
        .is_ok_and(|f| f.answers.notes.is_empty());
    if !from.is_dir() || from.join(CALIBRATION).exists() || follows {
        return Ok((as_protocol, SessionKind::Calibration));
    }
    let in_use = Recording::open(from)?.config;
    console.note(&format!(
        "{}: a session of ordinary use (it does not follow the protocol): read with the settings it was recorded with, its breaths split into short and long as you made them",
        from.display()
    ));
    if let Some(path) = request.current_file {
        let differ = differences(request.current, &in_use);
        if !differ.is_empty() {
            console.note(&format!(
                "note: {} is not the setup the session was recorded with ({}): the session is read with the recording's own, as the run read it; {} serves only for its fitted measurements",
                path.display(),
                differ,
                path.display()
            ));
        }
    }
    Ok((fit::fit_use(signal, &in_use), SessionKind::OrdinaryUse))
}

/// The settings in which `given` differs from `used`, as `key = given
/// (recorded: used)`, at most four and a count of the rest. `given` is
/// first re-zeroed at the recording's rest level as a run re-zeroes it
/// (its thresholds move with it), so a run's own measurement is no
/// difference.
fn differences(given: &Config, used: &Config) -> String {
    const SHOWN: usize = 4;
    let neutral = used.core().detector().neutral_volts;
    let rezeroed = given.clone().with_neutral_volts(neutral).ok();
    let given = rezeroed.as_ref().unwrap_or(given);
    let (given, used) = (profile::values(given), profile::values(used));
    let differ: Vec<String> = given
        .iter()
        .filter(|(key, _)| key.as_str() != "detector.neutral_volts")
        .filter_map(|(key, value)| {
            let recorded = used.get(key)?;
            (!profile::same(value, recorded)).then(|| {
                if key.starts_with("sequence") {
                    format!("{key} differs")
                } else {
                    format!("{key} = {value} (recorded: {recorded})")
                }
            })
        })
        .collect();
    let mut text = differ
        .iter()
        .take(SHOWN)
        .cloned()
        .collect::<Vec<_>>()
        .join(", ");
    if differ.len() > SHOWN {
        text += &format!(" and {} more", differ.len() - SHOWN);
    }
    text
}

/// The fitted measurements to compare with: those in the header of the
/// file given, or, for a library designed for a profile, that profile's
/// (found beside the library or where its header says). `Err` says why
/// there are none.
fn baseline(path: &Path) -> anyhow::Result<Result<(Vec<drift::Fitted>, String), String>> {
    let read = |p: &Path| {
        std::fs::read_to_string(p).with_context(|| format!("cannot read {}", p.display()))
    };
    let text = read(path)?;
    let then = drift::fitted(&text);
    if !then.is_empty() {
        return Ok(Ok((then, format!("the profile {}", path.display()))));
    }
    let Some(profile) = drift::designed_for(&text) else {
        return Ok(Err(format!(
            "{} has no fitted measurements in its header (it was not written by `sipnpuff fit`)",
            path.display()
        )));
    };
    let named = Path::new(profile);
    let beside = path
        .parent()
        .map(|dir| dir.join(named.file_name().unwrap_or_default()));
    let found = [Some(named.to_path_buf()), beside]
        .into_iter()
        .flatten()
        .find(|p| p.is_file());
    let Some(found) = found else {
        return Ok(Err(format!(
            "{} was designed for the profile {profile}, which is not there: give it (--config {profile}) to compare with its fitting",
            path.display()
        )));
    };
    let then = drift::fitted(&read(&found)?);
    Ok(if then.is_empty() {
        Err(format!(
            "{} was designed for {}, which has no fitted measurements",
            path.display(),
            found.display()
        ))
    } else {
        Ok((
            then,
            format!(
                "the profile {} that {} was designed for",
                found.display(),
                path.display()
            ),
        ))
    })
}

/// Reports a fit (from `source`, in words), and writes the profile to
/// `out` (if any) when it reads the user reliably or `force`: what a
/// recording and a live session share. Ordinary use, or any session
/// given a configuration file, ends with the drift's verdict. How it
/// ended, and the outcome for the page.
pub(super) fn conclude(
    request: &FitRequest,
    fitted: Result<Fit, FitError>,
    kind: SessionKind,
    source: &str,
    out: Option<&Path>,
    console: &dyn Console,
) -> anyhow::Result<(FitEnd, Outcome)> {
    let fit = match fitted {
        Ok(fit) => fit,
        Err(e) => {
            console.note(&format!("error: cannot fit {source}: {e}"));
            let outcome = Outcome {
                problem: Some(format!("cannot fit the session: {e}")),
                ..Outcome::default()
            };
            return Ok((FitEnd::Failed, outcome));
        }
    };
    let verdict = match (kind, request.current_file) {
        (SessionKind::Calibration, None) => None,
        (_, file) => {
            let then = match file {
                Some(path) => baseline(path)?,
                None => Err(
                    "no profile given to compare with (--config PROFILE, the profile the run used)"
                        .to_string(),
                ),
            };
            let meant = match kind {
                SessionKind::Calibration => "as asked",
                SessionKind::OrdinaryUse => "as you made them",
            };
            // A calibration against settings that were never fitted (the
            // built-in ones, a library) has nothing to drift from: the
            // report's current-against-proposed columns say the rest.
            match (&then, kind) {
                (Ok((fitted, from)), _) => Some(drift::verdict(Some(fitted), from, &fit, meant)),
                (Err(_), SessionKind::Calibration) => None,
                (Err(why), SessionKind::OrdinaryUse) => {
                    Some(drift::verdict(None, why, &fit, meant))
                }
            }
        }
    };
    if request.json {
        console.print_line(&report::json(&fit)?).context("stdout")?;
    } else {
        console.print(&report::text(&fit)).context("stdout")?;
    }
    let (end, outcome) = write_profile(request, &fit, source, out, console)?;
    for line in verdict.iter().flat_map(|v| &v.lines) {
        console.note(line);
    }
    Ok((end, outcome))
}

/// Writes the profile to `out` (if any) when the fit reads the user
/// reliably or `force`.
fn write_profile(
    request: &FitRequest,
    fit: &Fit,
    source: &str,
    out: Option<&Path>,
    console: &dyn Console,
) -> anyhow::Result<(FitEnd, Outcome)> {
    let mut outcome = Outcome::of(fit, request.current);
    if let Some(overlap) = &fit.overlap
        && !request.force
    {
        console.note(&format!(
            "no profile written: {overlap} (--force writes it anyway)"
        ));
        outcome.problem = Some(format!("{overlap} (--force writes the profile anyway)"));
        return Ok((FitEnd::Failed, outcome));
    }
    let Some(out) = out else {
        return Ok((FitEnd::Completed, outcome));
    };
    let header = ProfileHeader {
        label: request.label.to_string(),
        date: today(),
        source: source.to_string(),
    };
    let text = profile::text_keeping(fit, &header, request.setup);
    std::fs::write(out, &text).with_context(|| format!("cannot write {}", out.display()))?;
    for line in kept_lines(fit, request.setup) {
        console.note(&line);
    }
    console.note(&format!("wrote the profile to {}", out.display()));
    outcome.profile = Some(out.display().to_string());
    Ok((FitEnd::Completed, outcome))
}

/// What the profile keeps that the fit did not measure, file by file:
/// `kept from FILE: the library (12 entries), output.mqtt.host`.
fn kept_lines(fit: &Fit, setup: &Layered) -> Vec<String> {
    let kept = profile::kept(fit, setup);
    let mut lines = Vec::new();
    for (i, layer) in setup.layers().iter().enumerate() {
        let keys: Vec<String> = (kept.iter().filter(|s| s.layer == i))
            .map(|s| match s.key.as_str() {
                "sequence" => format!(
                    "the library ({} entries)",
                    setup.config().core().sequences().len()
                ),
                key => key.to_string(),
            })
            .collect();
        if !keys.is_empty() {
            lines.push(format!(
                "kept from {} (not measured): {}",
                layer.path.display(),
                keys.join(", ")
            ));
        }
    }
    lines
}

/// Today, `YYYY-MM-DD` (UTC).
pub(super) fn today() -> String {
    crate::tools::recording::meta::utc_now()[..10].to_string()
}
