//! `sipnpuff study`: the paper's experiment in simulation. Simulated
//! participants do the paper's three tasks with both selection interfaces
//! (ASP, sequence matching; BSP, Kinova-style scanning), through the same
//! production core and simulated arm; completion and moving times are
//! compared as the paper did, with Wilcoxon signed-rank tests on the paired
//! times, side by side with the paper's figures.

pub mod atypical;
pub mod fit_paper;
pub mod head;
pub mod libraries;
pub mod plot;
pub mod stats;
pub mod tasks;

use serde::Serialize;

use crate::config::{Config, ConfigError, ConfigErrors};
use crate::control::mode::Mode;
use crate::control::selection::Interface;
use crate::control::selection::scanning::ScanningConfig;
use crate::sim::user::{TaskRun, UserModel, run_task};
use stats::{Tail, mean, sample_sd, wilcoxon_signed_rank};
use tasks::{TASKS, Task};

/// What the paper reports (8 participants).
pub mod paper {
    /// Participants.
    pub const PARTICIPANTS: usize = 8;
    /// ASP completion times lower than BSP's, percent, tasks 1–3.
    pub const REDUCTION_PCT: [f64; 3] = [35.0, 30.0, 42.0];
    /// One-tailed Wilcoxon signed-rank p-value, each task.
    pub const P_VALUE: f64 = 5.86e-3;
    /// Two-tailed Wilcoxon p-value on the moving times.
    pub const MOVING_TIME_P_VALUE: f64 = 0.433;
}

/// How to run the study.
#[derive(Debug, Clone, Copy)]
pub struct StudyOptions {
    /// Simulated participants.
    pub users: usize,
    /// Seed: the same seed gives the same study.
    pub seed: u64,
    /// The population the participants are drawn from.
    pub population: UserModel,
}

impl Default for StudyOptions {
    fn default() -> Self {
        StudyOptions {
            users: paper::PARTICIPANTS,
            seed: 1,
            population: UserModel::POPULATION,
        }
    }
}

/// One task's runs, one per participant and interface (same order).
#[derive(Debug, Clone)]
pub struct TaskResults {
    /// The task.
    pub task: Task,
    /// ASP runs, by participant.
    pub asp: Vec<TaskRun>,
    /// BSP runs, by participant.
    pub bsp: Vec<TaskRun>,
}

/// One task's comparison.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TaskSummary {
    /// 1, 2 or 3.
    pub task: u8,
    /// ASP completion time, mean and SD, s.
    pub asp_mean_s: f64,
    /// See `asp_mean_s`.
    pub asp_sd_s: f64,
    /// BSP completion time, mean and SD, s.
    pub bsp_mean_s: f64,
    /// See `bsp_mean_s`.
    pub bsp_sd_s: f64,
    /// ASP's mean completion time lower than BSP's by this, percent.
    pub reduction_pct: f64,
    /// One-tailed Wilcoxon signed-rank p-value (BSP > ASP), the normal
    /// approximation as the paper's figures are.
    pub p_value: f64,
    /// The same test, exact.
    pub p_exact: f64,
    /// Two-tailed Wilcoxon p-value on the moving times (normal
    /// approximation).
    pub moving_time_p_value: f64,
    /// Mean moving time with ASP, s.
    pub asp_moving_mean_s: f64,
    /// Mean moving time with BSP, s.
    pub bsp_moving_mean_s: f64,
    /// Runs that hit the simulation's time cap (never expected).
    pub timed_out: usize,
    /// ASP: selections started in command mode by a slip, all runs.
    pub asp_slips: u32,
    /// ASP: selections started in command mode on purpose (motion onset).
    pub asp_direct_switches: u32,
    /// ASP: motion commanded by the breaths of a selection (braking
    /// included), mm, all runs.
    pub asp_unintended_mm: f64,
    /// The same per slip (0 without slips).
    pub asp_unintended_mm_per_slip: f64,
}

