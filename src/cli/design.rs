//! `sipnpuff design`: the sequence library for the person. With
//! `--check`, a library analysed for a user and a usage mix; without, the
//! search for the library that costs them least, written as a
//! configuration and tried in the study against the library it replaces.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Context, bail};
use serde::Serialize;

use crate::cli::output::{self, invalid};
use crate::config::Config;
use crate::control::action::{Action, ActionSeq};
use crate::control::selection::Interface;
use crate::control::selection::SequenceEntry;
use crate::design::analysis::{self, Analysis, AttemptTiming, analyse};
use crate::design::breathing::Breathing;
use crate::design::search::{self, Problem, SearchResult, candidates};
use crate::design::usage::{Mix, Usage};
use crate::design::{library_file, plot};
use crate::sim::study::libraries::{self, LibraryComparison};
use crate::sim::study::missing_modes;
use crate::tools::recording::matches::read_matches;

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
    /// Usage from the `match` events of recordings (`run --record DIR`),
    /// or directories of them.
    #[arg(long, num_args = 1..)]
    usage: Vec<PathBuf>,
    /// Without recordings: every entry as often, or as the study's tasks
    /// change mode.
    #[arg(long, value_enum, default_value_t = Mix::Uniform, conflicts_with = "usage")]
    mix: Mix,
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
    /// Most bursts in a designed sequence.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u8).range(1..=4))]
    max_breaths: u8,
    /// Fewest bursts in a designed sequence (2: a cough or sigh alone
    /// never changes mode, as in the built-in library).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u8).range(1..=4))]
    min_breaths: u8,
    /// Bursts the person cannot breathe reliably: `short_sip`, `long_sip`,
    /// `short_puff`, `long_puff`.
    #[arg(long, value_enum, num_args = 1..)]
    without: Vec<BurstArg>,
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
}

/// A burst kind on the command line.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
#[clap(rename_all = "snake_case")]
enum BurstArg {
    ShortSip,
    LongSip,
    ShortPuff,
    LongPuff,
}

impl From<BurstArg> for Action {
    fn from(b: BurstArg) -> Action {
        match b {
            BurstArg::ShortSip => Action::ShortSip,
            BurstArg::LongSip => Action::LongSip,
            BurstArg::ShortPuff => Action::ShortPuff,
            BurstArg::LongPuff => Action::LongPuff,
        }
    }
}

/// The person, their settings and the library, as the options say.
struct Inputs {
    who: Breathing,
    config: Config,
    library_name: String,
    usage: Usage,
    timing: AttemptTiming,
}

fn inputs(args: &DesignArgs) -> anyhow::Result<Inputs> {
    let load = |path: &PathBuf| invalid(Config::from_file(path).map_err(anyhow::Error::from));
    let (config, who) = match &args.user {
        Some(path) => {
            let profile = load(path)?;
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("cannot read {}", path.display()))?;
            let measured = crate::fit::profile::measured(&text).map_err(|e| {
                anyhow::anyhow!(
                    "{}: {e}; fit the person first (`sipnpuff fit`) and give the profile it writes",
                    path.display()
                )
            })?;
            let who = Breathing::of_profile(
                &measured,
                &profile,
                &format!("measured by the profile {}", path.display()),
            );
            (profile, who)
        }
        None => {
            let config = Config::default();
            let who = Breathing::of_model(
                &crate::sim::user::UserModel::POPULATION,
                config.core().detector(),
                "the study's simulated user",
            );
            (config, who)
        }
    };
    let (config, library_name) = match &args.library {
        Some(path) => {
            let library = load(path)?;
            (
                invalid(
                    config
                        .with_sequences(library.core().sequences().to_vec())
                        .map_err(anyhow::Error::from),
                )?,
                path.display().to_string(),
            )
        }
        None if args.user.is_some() => (config, "the profile's library".to_string()),
        None => (config, "the built-in library".to_string()),
    };
    let library = config.core().sequences();
    let usage = if args.usage.is_empty() {
        match args.mix {
            Mix::Uniform => Usage::uniform(library),
            Mix::Tasks => Usage::tasks(library),
        }
    } else {
        let found = read_matches(&args.usage).map_err(anyhow::Error::msg)?;
        Usage::recorded(library, &found.events, found.recordings)
    };
    let who = Breathing {
        swap_rate: args.swap_rate,
        ..who
    };
    let timing = AttemptTiming::of(&who, &config, args.wrong_cost_ms);
    Ok(Inputs {
        who,
        config,
        library_name,
        usage,
        timing,
    })
}

/// `design`'s JSON without `--check`.
#[derive(Serialize)]
struct DesignReport<'a> {
    search: &'a SearchResult,
    gap_pct: f64,
    verdict: String,
    designed: &'a Analysis,
    before: &'a Analysis,
    study: Option<&'a StudyCheck>,
    out: Option<String>,
}

