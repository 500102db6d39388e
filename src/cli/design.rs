//! `sipnpuff design`: the sequence library for the person, their breaths
//! and their gestures. With `--check`, a library analysed for a user and a
//! usage mix; without, the search for the library that costs them least,
//! written as a configuration and tried in the study against the library
//! it replaces ([`crate::design::designing`]).

use std::path::PathBuf;

use anyhow::Context;

use crate::cli::args::ConfigArg;
use crate::cli::output::{self, invalid};
use crate::design::analysis;
use crate::design::designing;
use crate::design::report;
use crate::design::request::{Request, Without};
use crate::design::usage::Mix;

/// `design`'s options.
#[derive(clap::Args, Debug)]
pub struct DesignArgs {
    /// Analyse the library instead of searching for a better one.
    #[arg(long)]
    check: bool,
    /// The library: to analyse, or whose entries to place (default: the
    /// built-in one, or the profile's).
    library: Option<PathBuf>,
    /// The person: a profile `sipnpuff fit` wrote (its measured breaths and
    /// its settings). Default: the study's simulated user.
    #[arg(long)]
    user: Option<PathBuf>,
    /// The person's gesture set (made by `gestures record`), in place of
    /// the settings' `[gestures] set` (default: that one, or LIBRARY's):
    /// each gesture priced from its examples' lengths and the set's
    /// leave-one-out check, and placed by the search beside the bursts.
    #[arg(long, value_name = "SET.toml")]
    gestures: Option<PathBuf>,
    /// The settings in use, as often as needed (a profile, then a
    /// library…; default: the profile's, or the built-in ones): their
    /// library is the one placed unless LIBRARY is given.
    #[command(flatten)]
    config: ConfigArg,
    /// Usage from the `match` events of recordings (`run --record DIR`),
    /// or directories of them.
    #[arg(long, num_args = 1..)]
    usage: Vec<PathBuf>,
    /// Without recordings: every entry as often, or as the study's tasks
    /// change mode (default: the tasks when the library selects their
    /// modes, every entry as often otherwise).
    #[arg(long, value_enum, conflicts_with = "usage")]
    mix: Option<Mix>,
    /// The cost of a wrong selection beyond the attempt, ms (default: the
    /// inactivity timeout, the time for the wrong mode to return to
    /// selection).
    #[arg(long)]
    wrong_cost_ms: Option<f64>,
    /// Chance a burst is read as the other breath (a sip as a puff), for a
    /// person a clinician has seen it happen to: calibration does not
    /// measure it (default 0).
    #[arg(long, default_value_t = 0.0)]
    swap_rate: f64,
    /// Most bursts (and gestures) in a designed sequence.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u8).range(1..=4))]
    max_breaths: u8,
    /// Fewest bursts in a designed sequence of bursts alone (2: a cough or
    /// sigh alone never changes mode, as in the built-in library); one
    /// gesture alone may select.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u8).range(1..=4))]
    min_breaths: u8,
    /// Bursts and gestures the person cannot make reliably: `short_sip`,
    /// `long_sip`, `short_puff`, `long_puff`, `breaths` (all four), or a
    /// gesture of their set (`shake`).
    #[arg(long, num_args = 1.., value_name = "BURST|GESTURE", value_parser = Without::parse)]
    without: Vec<Without>,
    /// With a gesture set and a library of gestures alone: place breaths
    /// too (by default not: the person may have no breath sensor).
    #[arg(long)]
    with_breaths: bool,
    /// Entries that keep their sequence, by what they select
    /// (`translate_x`, `ctrl+c`, `lights_toggle`, …).
    #[arg(long, num_args = 1..)]
    keep: Vec<String>,
    /// Stop branching after this many seconds and report the bound.
    #[arg(long, default_value_t = 50.0)]
    time_limit_s: f64,
    /// Write the designed library (a configuration `run`, `study` and
    /// `design --check` read) to this file.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Draw each entry's expected time and error to this SVG.
    #[arg(long)]
    svg: Option<PathBuf>,
    /// Participants in the study that tries the designed library.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u64).range(2..))]
    users: u64,
    /// The study's seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Skip the study (the model's figures only).
    #[arg(long)]
    no_study: bool,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
    /// Write the designed library even when it is slower than the one it
    /// replaces on the usage it was designed for.
    #[arg(long)]
    force: bool,
}

/// `design --check`'s JSON: what the text's first line says (the library,
/// why this usage), then the analysis, whose `usage` names the usage.
#[derive(serde::Serialize)]
struct CheckReport<'a> {
    library: &'a str,
    usage_why: &'a str,
    #[serde(flatten)]
    analysis: &'a analysis::Analysis,
}

/// Runs `design`.
pub fn design(args: DesignArgs) -> anyhow::Result<()> {
    if args
        .wrong_cost_ms
        .is_some_and(|ms| !(ms.is_finite() && ms >= 0.0))
    {
        return invalid(Err(anyhow::anyhow!(
            "--wrong-cost-ms: must be 0 or more milliseconds"
        )));
    }
    if !(0.0..=0.2).contains(&args.swap_rate) {
        return invalid(Err(anyhow::anyhow!(
            "--swap-rate {}: a chance per burst from 0 to 0.2",
            args.swap_rate
        )));
    }
    if args.min_breaths > args.max_breaths {
        return invalid(Err(anyhow::anyhow!(
            "--min-breaths {} is more than --max-breaths {}",
            args.min_breaths,
            args.max_breaths
        )));
    }
    let request = Request {
        library: args.library,
        user: args.user,
        gestures: args.gestures,
        config: args.config.config,
        usage: args.usage,
        mix: args.mix,
        wrong_cost_ms: args.wrong_cost_ms,
        swap_rate: args.swap_rate,
        min_breaths: args.min_breaths,
        max_breaths: args.max_breaths,
        without: args.without,
        with_breaths: args.with_breaths,
        keep: args.keep,
        time_limit_s: args.time_limit_s,
        out: args.out,
        svg: args.svg,
        users: args.users,
        seed: args.seed,
        no_study: args.no_study,
        force: args.force,
    };
    if args.check {
        let checked = designing::check(&request)?;
        return if args.json {
            output::stdout_line(&serde_json::to_string(&CheckReport {
                library: &checked.library_name,
                usage_why: &checked.usage_why,
                analysis: &checked.analysis,
            })?)
        } else {
            output::stdout(&format!(
                "{} analysed for: {}\n\n{}",
                checked.library_name,
                checked.usage_line,
                analysis::text(&checked.analysis)
            ))
        }
        .context("stdout");
    }
    let designed = designing::design(&request, &|line| note!("{line}"))?;
    if args.json {
        output::stdout_line(&report::json(&designed)?).context("stdout")?;
    } else {
        output::stdout(&report::text(&designed)).context("stdout")?;
    }
    if let Some(path) = &designed.out {
        note!("wrote {}", path.display());
    }
    Ok(())
}
