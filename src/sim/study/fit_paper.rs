//! `sipnpuff study --fit-paper`: the scanning interface's (BSP's) free
//! parameters fitted to the paper's figures. The paper gives BSP's
//! reductions (35, 30, 42 %) and p-values but neither its scan timing nor
//! how often its participants missed a mode; the fit finds the scan dwell,
//! the first dwell (as a factor of the dwell) and the users' miss rate that
//! make the simulated study report the paper's reductions.
//!
//! Every evaluation runs the same participants with the same seeds (common
//! random numbers), so two parameter sets differ by their effect, not by
//! noise; ASP does not depend on these parameters and runs once. The
//! optimiser is plain and deterministic: a coarse grid, then a compass
//! search from its best point (each of the six neighbours at ± a step,
//! evaluated in parallel; move to the best if it is better, else halve the
//! steps).

use std::collections::BTreeMap;

use serde::Serialize;

use super::stats::mean;
use super::tasks::TASKS;
use super::{StudyOptions, TaskResults, TaskSummary, check_modes, paper, run_interface};
use crate::config::{Config, ConfigErrors};
use crate::control::selection::Interface;
use crate::control::selection::scanning::ScanningConfig;
use crate::sim::user::TaskRun;

/// The BSP parameters the fit varies.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BspParams {
    /// How long each mode stays highlighted, ms (`scanning.dwell_ms`).
    pub dwell_ms: f64,
    /// The first mode's dwell when scanning (re)starts, as a factor of
    /// `dwell_ms` (`scanning.first_dwell_ms`).
    pub first_dwell_factor: f64,
    /// Chance that a user lets the target's highlight pass
    /// (`UserModel::miss_rate`).
    pub miss_rate: f64,
}

/// Where the fit looks: dwell, first-dwell factor, miss rate.
const LOWER: [f64; 3] = [250.0, 1.0, 0.0];
/// See [`LOWER`].
const UPPER: [f64; 3] = [3000.0, 4.0, 0.5];

impl BspParams {
    /// The built-in values: `config`'s scan and `miss_rate`.
    pub fn of(config: &Config, miss_rate: f64) -> BspParams {
        let scanning = config.core().scanning();
        BspParams {
            dwell_ms: f64::from(scanning.dwell_ms),
            first_dwell_factor: f64::from(scanning.first_dwell_ms)
                / f64::from(scanning.dwell_ms.max(1)),
            miss_rate,
        }
    }

    fn to_array(self) -> [f64; 3] {
        [self.dwell_ms, self.first_dwell_factor, self.miss_rate]
    }

    /// Inside the search box, at the resolution the study sees (whole
    /// milliseconds; the miss rate to 10⁻⁴).
    fn from_array(a: [f64; 3]) -> BspParams {
        let c = |i: usize| a[i].clamp(LOWER[i], UPPER[i]);
        let dwell_ms = c(0).round();
        let first_dwell_ms = (c(1) * dwell_ms).round();
        BspParams {
            dwell_ms,
            first_dwell_factor: first_dwell_ms / dwell_ms,
            miss_rate: (c(2) * 1e4).round() / 1e4,
        }
    }

    /// The cache key: what the simulation actually receives.
    fn key(self) -> (u32, u32, u32) {
        (
            self.dwell_ms as u32,
            (self.first_dwell_factor * self.dwell_ms).round() as u32,
            (self.miss_rate * 1e4).round() as u32,
        )
    }
}

/// What the fit aims at.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Targets {
    /// ASP lower than BSP by, percent, tasks 1–3.
    pub reduction_pct: [f64; 3],
    /// One-tailed Wilcoxon p-value, each task.
    pub p_value: f64,
}

impl Targets {
    /// The paper's figures.
    pub const PAPER: Targets = Targets {
        reduction_pct: paper::REDUCTION_PCT,
        p_value: paper::P_VALUE,
    };
}

