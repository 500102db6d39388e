//! `sipnpuff study`: the paper's experiment in simulation.

use std::path::PathBuf;

use anyhow::Context;

use crate::cli::args::ConfigArg;
use crate::cli::output;
use crate::sim::study::atypical::{self, AtypicalOptions};
use crate::sim::study::fit_paper::{self, FitPlan, Targets};
use crate::sim::study::head::{self, HeadStudyOptions};
use crate::sim::study::{
    StudyOptions, StudyReport, SweepParam, plot, run_study, study_text, sweep, sweep_text,
};

/// `study`'s options.
#[derive(clap::Args, Debug)]
pub struct StudyArgs {
    /// Simulated participants (at least 2: the test pairs them).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u64).range(2..))]
    users: u64,
    /// Seed: the same seed gives the same study.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[command(flatten)]
    config: ConfigArg,
    /// Print one JSON object (a sweep: one JSON array of rows).
    #[arg(long)]
    json: bool,
    /// Draw the completion times per task and interface to this SVG.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Instead, how the gap moves with one parameter.
    #[arg(long, value_enum)]
    sweep: Option<SweepParam>,
    /// Instead, the built-in atypical breathers (weak, slow, tremulous,
    /// …): each fitted from the calibration protocol, then reading a
    /// held-out session and doing the three tasks with the defaults and
    /// with their profile.
    #[arg(long, conflicts_with_all = ["sweep", "plot", "users"])]
    atypical: bool,
    /// Instead, fit BSP's scan dwell, first-dwell factor and the users'
    /// miss rate to the paper's reductions (35, 30, 42 %), and print the
    /// fitted study beside the paper.
    #[arg(long, conflicts_with_all = ["sweep", "plot", "atypical"])]
    fit_paper: bool,
    /// Instead, the six simulated head-gesture people: each records their
    /// gestures by the protocol, then does the three tasks selecting with
    /// gestures and driving with head tilts, beside the breath study's
    /// ASP and BSP in the same run.
    #[arg(long, conflicts_with_all = ["sweep", "plot", "atypical", "fit_paper", "users", "config"])]
    head: bool,
}

/// Runs the study (or a sweep) and prints it.
pub fn study(args: StudyArgs) -> anyhow::Result<()> {
    if args.atypical {
        let options = AtypicalOptions {
            seed: args.seed,
            ..AtypicalOptions::default()
        };
        let results = atypical::run(&options);
        return print(args.json, &results[..], atypical::text);
    }
    if args.head {
        let options = HeadStudyOptions {
            seed: args.seed,
            ..HeadStudyOptions::default()
        };
        let report = head::run(&options, |done, total| {
            progress!("\r{done}/{total} head runs");
        })
        .map_err(|e| anyhow::anyhow!(e))?;
        note!();
        return print(args.json, &report, head::text);
    }
    let config = args.config.load()?;
    let options = StudyOptions {
        users: usize::try_from(args.users)?,
        seed: args.seed,
        ..StudyOptions::default()
    };
    if args.fit_paper {
        let report = output::invalid(
            fit_paper::fit(
                &config,
                &options,
                &Targets::PAPER,
                &FitPlan::default(),
                |studies| progress!("\rfit: {studies} studies   "),
            )
            .map_err(anyhow::Error::from),
        )?;
        note!();
        return print(args.json, &report, fit_paper::fit_text);
    }
    if let Some(param) = args.sweep {
        let rows = sweep(&config, &options, param, |label, done, total| {
            progress!("\r{label}: {done}/{total} runs   ");
        })?;
        note!();
        if args.json {
            output::stdout_line(&serde_json::to_string(&rows)?)
        } else {
            output::stdout(&sweep_text(param, &rows))
        }
        .context("stdout")?;
        return Ok(());
    }
    let results = output::invalid(
        run_study(&config, &options, |done, total| {
            progress!("\r{done}/{total} runs");
        })
        .map_err(anyhow::Error::from),
    )?;
    note!();
    if args.json {
        output::stdout_line(&serde_json::to_string(&StudyReport::of(
            &results, &options,
        ))?)
    } else {
        output::stdout(&study_text(&results, &options))
    }
    .context("stdout")?;
    if let Some(path) = args.plot {
        plot::write_completion_svg(&path, &results)
            .with_context(|| format!("cannot write {}", path.display()))?;
        note!("wrote {}", path.display());
    }
    Ok(())
}

/// `report` as one JSON line, or as `text` words it.
fn print<T: serde::Serialize + ?Sized>(
    json: bool,
    report: &T,
    text: impl FnOnce(&T) -> String,
) -> anyhow::Result<()> {
    if json {
        output::stdout_line(&serde_json::to_string(report)?)
    } else {
        output::stdout(&text(report))
    }
    .context("stdout")
}
