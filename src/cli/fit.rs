//! `sipnpuff fit`: fits a user's settings from a calibration session and
//! writes their profile. With `--from`, a session recorded before
//! ([`crate::session::fitting`]); without it, a live session, guided,
//! recorded, then fitted ([`crate::session::calibration`]).

use std::path::{Path, PathBuf};

use crate::cli::args::{ConfigArg, RtArgs, record_dir};
use crate::cli::display::DisplayArgs;
use crate::cli::output::{self, Invalid, Terminal, invalid};
use crate::config::layers::Layered;
use crate::fit::drift;
use crate::fit::protocol::DEFAULT_COUNT;
use crate::sensor::SensorSpec;
use crate::session::calibration::{self, Live};
use crate::session::fitting::{
    FitEnd, FitRequest, PROFILE, fit_recorded, settings_on_another_scale,
};

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
    /// The settings in use, to compare with (default: built-in); as
    /// often as needed (a profile, a library…). The profile keeps every
    /// setting of them the fit does not measure, marked "kept from FILE".
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
    /// the prompts; `synthetic:NAME` a built-in breather, e.g.
    /// `synthetic:tremor_4hz`, in that user's place).
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
/// written; 2 for options or settings that do not fit the session (a
/// profile in ADC counts, another `--count` than a guided session's); a
/// live session interrupted by signal N: 128 + N.
pub fn fit(args: FitArgs) -> anyhow::Result<u8> {
    let setup = args.config.layered().map_err(|e| {
        // A profile of another sensor: said against the session, in one line.
        let other = (args.from.as_deref())
            .and_then(|from| settings_on_another_scale(from, &args.config.config));
        match other {
            Some(line) => Invalid(anyhow::Error::msg(line)).into(),
            None => e,
        }
    })?;
    let current = setup.config().clone();
    let request = FitRequest {
        count: args.count,
        holds: args.holds,
        current: &current,
        current_file: fitted_file(&setup),
        setup: &setup,
        label: &args.label,
        force: args.force,
        json: args.json,
    };
    let end = match &args.from {
        Some(from) => fit_recorded(&request, from, args.out.as_deref(), &Terminal)?,
        None => live(&args, &request)?,
    };
    Ok(match end {
        FitEnd::Completed => output::COMPLETED,
        FitEnd::Failed => output::FAILED,
        FitEnd::Interrupted(n) => output::interrupted(n),
    })
}

/// Of the setup's files, the one whose header holds the measurements of
/// the fit before (the last profile `fit` wrote), for the drift; with
/// none, the last file.
fn fitted_file(setup: &Layered) -> Option<&Path> {
    let layers = setup.layers();
    layers
        .iter()
        .rev()
        .find(|l| !drift::fitted(&l.text).is_empty())
        .or(layers.last())
        .map(|l| l.path.as_path())
}

/// A live session's options, checked before it starts: the session's
/// directory (by default `fit-LABEL-DATE`) and where the profile goes.
fn live(args: &FitArgs, request: &FitRequest) -> anyhow::Result<FitEnd> {
    if args.display.tui {
        return invalid(Err(anyhow::anyhow!(
            "fit has no terminal view (--tui): its prompts are printed, and shown on the page"
        )));
    }
    let dir = match &args.record {
        Some(dir) => dir.clone(),
        None => calibration::default_dir(&args.label),
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
    record_dir(&dir)?;
    let out = args.out.clone().unwrap_or_else(|| dir.join(PROFILE));
    let settings = args.rt.loop_settings(None, request.current.rt())?;
    let live = Live {
        sensor: &args.sensor,
        dir: &dir,
        out: &out,
        settings: &settings,
        display: args.display.choice(),
    };
    calibration::calibrate(request, &live, &Terminal)
}