/// Where the fit starts and when it stops.
#[derive(Debug, Clone, PartialEq)]
pub struct FitPlan {
    /// The coarse grid: every combination of these is evaluated.
    pub grid: [Vec<f64>; 3],
    /// The compass search's first steps (dwell ms, factor, miss rate).
    pub steps: [f64; 3],
    /// It stops once every step is below these.
    pub min_steps: [f64; 3],
    /// Steps of the central differences for the uncertainty: wide enough
    /// to average over the discrete misses that make the reductions jump
    /// by a point or two from one millisecond of dwell to the next.
    pub difference_steps: [f64; 3],
    /// Threads evaluating at once.
    pub threads: usize,
}

impl Default for FitPlan {
    fn default() -> Self {
        FitPlan {
            grid: [
                vec![500.0, 750.0, 1000.0, 1250.0, 1500.0],
                vec![1.0, 2.0, 3.0],
                vec![0.0, 0.15, 0.3],
            ],
            steps: [125.0, 0.5, 0.075],
            min_steps: [10.0, 0.05, 0.01],
            difference_steps: [150.0, 0.5, 0.05],
            threads: std::thread::available_parallelism().map_or(1, |n| n.get().min(2)),
        }
    }
}

/// A fitted value and its uncertainty.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Estimate {
    /// The fitted value.
    pub value: f64,
    /// One standard deviation, linearised (see [`FitReport::fit`]);
    /// infinite (`null` in JSON) when the figures do not constrain it.
    pub uncertainty: f64,
}

/// The fitted parameters.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FittedParams {
    /// `scanning.dwell_ms`.
    pub dwell_ms: Estimate,
    /// `scanning.first_dwell_ms` / `scanning.dwell_ms`.
    pub first_dwell_factor: Estimate,
    /// `UserModel::miss_rate`.
    pub miss_rate: Estimate,
}

/// One task of the fitted study beside the paper.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FitTask {
    /// 1, 2 or 3.
    pub task: u8,
    /// Mean ASP completion time, s.
    pub asp_mean_s: f64,
    /// Mean BSP completion time with the fitted parameters, s.
    pub bsp_mean_s: f64,
    /// ASP lower than BSP by, percent.
    pub reduction_pct: f64,
    /// Its standard error over the participants (delta method), percentage
    /// points: how far 8 participants' figure can fall from the mean.
    pub reduction_se_pct: f64,
    /// The paper's.
    pub paper_reduction_pct: f64,
    /// `reduction_pct` − `paper_reduction_pct`, percentage points.
    pub residual_pct: f64,
    /// One-tailed Wilcoxon p-value (normal approximation, as the paper's).
    pub p_value: f64,
    /// The paper's.
    pub paper_p_value: f64,
    /// Two-tailed Wilcoxon p-value on the moving times.
    pub moving_time_p_value: f64,
}

/// `study --fit-paper`'s report.
#[derive(Debug, Clone, Serialize)]
pub struct FitReport {
    /// Simulated participants.
    pub users: usize,
    /// The seed (the same for every evaluation).
    pub seed: u64,
    /// The fitted parameters. Uncertainty: one standard deviation of the
    /// parameters that would reproduce reductions off by the study's own
    /// standard errors (Gauss–Newton curvature, `(JᵀWJ)⁻¹` with `J` the
    /// reductions' central differences at the fit and `W` the inverse
    /// squared standard errors).
    pub fit: FittedParams,
    /// Correlation of the fitted parameters (dwell, factor, miss), from the
    /// same matrix: near ±1, the figures fix a combination, not each.
    pub correlation: [[f64; 3]; 3],
    /// The built-in values.
    pub builtin: BspParams,
    /// Tasks 1–3 with the fitted parameters.
    pub tasks: Vec<FitTask>,
    /// The paper's two-tailed moving-time p-value (one for all tasks).
    pub paper_moving_time_p_value: f64,
    /// The objective at the fit: squared residuals, pp², plus the p-value
    /// term.
    pub objective: f64,
    /// Studies run (BSP halves; ASP once).
    pub evaluations: usize,
}

