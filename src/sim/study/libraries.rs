//! Two libraries in the study, paired: the same simulated participants
//! do the same three tasks with sequence matching, once with each
//! library (the same seeds, so only the library differs), and the task
//! times are compared with a two-tailed Wilcoxon signed-rank test.

use serde::Serialize;

use crate::config::{Config, ConfigErrors};
use crate::control::selection::Interface;
use crate::sim::study::stats::{Tail, mean, wilcoxon_signed_rank};
use crate::sim::study::tasks::TASKS;
use crate::sim::user::{TaskRun, UserModel, run_task};

/// One task with both libraries.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TaskPair {
    /// 1, 2 or 3.
    pub task: u8,
    /// Mean completion time with the first library, s.
    pub a_mean_s: f64,
    /// With the second, s.
    pub b_mean_s: f64,
    /// The second lower than the first by this, percent.
    pub reduction_pct: f64,
    /// Two-tailed Wilcoxon signed-rank p-value on the paired times
    /// (normal approximation).
    pub p_value: f64,
    /// The same, exact.
    pub p_exact: f64,
    /// Wrong selections with the first, all participants.
    pub a_wrong: u32,
    /// With the second.
    pub b_wrong: u32,
}

/// The comparison over the three tasks.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LibraryComparison {
    /// Participants.
    pub users: usize,
    /// The seed.
    pub seed: u64,
    /// Per task.
    pub tasks: Vec<TaskPair>,
    /// Mean time per mode change with the first library, deciding to
    /// entering, s.
    pub a_selection_s: f64,
    /// With the second, s.
    pub b_selection_s: f64,
    /// Every run with the first library, task by task.
    #[serde(skip)]
    pub a_runs: Vec<Vec<TaskRun>>,
    /// With the second.
    #[serde(skip)]
    pub b_runs: Vec<Vec<TaskRun>>,
}

/// Runs `users` participants drawn from `population` through the three
/// tasks with `a`'s and `b`'s library (sequence matching). Both must
/// select every mode the tasks need ([`missing_modes`] is empty).
///
/// [`missing_modes`]: crate::sim::study::missing_modes
pub fn compare(
    a: &Config,
    b: &Config,
    population: &UserModel,
    users: usize,
    seed: u64,
) -> Result<LibraryComparison, ConfigErrors> {
    let a = a.clone().with_interface(Interface::Asp)?;
    let b = b.clone().with_interface(Interface::Asp)?;
    let participants: Vec<UserModel> = (0..users)
        .map(|u| population.participant(seed ^ (u as u64 + 1) << 32))
        .collect();
    let mut tasks = Vec::new();
    let (mut a_runs, mut b_runs) = (Vec::new(), Vec::new());
    for task in &TASKS {
        let run = |config: &Config| -> Vec<TaskRun> {
            participants
                .iter()
                .enumerate()
                .map(|(u, user)| {
                    let run_seed = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15)
                        ^ (u as u64) << 20
                        ^ u64::from(task.number) << 8;
                    run_task(config, task, user, run_seed)
                })
                .collect()
        };
        let (ra, rb) = (run(&a), run(&b));
        let times = |runs: &[TaskRun]| runs.iter().map(|r| r.completion_s).collect::<Vec<_>>();
        let (ta, tb) = (times(&ra), times(&rb));
        let test = wilcoxon_signed_rank(&ta, &tb, Tail::TwoSided);
        tasks.push(TaskPair {
            task: task.number,
            a_mean_s: mean(&ta),
            b_mean_s: mean(&tb),
            reduction_pct: 100.0 * (1.0 - mean(&tb) / mean(&ta)),
            p_value: test.map_or(1.0, |t| t.p_normal),
            p_exact: test.and_then(|t| t.p_exact).unwrap_or(1.0),
            a_wrong: ra.iter().map(|r| r.wrong_selections).sum(),
            b_wrong: rb.iter().map(|r| r.wrong_selections).sum(),
        });
        a_runs.push(ra);
        b_runs.push(rb);
    }
    let per_selection = |runs: &[Vec<TaskRun>]| {
        let all = runs.iter().flatten();
        let s: f64 = all.clone().map(|r| r.selecting_s).sum();
        let n: u32 = all.map(|r| r.selections_timed).sum();
        s / f64::from(n.max(1))
    };
    Ok(LibraryComparison {
        users,
        seed,
        a_selection_s: per_selection(&a_runs),
        b_selection_s: per_selection(&b_runs),
        tasks,
        a_runs,
        b_runs,
    })
}

/// The comparison as a Markdown table; `names` are the two libraries'.
pub fn text(c: &LibraryComparison, names: (&str, &str)) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "| task | {} s | {} s | lower by | p two-tailed (exact) | wrong selections |",
        names.0, names.1
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|");
    for t in &c.tasks {
        let _ = writeln!(
            out,
            "| {} | {:.1} | {:.1} | {:.1} % | {:.3} ({:.3}) | {} → {} |",
            t.task,
            t.a_mean_s,
            t.b_mean_s,
            t.reduction_pct,
            t.p_value,
            t.p_exact,
            t.a_wrong,
            t.b_wrong
        );
    }
    let _ = writeln!(
        out,
        "\n{} simulated participants (seed {}), the same seeds with both; per mode change {:.2} s → {:.2} s",
        c.users, c.seed, c.a_selection_s, c.b_selection_s
    );
    out
}

/// The mean of `per_entry` over the mode changes of the three tasks,
/// each change counted once (entries by their index in `library`).
pub fn mean_over_task_selections(
    library: &[crate::control::selection::SequenceEntry],
    per_entry: impl Fn(usize) -> f64,
) -> f64 {
    let values: Vec<f64> = TASKS
        .iter()
        .flat_map(|t| t.mode_changes())
        .filter_map(|mode| library.iter().position(|e| e.target.mode() == Some(mode)))
        .map(per_entry)
        .collect();
    mean(&values)
}