/// The study's verdict on the designed library, with the model's
/// prediction beside the study's measure.
#[derive(Serialize)]
struct StudyCheck {
    comparison: LibraryComparison,
    /// The model's mean time per mode change of the tasks, before and
    /// designed, s.
    predicted_selection_s: (f64, f64),
    /// The model's error against the study's measure, percent.
    prediction_error_pct: (f64, f64),
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
    let inputs = inputs(&args)?;
    let library = inputs.config.core().sequences();
    let before = analyse(library, &inputs.who, &inputs.usage, &inputs.timing);
    if args.check {
        if let Some(path) = &args.svg {
            write(path, &plot::analysis_svg(&before, &inputs.library_name))?;
        }
        return if args.json {
            output::stdout_line(&serde_json::to_string(&before)?)
        } else {
            output::stdout(&format!(
                "{}\n\n{}",
                inputs.library_name,
                analysis::text(&before)
            ))
        }
        .context("stdout");
    }
    let problem = problem(&args, &inputs)?;
    note!(
        "placing {} entries on {} sequences…",
        library.len(),
        problem.candidates.len()
    );
    let found = search::search(&problem);
    let designed_library: Vec<SequenceEntry> = library
        .iter()
        .zip(&found.sequences)
        .map(|(e, s)| SequenceEntry {
            actions: *s,
            target: e.target,
        })
        .collect();
    let designed_config = invalid(
        inputs
            .config
            .clone()
            .with_sequences(designed_library.clone())
            .map_err(anyhow::Error::from),
    )?;
    let designed = analyse(
        &designed_library,
        &inputs.who,
        &inputs.usage,
        &inputs.timing,
    );
    let missing = missing_modes(&inputs.config, Interface::Asp);
    let study = if args.no_study {
        None
    } else if !missing.is_empty() {
        let names: Vec<&str> = missing.iter().map(|m| m.name()).collect();
        note!(
            "no study: its tasks need {}, which the library does not select",
            names.join(", ")
        );
        None
    } else {
        Some(study_check(&args, &inputs, &designed_config)?)
    };
    if let Some(path) = &args.out {
        let text = library_file::text(&library_file::Designed {
            config: &designed_config,
            analysis: &designed,
            before: &before,
            found: &found,
            library_name: &inputs.library_name,
        })?;
        write(path, &text)?;
    }
    if let Some(path) = &args.svg {
        write(path, &plot::analysis_svg(&designed, "the designed library"))?;
    }
    if args.json {
        let report = DesignReport {
            search: &found,
            gap_pct: found.gap_pct(),
            verdict: verdict(&designed, &before, &inputs.library_name),
            designed: &designed,
            before: &before,
            study: study.as_ref(),
            out: args.out.as_ref().map(|p| p.display().to_string()),
        };
        output::stdout_line(&serde_json::to_string(&report)?).context("stdout")?;
    } else {
        let mut out = search_text(&found, &designed, &before, &inputs.library_name);
        if let Some(s) = &study {
            out += &format!(
                "\nIn the study ({} against the designed library, sequence matching):\n\n{}",
                inputs.library_name,
                libraries::text(&s.comparison, ("before", "designed"))
            );
            out += &format!(
                "predicted per mode change {:.2} s → {:.2} s (model error {:+.1} % and {:+.1} %)\n",
                s.predicted_selection_s.0,
                s.predicted_selection_s.1,
                s.prediction_error_pct.0,
                s.prediction_error_pct.1
            );
        }
        output::stdout(&out).context("stdout")?;
    }
    if let Some(path) = &args.out {
        note!("wrote {}", path.display());
    }
    Ok(())
}