/// One evaluated parameter set.
#[derive(Debug, Clone)]
struct Evaluation {
    params: BspParams,
    results: Vec<TaskResults>,
    summaries: Vec<TaskSummary>,
    objective: f64,
}

/// One decade of p-value counts as 10 percentage points of reduction.
const P_WEIGHT: f64 = 10.0;

/// Squared residuals of the reductions, pp², plus `P_WEIGHT`² per squared
/// decade between each task's p and the target. The reductions carry the
/// fit: the paper's p is the smallest the test gives with 8 pairs, reached
/// whenever every participant is faster with ASP, so its term is a penalty
/// against parameters that make some participant faster with BSP, not a
/// figure to trade against the reductions (the smallest pair lost, p
/// 5.86e-3 → 8.65e-3, costs 2.9 pp²).
fn objective(summaries: &[TaskSummary], targets: &Targets) -> f64 {
    summaries
        .iter()
        .zip(targets.reduction_pct)
        .map(|(s, target)| {
            let p = P_WEIGHT * (s.p_value.log10() - targets.p_value.log10());
            (s.reduction_pct - target).powi(2) + p * p
        })
        .sum()
}

/// The study's parts that stay fixed across evaluations.
struct Study<'a> {
    config: &'a Config,
    options: &'a StudyOptions,
    asp: Vec<Vec<TaskRun>>,
    targets: Targets,
}

impl Study<'_> {
    fn evaluate(&self, params: BspParams) -> Result<Evaluation, ConfigErrors> {
        let scanning = ScanningConfig {
            dwell_ms: params.dwell_ms as u32,
            first_dwell_ms: (params.first_dwell_factor * params.dwell_ms).round() as u32,
            ..*self.config.core().scanning()
        };
        let bsp = self
            .config
            .clone()
            .with_interface(Interface::Bsp)?
            .with_scanning(scanning)?;
        let mut options = *self.options;
        options.population.miss_rate = params.miss_rate;
        let bsp_runs = run_interface(&bsp, &options, || {});
        let results: Vec<TaskResults> = TASKS
            .iter()
            .zip(self.asp.iter().zip(bsp_runs))
            .map(|(task, (asp, bsp))| TaskResults {
                task: *task,
                asp: asp.clone(),
                bsp,
            })
            .collect();
        let summaries: Vec<TaskSummary> = results.iter().map(TaskResults::summary).collect();
        Ok(Evaluation {
            params,
            objective: objective(&summaries, &self.targets),
            results,
            summaries,
        })
    }
}

/// Evaluations by what the simulation receives: each parameter set runs
/// once.
struct Cache<'a> {
    study: Study<'a>,
    threads: usize,
    done: BTreeMap<(u32, u32, u32), Evaluation>,
}

impl Cache<'_> {
    /// Evaluates the sets not yet run, `threads` at once, and returns all
    /// of them in order.
    fn evaluate(&mut self, points: &[BspParams]) -> Result<Vec<Evaluation>, ConfigErrors> {
        let mut todo: Vec<BspParams> = Vec::new();
        for p in points {
            if !self.done.contains_key(&p.key()) && !todo.iter().any(|t| t.key() == p.key()) {
                todo.push(*p);
            }
        }
        let threads = self.threads.clamp(1, todo.len().max(1));
        let study = &self.study;
        let evaluated: Vec<Result<Evaluation, ConfigErrors>> = std::thread::scope(|scope| {
            let handles: Vec<_> = (0..threads)
                .map(|t| {
                    let mine: Vec<BspParams> =
                        todo.iter().skip(t).step_by(threads).copied().collect();
                    scope.spawn(move || {
                        mine.into_iter()
                            .map(|p| study.evaluate(p))
                            .collect::<Vec<_>>()
                    })
                })
                .collect();
            handles
                .into_iter()
                .flat_map(|h| h.join().unwrap_or_default())
                .collect()
        });
        for e in evaluated {
            let e = e?;
            self.done.insert(e.params.key(), e);
        }
        points
            .iter()
            .map(|p| {
                self.done.get(&p.key()).cloned().ok_or_else(|| {
                    // Only a panicked worker leaves a point without a result.
                    ConfigErrors(vec![crate::config::ConfigError {
                        key: "(fit)".into(),
                        line: None,
                        column: None,
                        message: "an evaluation of the study failed".into(),
                    }])
                })
            })
            .collect()
    }
}