impl TaskResults {
    /// The comparison, as the paper made it.
    pub fn summary(&self) -> TaskSummary {
        let times = |runs: &[TaskRun]| runs.iter().map(|r| r.completion_s).collect::<Vec<_>>();
        let moving = |runs: &[TaskRun]| runs.iter().map(|r| r.moving_s).collect::<Vec<_>>();
        let (asp, bsp) = (times(&self.asp), times(&self.bsp));
        let completion = wilcoxon_signed_rank(&bsp, &asp, Tail::Greater);
        let moved = wilcoxon_signed_rank(&moving(&self.asp), &moving(&self.bsp), Tail::TwoSided);
        TaskSummary {
            task: self.task.number,
            asp_mean_s: mean(&asp),
            asp_sd_s: sample_sd(&asp),
            bsp_mean_s: mean(&bsp),
            bsp_sd_s: sample_sd(&bsp),
            reduction_pct: 100.0 * (1.0 - mean(&asp) / mean(&bsp)),
            p_value: completion.map_or(1.0, |t| t.p_normal),
            p_exact: completion.and_then(|t| t.p_exact).unwrap_or(1.0),
            moving_time_p_value: moved.map_or(1.0, |t| t.p_normal),
            asp_moving_mean_s: mean(&moving(&self.asp)),
            bsp_moving_mean_s: mean(&moving(&self.bsp)),
            timed_out: self
                .asp
                .iter()
                .chain(&self.bsp)
                .filter(|r| r.timed_out)
                .count(),
            asp_slips: self.asp.iter().map(|r| r.slips).sum(),
            asp_direct_switches: self.asp.iter().map(|r| r.direct_switches).sum(),
            asp_unintended_mm: self.asp.iter().map(|r| r.unintended_mm).sum(),
            asp_unintended_mm_per_slip: {
                let slips: u32 = self.asp.iter().map(|r| r.slips).sum();
                let mm: f64 = self.asp.iter().map(|r| r.unintended_mm).sum();
                if slips == 0 {
                    0.0
                } else {
                    mm / f64::from(slips)
                }
            },
        }
    }
}

/// The seed of one run: participant, task and interface apart.
fn run_seed(seed: u64, user: usize, task: u8, interface: Interface) -> u64 {
    let i = match interface {
        Interface::Asp => 1,
        Interface::Bsp => 2,
    };
    seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ (user as u64) << 20 ^ u64::from(task) << 8 ^ i
}

/// Runs every participant through every task with both interfaces.
/// `progress(done, total)` after each run. Refuses, before any run, a
/// configuration that cannot select every mode the tasks need (the
/// simulated user would wait for it until the time cap).
pub fn run_study(
    config: &Config,
    options: &StudyOptions,
    mut progress: impl FnMut(usize, usize),
) -> Result<Vec<TaskResults>, ConfigErrors> {
    let asp = config.clone().with_interface(Interface::Asp)?;
    let bsp = config.clone().with_interface(Interface::Bsp)?;
    check_modes(config)?;
    let total = TASKS.len() * options.users * 2;
    let mut done = 0;
    let mut tick = || {
        done += 1;
        progress(done, total);
    };
    let asp_runs = run_interface(&asp, options, &mut tick);
    let bsp_runs = run_interface(&bsp, options, &mut tick);
    Ok(TASKS
        .iter()
        .zip(asp_runs.into_iter().zip(bsp_runs))
        .map(|(task, (asp, bsp))| TaskResults {
            task: *task,
            asp,
            bsp,
        })
        .collect())
}

/// The participants of a study, drawn from its population.
fn participants(options: &StudyOptions) -> Vec<UserModel> {
    (0..options.users)
        .map(|u| {
            options
                .population
                .participant(options.seed ^ (u as u64 + 1) << 32)
        })
        .collect()
}

/// Every participant through every task on `config`'s interface: the runs
/// by task, then participant. `run_done()` after each run.
fn run_interface(
    config: &Config,
    options: &StudyOptions,
    mut run_done: impl FnMut(),
) -> Vec<Vec<TaskRun>> {
    let interface = config.core().interface();
    let participants = participants(options);
    TASKS
        .iter()
        .map(|task| {
            participants
                .iter()
                .enumerate()
                .map(|(u, user)| {
                    let run = run_task(
                        config,
                        task,
                        user,
                        run_seed(options.seed, u, task.number, interface),
                    );
                    run_done();
                    run
                })
                .collect()
        })
        .collect()
}

/// The modes the study's tasks need, in [`Mode::ALL`]'s order.
pub fn task_modes() -> Vec<Mode> {
    Mode::ALL
        .into_iter()
        .filter(|m| TASKS.iter().any(|t| t.steps.iter().any(|s| s.mode == *m)))
        .collect()
}

/// The modes the tasks need that `config` cannot select with
/// `interface`: ASP, those without a sequence in the library; BSP, those
/// not in the scan order.
pub fn missing_modes(config: &Config, interface: Interface) -> Vec<Mode> {
    let core = config.core();
    task_modes()
        .into_iter()
        .filter(|mode| match interface {
            Interface::Asp => !core
                .sequences()
                .iter()
                .any(|e| e.target.mode() == Some(*mode)),
            Interface::Bsp => !core.scanning().modes().contains(mode),
        })
        .collect()
}