/// The search's problem from the options.
fn problem(args: &DesignArgs, inputs: &Inputs) -> anyhow::Result<Problem> {
    let library = inputs.config.core().sequences();
    let allowed: Vec<Action> = Action::ALL
        .into_iter()
        .filter(|a| !args.without.iter().any(|w| Action::from(*w) == *a))
        .collect();
    if allowed.is_empty() {
        return invalid(Err(anyhow::anyhow!("--without leaves no burst to breathe")));
    }
    let mut fixed: Vec<Option<ActionSeq>> = vec![None; library.len()];
    for name in &args.keep {
        let Some(i) = library
            .iter()
            .position(|e| names(e).iter().any(|n| n == name))
        else {
            let all: Vec<String> = library.iter().map(|e| names(e)[0].clone()).collect();
            return invalid(Err(anyhow::anyhow!(
                "--keep {name}: the library has no such entry (it has {})",
                all.join(", ")
            )));
        };
        fixed[i] = Some(library[i].actions);
    }
    let candidates = candidates(
        &allowed,
        usize::from(args.min_breaths),
        usize::from(args.max_breaths),
    );
    let free = candidates
        .iter()
        .filter(|c| !fixed.iter().any(|f| f.as_ref() == Some(c)))
        .count();
    let places = fixed.iter().filter(|f| f.is_none()).count();
    if free < places {
        bail!(
            "{places} entries to place but only {free} sequences of {}–{} bursts of {}: allow longer sequences (--max-breaths) or more bursts",
            args.min_breaths,
            args.max_breaths,
            allowed
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    Ok(Problem {
        usage: inputs.usage.shares.clone(),
        fixed,
        candidates,
        who: inputs.who.clone(),
        timing: inputs.timing,
        time_limit: Duration::from_secs_f64(args.time_limit_s.max(0.0)),
    })
}

/// The names `--keep` knows an entry by: its target as the file writes
/// it and as the display labels it.
fn names(e: &SequenceEntry) -> Vec<String> {
    let mut out = Vec::new();
    if let Ok(serde_json::Value::Object(map)) = serde_json::to_value(e.target) {
        out.extend(map.values().filter_map(|v| v.as_str().map(str::to_owned)));
    }
    out.push(e.target.label());
    out
}

/// Runs the study with the library before and the designed one, and sets
/// the model's prediction beside it.
fn study_check(
    args: &DesignArgs,
    inputs: &Inputs,
    designed: &Config,
) -> anyhow::Result<StudyCheck> {
    let population = inputs.who.user_model();
    let comparison = invalid(
        libraries::compare(
            &inputs.config,
            designed,
            &population,
            usize::try_from(args.users)?,
            args.seed,
        )
        .map_err(anyhow::Error::from),
    )?;
    let predict = |config: &Config| {
        let library = config.core().sequences();
        let a = analyse(library, &inputs.who, &Usage::tasks(library), &inputs.timing);
        libraries::mean_over_task_selections(library, |i| a.entries[i].expected_ms) / 1000.0
    };
    let predicted = (predict(&inputs.config), predict(designed));
    let error = |p: f64, m: f64| 100.0 * (p - m) / m;
    Ok(StudyCheck {
        predicted_selection_s: predicted,
        prediction_error_pct: (
            error(predicted.0, comparison.a_selection_s),
            error(predicted.1, comparison.b_selection_s),
        ),
        comparison,
    })
}

fn write(path: &PathBuf, text: &str) -> anyhow::Result<()> {
    std::fs::write(path, text).with_context(|| format!("cannot write {}", path.display()))
}

/// The search's result in words and a table.
fn search_text(found: &SearchResult, designed: &Analysis, before: &Analysis, name: &str) -> String {
    let mut out = format!(
        "{} partial libraries in {:.1} s: {}\n",
        found.nodes,
        found.seconds,
        if found.complete {
            "the whole space searched, this is the least cost there is".to_string()
        } else {
            format!(
                "time ran out; no library costs less than {:.0} ms, this one is within {:.2} % of that",
                found.bound_ms,
                found.gap_pct()
            )
        }
    );
    out += &format!(
        "cost per selection: {} {:.0} ms, designed {:.0} ms ({:.1} % less); wrong selections per attempt {:.2} % → {:.2} %\n\n",
        name,
        before.expected_ms_per_selection,
        designed.expected_ms_per_selection,
        100.0 * (1.0 - designed.expected_ms_per_selection / before.expected_ms_per_selection),
        100.0 * before.p_wrong_per_selection,
        100.0 * designed.p_wrong_per_selection
    );
    out += &format!("{}\n\n", verdict(designed, before, name));
    out += &analysis::text(designed);
    out
}

/// Whether the designed library is worth the change, in words: under
/// 2 % faster and under a quarter fewer wrong selections is not.
fn verdict(designed: &Analysis, before: &Analysis, name: &str) -> String {
    let faster = 1.0 - designed.expected_ms_per_selection / before.expected_ms_per_selection;
    let fewer_wrong =
        1.0 - designed.p_wrong_per_selection / before.p_wrong_per_selection.max(1e-12);
    if faster < NEAR_OPTIMAL && fewer_wrong < 0.25 {
        format!(
            "{name} is already near-optimal for this user: within {:.1} % of the least cost there is; keep it",
            100.0 * faster.max(0.0)
        )
    } else {
        format!(
            "the designed library is {:.1} % faster and {:.0} % less often wrong than {name}",
            100.0 * faster,
            100.0 * fewer_wrong
        )
    }
}

/// A designed library less than this much faster is not worth relearning.
const NEAR_OPTIMAL: f64 = 0.02;