/// Fits BSP's dwell, first-dwell factor and miss rate so that the study
/// with `options` reports `targets`. `progress(studies)` after each batch
/// of evaluations. Errors: the configuration cannot run the study.
pub fn fit(
    config: &Config,
    options: &StudyOptions,
    targets: &Targets,
    plan: &FitPlan,
    mut progress: impl FnMut(usize),
) -> Result<FitReport, ConfigErrors> {
    check_modes(config)?;
    let asp_config = config.clone().with_interface(Interface::Asp)?;
    let asp = run_interface(&asp_config, options, || {});
    let mut cache = Cache {
        study: Study {
            config,
            options,
            asp,
            targets: *targets,
        },
        threads: plan.threads,
        done: BTreeMap::new(),
    };
    // The grid.
    let mut grid = Vec::new();
    for &d in &plan.grid[0] {
        for &f in &plan.grid[1] {
            for &m in &plan.grid[2] {
                grid.push(BspParams::from_array([d, f, m]));
            }
        }
    }
    let mut best = best_of(cache.evaluate(&grid)?).ok_or_else(empty_grid)?;
    progress(cache.done.len());
    // The compass search.
    let mut steps = plan.steps;
    for _ in 0..64 {
        if steps.iter().zip(plan.min_steps).all(|(s, min)| *s < min) {
            break;
        }
        let centre = best.params.to_array();
        let neighbours: Vec<BspParams> = (0..3)
            .flat_map(|i| {
                [-1.0, 1.0].map(|sign| {
                    let mut a = centre;
                    a[i] += sign * steps[i];
                    BspParams::from_array(a)
                })
            })
            .filter(|p| p.key() != best.params.key())
            .collect();
        let candidate = best_of(cache.evaluate(&neighbours)?);
        progress(cache.done.len());
        match candidate {
            Some(c) if c.objective < best.objective => best = c,
            _ => steps = steps.map(|s| s / 2.0),
        }
    }
    // The curvature at the fit.
    let centre = best.params.to_array();
    let mut differences = Vec::new();
    for i in 0..3 {
        for sign in [-1.0, 1.0] {
            let mut a = centre;
            a[i] += sign * plan.difference_steps[i];
            differences.push(BspParams::from_array(a));
        }
    }
    let around = cache.evaluate(&differences)?;
    progress(cache.done.len());
    let se: Vec<f64> = best.results.iter().map(reduction_se_pct).collect();
    // Central differences (one-sided at the box's edge), in percentage
    // points per difference step: the matrix is then well scaled.
    let h = plan.difference_steps;
    let jacobian: [[f64; 3]; 3] = std::array::from_fn(|t| {
        std::array::from_fn(|i| {
            let (lo, hi) = (&around[2 * i], &around[2 * i + 1]);
            let span = hi.params.to_array()[i] - lo.params.to_array()[i];
            if span > 0.0 {
                (hi.summaries[t].reduction_pct - lo.summaries[t].reduction_pct) / span * h[i]
            } else {
                0.0
            }
        })
    });
    let covariance: Option<[[f64; 3]; 3]> = covariance(&jacobian, &se)
        .map(|c| std::array::from_fn(|i| std::array::from_fn(|j| c[i][j] * h[i] * h[j])));
    let sd: [f64; 3] = std::array::from_fn(|i| {
        let v = covariance.map_or(f64::INFINITY, |c| c[i][i]);
        if v.is_finite() && v >= 0.0 {
            v.sqrt()
        } else {
            f64::INFINITY
        }
    });
    let correlation = std::array::from_fn(|i| {
        std::array::from_fn(|j| match covariance {
            Some(c) if sd[i].is_finite() && sd[j].is_finite() && sd[i] * sd[j] > 0.0 => {
                c[i][j] / (sd[i] * sd[j])
            }
            _ => f64::NAN,
        })
    });
    let estimate = |i: usize| Estimate {
        value: best.params.to_array()[i],
        uncertainty: sd[i],
    };
    Ok(FitReport {
        users: options.users,
        seed: options.seed,
        fit: FittedParams {
            dwell_ms: estimate(0),
            first_dwell_factor: estimate(1),
            miss_rate: estimate(2),
        },
        correlation,
        builtin: BspParams::of(config, options.population.miss_rate),
        tasks: best
            .summaries
            .iter()
            .zip(&se)
            .zip(targets.reduction_pct)
            .map(|((s, se), target)| FitTask {
                task: s.task,
                asp_mean_s: s.asp_mean_s,
                bsp_mean_s: s.bsp_mean_s,
                reduction_pct: s.reduction_pct,
                reduction_se_pct: *se,
                paper_reduction_pct: target,
                residual_pct: s.reduction_pct - target,
                p_value: s.p_value,
                paper_p_value: targets.p_value,
                moving_time_p_value: s.moving_time_p_value,
            })
            .collect(),
        paper_moving_time_p_value: paper::MOVING_TIME_P_VALUE,
        objective: best.objective,
        evaluations: cache.done.len(),
    })
}