/// Every mode the tasks need selectable with both interfaces, or an error
/// per interface naming the modes missing.
fn check_modes(config: &Config) -> Result<(), ConfigErrors> {
    let names = |modes: &[Mode]| {
        modes
            .iter()
            .map(|m| m.name())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let needed = names(&task_modes());
    let mut errors = Vec::new();
    for (interface, key, what) in [
        (Interface::Asp, "sequence", "no sequence in the library for"),
        (
            Interface::Bsp,
            "scanning.order",
            "the scan never highlights",
        ),
    ] {
        let missing = missing_modes(config, interface);
        if !missing.is_empty() {
            errors.push(ConfigError {
                key: key.into(),
                line: None,
                column: None,
                message: format!(
                    "{what} {}: the study's tasks need {needed}",
                    names(&missing)
                ),
            });
        }
    }
    if errors.is_empty() {
        Ok(())
    } else {
        Err(ConfigErrors(errors))
    }
}

/// The `--json` report: each task's comparison and every run, beside the
/// paper's figures.
#[derive(Debug, Clone, Serialize)]
pub struct StudyReport {
    /// Simulated participants.
    pub users: usize,
    /// The seed.
    pub seed: u64,
    /// Tasks 1–3.
    pub tasks: Vec<TaskReport>,
    /// What the paper reports.
    pub paper: PaperFigures,
}

/// One task in the `--json` report.
#[derive(Debug, Clone, Serialize)]
pub struct TaskReport {
    /// The comparison.
    #[serde(flatten)]
    pub summary: TaskSummary,
    /// ASP completion times by participant, s.
    pub asp_completion_s: Vec<f64>,
    /// BSP completion times by participant, s.
    pub bsp_completion_s: Vec<f64>,
    /// Every ASP run, by participant.
    pub asp_runs: Vec<TaskRun>,
    /// Every BSP run, by participant.
    pub bsp_runs: Vec<TaskRun>,
}

/// The paper's figures, as [`paper`] has them.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct PaperFigures {
    /// Participants.
    pub participants: usize,
    /// ASP completion times lower than BSP's, percent, tasks 1–3.
    pub reduction_pct: [f64; 3],
    /// One-tailed Wilcoxon signed-rank p-value, each task.
    pub p_value: f64,
    /// Two-tailed Wilcoxon p-value on the moving times.
    pub moving_time_p_value: f64,
}

impl StudyReport {
    /// The report of a study's results.
    pub fn of(results: &[TaskResults], options: &StudyOptions) -> StudyReport {
        let completion = |runs: &[TaskRun]| runs.iter().map(|t| t.completion_s).collect();
        StudyReport {
            users: options.users,
            seed: options.seed,
            tasks: results
                .iter()
                .map(|r| TaskReport {
                    summary: r.summary(),
                    asp_completion_s: completion(&r.asp),
                    bsp_completion_s: completion(&r.bsp),
                    asp_runs: r.asp.clone(),
                    bsp_runs: r.bsp.clone(),
                })
                .collect(),
            paper: PaperFigures {
                participants: paper::PARTICIPANTS,
                reduction_pct: paper::REDUCTION_PCT,
                p_value: paper::P_VALUE,
                moving_time_p_value: paper::MOVING_TIME_P_VALUE,
            },
        }
    }
}

