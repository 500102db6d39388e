//! Fitting what a session leaves: a calibration (a CSV; a guided
//! session's recording, which says so; any recording whose breaths follow
//! the protocol block for block) or ordinary use (any other recording,
//! against the profile in use); the fit reported, compared with the
//! profile in use, and written as a profile when it reads the person
//! reliably.

use std::path::Path;

use anyhow::Context;

use crate::config::Config;
use crate::config::layers::Layered;
use crate::fit::outcome::Outcome;
use crate::fit::profile::{self, ProfileHeader};
use crate::fit::protocol::{DEFAULT_HOLDS, Protocol};
use crate::fit::signal::{FitError, Signal};
use crate::fit::{self, Fit, drift, report};
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
    let signal = read_signal(from).map_err(anyhow::Error::msg)?;
    let fitted = recorded(request, from, &signal, console)?;
    let source = from.display().to_string();
    let (end, _) = conclude(request, fitted, &source, out, console)?;
    Ok(end)
}

/// Fits a session recorded before: as a calibration, or, if it is a
/// recording that neither says it is one nor follows the protocol, as
/// ordinary use (against `--config`, or what it recorded).
fn recorded(
    request: &FitRequest,
    from: &Path,
    signal: &Signal,
    console: &dyn Console,
) -> anyhow::Result<Result<Fit, FitError>> {
    let as_protocol = fit::fit(signal, &request.protocol(), request.current);
    let follows = as_protocol
        .as_ref()
        .is_ok_and(|f| f.answers.notes.is_empty());
    if !from.is_dir() || from.join(CALIBRATION).exists() || follows {
        return Ok(as_protocol);
    }
    let in_use = match request.current_file {
        Some(_) => request.current.clone(),
        None => Recording::open(from)?.config,
    };
    console.note(&format!(
        "{}: a session of ordinary use (it does not follow the protocol): its breaths split into short and long as you made them",
        from.display()
    ));
    Ok(fit::fit_use(signal, &in_use))
}

/// Reports a fit (from `source`, in words), and writes the profile to
/// `out` (if any) when it reads the user reliably or `force`: what a
/// recording and a live session share. How it ended, and the outcome for
/// the page.
pub(super) fn conclude(
    request: &FitRequest,
    fitted: Result<Fit, FitError>,
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
    if let Some(path) = request.current_file {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        let then = drift::fitted(&text);
        if then.is_empty() {
            console.note(&format!(
                "{} has no fitted measurements in its header: no drift to report",
                path.display()
            ));
        }
        for line in drift::drift(&then, &fit.classes) {
            console.note(&format!("drift: {line}"));
        }
    }
    if request.json {
        console.print_line(&report::json(&fit)?).context("stdout")?;
    } else {
        console.print(&report::text(&fit)).context("stdout")?;
    }
    let mut outcome = Outcome::of(&fit, request.current);
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
    let text = profile::text_keeping(&fit, &header, request.setup);
    std::fs::write(out, &text).with_context(|| format!("cannot write {}", out.display()))?;
    for line in kept_lines(&fit, request.setup) {
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