fn empty_grid() -> ConfigErrors {
    ConfigErrors(vec![crate::config::ConfigError {
        key: "(fit)".into(),
        line: None,
        column: None,
        message: "the fit's grid is empty".into(),
    }])
}

/// The lowest objective; the first of equals (deterministic).
fn best_of(evaluations: Vec<Evaluation>) -> Option<Evaluation> {
    evaluations.into_iter().reduce(|best, e| {
        if e.objective < best.objective {
            e
        } else {
            best
        }
    })
}

/// The standard error of a task's reduction over its participants, pp:
/// the delta method on `1 − mean(ASP) / mean(BSP)` with paired times.
pub fn reduction_se_pct(results: &TaskResults) -> f64 {
    let a: Vec<f64> = results.asp.iter().map(|r| r.completion_s).collect();
    let b: Vec<f64> = results.bsp.iter().map(|r| r.completion_s).collect();
    let n = a.len().min(b.len());
    if n < 2 {
        return f64::INFINITY;
    }
    let (ma, mb) = (mean(&a), mean(&b));
    let sum: f64 = a
        .iter()
        .zip(&b)
        .map(|(ai, bi)| {
            let psi = -(ai - ma) / mb + ma * (bi - mb) / (mb * mb);
            psi * psi
        })
        .sum();
    100.0 * (sum / (n * (n - 1)) as f64).sqrt()
}

/// `(JᵀWJ)⁻¹` with `W = diag(1/se²)`, or `None` when it is singular.
fn covariance(j: &[[f64; 3]; 3], se: &[f64]) -> Option<[[f64; 3]; 3]> {
    let mut m = [[0.0; 3]; 3];
    for (t, row) in j.iter().enumerate() {
        let w = 1.0 / se.get(t).copied().unwrap_or(f64::INFINITY).powi(2);
        for a in 0..3 {
            for b in 0..3 {
                m[a][b] += row[a] * w * row[b];
            }
        }
    }
    invert(&m)
}

/// The inverse of a 3×3 matrix, or `None` when it is singular (or not
/// finite).
fn invert(m: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let cof = |r: usize, c: usize| {
        let (r1, r2) = ((r + 1) % 3, (r + 2) % 3);
        let (c1, c2) = ((c + 1) % 3, (c + 2) % 3);
        m[r1][c1] * m[r2][c2] - m[r1][c2] * m[r2][c1]
    };
    let det: f64 = (0..3).map(|c| m[0][c] * cof(0, c)).sum();
    let scale: f64 = m.iter().flatten().map(|x| x.abs()).fold(0.0, f64::max);
    if !det.is_finite() || det.abs() <= 1e-9 * scale.powi(3) {
        return None;
    }
    // The adjugate is the transposed cofactor matrix.
    Some(std::array::from_fn(|r| {
        std::array::from_fn(|c| cof(c, r) / det)
    }))
}