/// The text report: per task, the simulation beside the paper.
pub fn study_text(results: &[TaskResults], options: &StudyOptions) -> String {
    let users = options.users;
    let mut out = format!(
        "{users} simulated participants (seed {}), both interfaces through the production core and simulated arm\n\n",
        options.seed
    );
    out += "| task | ASP s (mean ± SD) | BSP s (mean ± SD) | ASP lower by | paper | p one-tailed (exact) | paper p | moving time ASP / BSP s | p two-tailed | paper p |\n";
    out += "|---|---|---|---|---|---|---|---|---|---|\n";
    for (r, paper_pct) in results.iter().zip(paper::REDUCTION_PCT) {
        let s = r.summary();
        out += &format!(
            "| {} | {:.1} ± {:.1} | {:.1} ± {:.1} | {:.0} % | {paper_pct:.0} % | {:.2e} ({:.2e}) | {:.2e} | {:.1} / {:.1} | {:.3} | {:.3} |\n",
            s.task,
            s.asp_mean_s,
            s.asp_sd_s,
            s.bsp_mean_s,
            s.bsp_sd_s,
            s.reduction_pct,
            s.p_value,
            s.p_exact,
            paper::P_VALUE,
            s.asp_moving_mean_s,
            s.bsp_moving_mean_s,
            s.moving_time_p_value,
            paper::MOVING_TIME_P_VALUE,
        );
        if s.timed_out > 0 {
            out += &format!("  ({} runs hit the time cap)\n", s.timed_out);
        }
    }
    let errors = |pick: fn(&TaskResults) -> &Vec<TaskRun>| {
        let runs: Vec<&TaskRun> = results.iter().flat_map(|r| pick(r).iter()).collect();
        let wrong: u32 = runs.iter().map(|r| r.wrong_selections).sum();
        let retries: u32 = runs.iter().map(|r| r.retries).sum();
        let selections: u32 = runs.iter().map(|r| r.selections).sum();
        (selections, wrong, retries)
    };
    let (s, w, r) = errors(|t| &t.asp);
    out += &format!("\nASP: {s} modes entered, {w} wrong, {r} sequences reset and entered again\n");
    let (s, w, r) = errors(|t| &t.bsp);
    out += &format!("BSP: {s} modes entered, {w} wrong, {r} target highlights let pass\n");
    out
}

/// A parameter `study --sweep` varies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SweepParam {
    /// BSP's dwell per mode (the first mode twice as long).
    BspDwell,
    /// ASP's sequence timeout.
    AspTimeout,
    /// The users' error rate.
    ErrorRate,
    /// The sequence library: prefix-free (built-in) or with prefixes.
    Library,
    /// `command.motion_onset_ms` (off, 300, 450, 600, 1300 ms), with users who
    /// slip (start a selection before the return to detection mode) at
    /// 20 % of their mode changes, and without slips for reference.
    MotionOnset,
}

impl SweepParam {
    /// `bsp-dwell`, `asp-timeout`, `error-rate`, `library` or
    /// `motion-onset`.
    pub const fn name(self) -> &'static str {
        match self {
            SweepParam::BspDwell => "bsp-dwell",
            SweepParam::AspTimeout => "asp-timeout",
            SweepParam::ErrorRate => "error-rate",
            SweepParam::Library => "library",
            SweepParam::MotionOnset => "motion-onset",
        }
    }
}

/// A 9-mode library in the style of the paper's example, where short
/// sequences are prefixes of longer ones (so each needs the timeout).
pub const PREFIX_LIBRARY: &str = r#"
[[sequence]]
actions = [-1]
mode = "translate_x"
[[sequence]]
actions = [-1, -1]
mode = "translate_y"
[[sequence]]
actions = [-1, 1]
mode = "translate_z"
[[sequence]]
actions = [1]
mode = "rotate_x"
[[sequence]]
actions = [1, 1]
mode = "rotate_y"
[[sequence]]
actions = [1, -1]
mode = "rotate_z"
[[sequence]]
actions = [-2]
mode = "fingers"
[[sequence]]
actions = [2]
mode = "save_point"
[[sequence]]
actions = [2, 2]
mode = "goto_point"
"#;

/// `config` with [`PREFIX_LIBRARY`] as its library.
fn prefix_library(config: &Config) -> Result<Config, ConfigErrors> {
    let library = Config::from_toml_str(PREFIX_LIBRARY)?;
    config
        .clone()
        .with_sequences(library.core().sequences().to_vec())
}

/// The slip rate of the motion-onset sweep: one mode change in five.
pub const SLIP_RATE: f64 = 0.2;

/// One row of a sweep: the value and each task's summary.
#[derive(Debug, Clone, Serialize)]
pub struct SweepRow {
    /// The value, as printed.
    pub value: String,
    /// Tasks 1–3.
    pub tasks: Vec<TaskSummary>,
}

/// Runs the study at each value of `param`.
pub fn sweep(
    config: &Config,
    options: &StudyOptions,
    param: SweepParam,
    mut progress: impl FnMut(&str, usize, usize),
) -> Result<Vec<SweepRow>, ConfigErrors> {
    let mut settings: Vec<(String, Config, StudyOptions)> = Vec::new();
    match param {
        SweepParam::BspDwell => {
            for dwell in [750, 1000, 1500, 2000, 2500] {
                let scanning = ScanningConfig {
                    dwell_ms: dwell,
                    first_dwell_ms: 2 * dwell,
                    ..*config.core().scanning()
                };
                settings.push((
                    format!("{dwell} ms"),
                    config.clone().with_scanning(scanning)?,
                    *options,
                ));
            }
        }
        SweepParam::AspTimeout => {
            // On the library with prefixes: with a prefix-free one the
            // timeout only matters after a mistake.
            let prefixes = prefix_library(config)?;
            for ms in [500, 750, 1000, 1500, 2000] {
                settings.push((
                    format!("{ms} ms (library with prefixes)"),
                    prefixes.clone().with_sequence_timeout_ms(ms)?,
                    *options,
                ));
            }
        }
        SweepParam::ErrorRate => {
            for rate in [0.0, 0.05, 0.1, 0.2, 0.3] {
                let mut o = *options;
                o.population.error_rate = rate;
                settings.push((format!("{rate:.2}"), config.clone(), o));
            }
        }
        SweepParam::Library => {
            settings.push(("prefix-free (built-in)".into(), config.clone(), *options));
            settings.push(("with prefixes".into(), prefix_library(config)?, *options));
        }
        SweepParam::MotionOnset => {
            for (onset, slip) in [
                (0, 0.0),
                (0, SLIP_RATE),
                (300, SLIP_RATE),
                (450, SLIP_RATE),
                (600, SLIP_RATE),
                (1300, SLIP_RATE),
            ] {
                let mut o = *options;
                o.population.slip_rate = slip;
                let onset_name = if onset == 0 {
                    "off".to_string()
                } else {
                    format!("{onset} ms")
                };
                settings.push((
                    format!("{onset_name}, slips {:.0} %", slip * 100.0),
                    config.clone().with_motion_onset_ms(onset)?,
                    o,
                ));
            }
        }
    }
    let count = settings.len();
    let mut rows = Vec::with_capacity(count);
    for (i, (value, config, o)) in settings.into_iter().enumerate() {
        let label = format!("{} ({}/{count})", value, i + 1);
        let results = run_study(&config, &o, |done, total| progress(&label, done, total))?;
        rows.push(SweepRow {
            value,
            tasks: results.iter().map(TaskResults::summary).collect(),
        });
    }
    Ok(rows)
}

/// The sweep as a Markdown table.
pub fn sweep_text(param: SweepParam, rows: &[SweepRow]) -> String {
    if param == SweepParam::MotionOnset {
        return onset_text(rows);
    }
    let param_name = param.name();
    let mut out = format!(
        "| {param_name} | task 1 ASP / BSP s | lower by | task 2 ASP / BSP s | lower by | task 3 ASP / BSP s | lower by |\n|---|---|---|---|---|---|---|\n"
    );
    for row in rows {
        out += &format!("| {} |", row.value);
        for s in &row.tasks {
            out += &format!(
                " {:.1} / {:.1} | {:.0} % |",
                s.asp_mean_s, s.bsp_mean_s, s.reduction_pct
            );
        }
        out.push('\n');
    }
    out
}

/// The motion-onset sweep: ASP completion times, and per slip the motion
/// nobody wanted.
fn onset_text(rows: &[SweepRow]) -> String {
    let mut out = String::from(
        "| motion onset | task 1 ASP s | task 2 ASP s | task 3 ASP s | slips | direct switches | unintended motion per slip, mm | unintended motion in all, mm |\n|---|---|---|---|---|---|---|---|\n",
    );
    for row in rows {
        out += &format!("| {} |", row.value);
        for s in &row.tasks {
            out += &format!(" {:.1} ± {:.1} |", s.asp_mean_s, s.asp_sd_s);
        }
        let slips: u32 = row.tasks.iter().map(|s| s.asp_slips).sum();
        let direct: u32 = row.tasks.iter().map(|s| s.asp_direct_switches).sum();
        let mm: f64 = row.tasks.iter().map(|s| s.asp_unintended_mm).sum();
        let per_slip = if slips == 0 {
            0.0
        } else {
            mm / f64::from(slips)
        };
        out += &format!(" {slips} | {direct} | {per_slip:.1} | {mm:.0} |\n");
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_prefix_library_is_valid_and_has_prefixes() {
        let config = Config::from_toml_str(PREFIX_LIBRARY).unwrap();
        assert_eq!(config.core().sequences().len(), 9);
        let seqs = config.core().sequences();
        let prefixes = seqs
            .iter()
            .filter(|a| {
                seqs.iter().any(|b| {
                    b.actions.len() > a.actions.len()
                        && b.actions.as_slice().starts_with(a.actions.as_slice())
                })
            })
            .count();
        assert_eq!(prefixes, 3);
    }
}