/// The text report: the parameters, then the tasks, as Markdown tables.
pub fn fit_text(report: &FitReport) -> String {
    let pm = |e: &Estimate, digits: usize| {
        if e.uncertainty.is_finite() {
            format!("{:.digits$} | ± {:.digits$}", e.value, e.uncertainty)
        } else {
            format!("{:.digits$} | not constrained", e.value)
        }
    };
    let b = &report.builtin;
    let mut out = format!(
        "BSP fitted to the paper's reductions: {} simulated participants, seed {} (the same in every evaluation), {} studies\n\n",
        report.users, report.seed, report.evaluations
    );
    out += "| parameter | fitted | uncertainty (1 SD) | built-in |\n|---|---|---|---|\n";
    out += &format!(
        "| scan dwell, ms | {} | {:.0} |\n",
        pm(&report.fit.dwell_ms, 0),
        b.dwell_ms
    );
    out += &format!(
        "| first-dwell factor | {} | {:.2} |\n",
        pm(&report.fit.first_dwell_factor, 2),
        b.first_dwell_factor
    );
    out += &format!(
        "| BSP miss rate | {} | {:.2} |\n",
        pm(&report.fit.miss_rate, 3),
        b.miss_rate
    );
    let c = &report.correlation;
    out += &format!(
        "\nUncertainty: Gauss–Newton curvature at the fit (reductions' central differences, each task's standard error over the participants); correlation dwell–factor {:.2}, dwell–miss {:.2}, factor–miss {:.2}\n\n",
        c[0][1], c[0][2], c[1][2]
    );
    out += "| task | ASP s | BSP s | ASP lower by | ± SE | paper | residual | p one-tailed | paper p | moving-time p | paper p |\n";
    out += "|---|---|---|---|---|---|---|---|---|---|---|\n";
    for t in &report.tasks {
        out += &format!(
            "| {} | {:.1} | {:.1} | {:.1} % | {:.1} | {:.0} % | {:+.1} | {:.2e} | {:.2e} | {:.3} | {:.3} |\n",
            t.task,
            t.asp_mean_s,
            t.bsp_mean_s,
            t.reduction_pct,
            t.reduction_se_pct,
            t.paper_reduction_pct,
            t.residual_pct,
            t.p_value,
            t.paper_p_value,
            t.moving_time_p_value,
            report.paper_moving_time_p_value,
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_inverse_of_a_matrix() {
        let m = [[4.0, 1.0, 0.0], [1.0, 3.0, 1.0], [0.0, 1.0, 2.0]];
        let inv = invert(&m).unwrap();
        for (r, row) in m.iter().enumerate() {
            for c in 0..3 {
                let x: f64 = row.iter().zip(&inv).map(|(a, b)| a * b[c]).sum();
                assert!((x - f64::from(u8::from(r == c))).abs() < 1e-12);
            }
        }
        assert!(invert(&[[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]]).is_none());
    }

    #[test]
    fn parameters_at_the_resolution_the_study_sees() {
        let p = BspParams::from_array([812.4, 1.4567, 0.123_456]);
        assert_eq!(p.dwell_ms, 812.0);
        assert_eq!(p.first_dwell_factor * 812.0, 1183.0);
        assert_eq!(p.miss_rate, 0.1235);
        assert_eq!(p.key(), (812, 1183, 1235));
        // Clamped to the search box.
        let q = BspParams::from_array([10.0, 0.2, -1.0]);
        assert_eq!(q.to_array(), [250.0, 1.0, 0.0]);
    }
}
