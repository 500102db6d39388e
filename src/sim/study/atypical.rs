//! The fitted user in the study: each built-in breather (weak, slow,
//! tremulous, …) breathes the calibration protocol, is fitted, and then
//! uses the interface with the defaults and with their profile — on a
//! held-out practice session (breaths read right) and on the paper's
//! three tasks (time, wrong selections, unintended motion).

use serde::Serialize;

use crate::config::Config;
use crate::control::action::Action;
use crate::fit::check::{bursts, read_right};
use crate::fit::profile::{self, ProfileHeader};
use crate::fit::protocol::{Ask, Protocol};
use crate::fit::signal::Signal;
use crate::sim::breather::{Breather, VARIATION, practice_session, protocol_session};
use crate::sim::study::tasks::TASKS;
use crate::sim::user::{UserModel, run_task_as};

/// How the atypical study runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AtypicalOptions {
    /// Seed of the calibrations, practice sessions and tasks.
    pub seed: u64,
    /// Length of each held-out practice session, s.
    pub practice_s: u64,
    /// Runs of each task per breather and setting.
    pub runs: u64,
}

impl Default for AtypicalOptions {
    fn default() -> Self {
        AtypicalOptions {
            seed: 1,
            practice_s: 300,
            runs: 3,
        }
    }
}

/// A value as it truly is and as the fit measured it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Recovered {
    /// The truth.
    pub truth: f64,
    /// The fit's measurement.
    pub fitted: f64,
}

/// How one setting (defaults or the profile) served a breather.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct UseOutcome {
    /// Breaths of the calibration read right, and how many.
    pub calibration: (usize, usize),
    /// Breaths of the held-out practice session read right, and how many.
    pub practice: (usize, usize),
    /// Mean task completion time, s, over the runs that finished.
    pub task_s: f64,
    /// Task runs that did not finish (nothing read, or the cap reached).
    pub unfinished: u64,
    /// Modes entered that were not wanted, over all runs.
    pub wrong_selections: u64,
    /// Motion nobody wanted, over all runs, mm.
    pub unintended_mm: f64,
}

impl UseOutcome {
    /// Practice breaths read right, percent.
    pub fn practice_pct(&self) -> f64 {
        100.0 * self.practice.0 as f64 / self.practice.1.max(1) as f64
    }
}

/// One breather's fit and use.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BreatherResult {
    /// The breather's name.
    pub name: &'static str,
    /// What the fit recovered: rest level and noise (V), plateaus (V),
    /// lengths (ms) by kind, in the protocol's order.
    pub recovered: Vec<(String, Recovered)>,
    /// The profile's text.
    pub profile: String,
    /// With the defaults (re-zeroed at the user's rest).
    pub defaults: UseOutcome,
    /// With the profile.
    pub fitted: UseOutcome,
    /// Why the fit failed, if it did (then `fitted` is empty).
    pub fit_error: Option<String>,
}

/// Fits and runs every built-in breather.
pub fn run(options: &AtypicalOptions) -> Vec<BreatherResult> {
    Breather::all().iter().map(|b| one(b, options)).collect()
}

fn one(b: &Breather, options: &AtypicalOptions) -> BreatherResult {
    let protocol = Protocol::new(8, 3);
    let calibration = protocol_session(b, &protocol, options.seed);
    let signal = Signal::from_volts(calibration.signal());
    let defaults = Config::default()
        .with_neutral_volts(b.rest_volts)
        .unwrap_or_default();
    let mut result = BreatherResult {
        name: b.name,
        recovered: Vec::new(),
        profile: String::new(),
        defaults: UseOutcome::default(),
        fitted: UseOutcome::default(),
        fit_error: None,
    };
    let profile = crate::fit::fit(&signal, &protocol, &defaults).and_then(|fit| {
        result.recovered = recovered(b, &fit);
        let header = ProfileHeader {
            label: b.name.into(),
            date: "simulated".into(),
            source: format!(
                "the protocol breathed by `{}` (seed {})",
                b.name, options.seed
            ),
        };
        let text = profile::text(&fit, &header);
        let config = Config::from_toml_str(&text)
            .and_then(|c| c.with_neutral_volts(b.rest_volts))
            .map_err(|e| crate::fit::signal::FitError::new(e.to_string()))?;
        result.profile = text;
        Ok(config)
    });
    let meant: Vec<(Action, u64, u64)> = calibration
        .breaths
        .iter()
        .map(|t| {
            let action = match t.ask {
                Ask::Breath(a) => a,
                Ask::Hold(breath) => Action::new(breath, true),
            };
            (action, t.start, u64::from(t.ms))
        })
        .collect();
    result.defaults = outcome(b, &defaults, &signal, &meant, options);
    match profile {
        Ok(config) => result.fitted = outcome(b, &config, &signal, &meant, options),
        Err(e) => result.fit_error = Some(e.to_string()),
    }
    result
}

/// The breather's truth beside what the fit measured.
fn recovered(b: &Breather, fit: &crate::fit::Fit) -> Vec<(String, Recovered)> {
    let rest = &fit.found.rest;
    let mut out = vec![
        (
            "rest level V".to_string(),
            Recovered {
                truth: b.rest_volts,
                fitted: rest.level,
            },
        ),
        (
            "rest noise sd V".to_string(),
            Recovered {
                truth: b.noise_volts,
                fitted: rest.white_sd,
            },
        ),
        (
            "rest swing V".to_string(),
            Recovered {
                truth: b.rest_swing_volts(),
                fitted: rest.excursion_up.max(rest.excursion_down),
            },
        ),
    ];
    for class in &fit.classes {
        let breath = class.ask.breath();
        if !matches!(class.ask, Ask::Hold(_)) {
            out.push((
                format!("{} plateau V", class.ask.words()),
                Recovered {
                    truth: b.mean_volts(breath),
                    fitted: class.plateau_volts.mean,
                },
            ));
        }
        out.push((
            format!("{} ms", class.ask.words()),
            Recovered {
                truth: f64::from(b.mean_ms(class.ask)),
                fitted: class.duration_ms.mean,
            },
        ));
    }
    out
}

/// The breather's model in the study: their lengths and gaps (the
/// uniform ±30 % as a spread), no mistakes of intent (the misreadings
/// come from the signal), their hold capacity.
fn user_model(b: &Breather) -> UserModel {
    let spread = |mean: u32| (f64::from(mean), f64::from(mean) * VARIATION / 3f64.sqrt());
    UserModel {
        short_ms: spread(b.short_ms),
        long_ms: spread(b.long_ms),
        gap_ms: spread(b.gap_ms),
        error_rate: 0.0,
        hold_capacity_ms: f64::from(b.hold_ms),
        ..UserModel::POPULATION
    }
}

fn outcome(
    b: &Breather,
    config: &Config,
    calibration: &Signal,
    meant: &[(Action, u64, u64)],
    options: &AtypicalOptions,
) -> UseOutcome {
    let d = config.core().detector();
    let (read, _) = bursts(calibration, d);
    let practice = practice_session(
        b,
        config.core().sequences(),
        options.practice_s,
        options.seed + 1,
    );
    let practice_signal = Signal::from_volts(practice.signal());
    let (practice_bursts, _) = bursts(&practice_signal, d);
    let practice_meant: Vec<(Action, u64, u64)> = practice
        .breaths
        .iter()
        .map(|t| (t.action, t.start, u64::from(t.ms)))
        .collect();
    let user = user_model(b);
    let mut out = UseOutcome {
        calibration: (read_right(&read, meant), meant.len()),
        practice: (
            read_right(&practice_bursts, &practice_meant),
            practice_meant.len(),
        ),
        ..UseOutcome::default()
    };
    let (mut total_s, mut finished) = (0.0, 0u64);
    for task in &TASKS {
        for run in 0..options.runs {
            let seed = options.seed * 1000 + u64::from(task.number) * 10 + run;
            let r = run_task_as(config, task, &user, b.signal_params(seed), seed);
            if r.timed_out {
                out.unfinished += 1;
            } else {
                total_s += r.completion_s;
                finished += 1;
            }
            out.wrong_selections += u64::from(r.wrong_selections);
            out.unintended_mm += r.unintended_mm;
        }
    }
    out.task_s = if finished > 0 {
        total_s / finished as f64
    } else {
        f64::NAN
    };
    out
}

/// The results as a table.
pub fn text(results: &[BreatherResult]) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:<15} {:>22} {:>22} {:>17} {:>11} {:>9} {:>12}",
        "breather",
        "calibration right",
        "practice right",
        "task time s",
        "unfinished",
        "wrong",
        "unintended mm"
    );
    let pair = |a: String, b: String| format!("{a} → {b}");
    let seconds = |s: f64| {
        if s.is_nan() {
            "—".to_string()
        } else {
            format!("{s:.1}")
        }
    };
    for r in results {
        let (d, f) = (&r.defaults, &r.fitted);
        let _ = writeln!(
            out,
            "{:<15} {:>22} {:>22} {:>17} {:>11} {:>9} {:>12}",
            r.name,
            pair(
                format!("{}/{}", d.calibration.0, d.calibration.1),
                format!("{}/{}", f.calibration.0, f.calibration.1)
            ),
            pair(
                format!("{:.1} %", d.practice_pct()),
                format!("{:.1} %", f.practice_pct())
            ),
            pair(seconds(d.task_s), seconds(f.task_s)),
            pair(d.unfinished.to_string(), f.unfinished.to_string()),
            pair(
                d.wrong_selections.to_string(),
                f.wrong_selections.to_string()
            ),
            pair(
                format!("{:.0}", d.unintended_mm),
                format!("{:.0}", f.unintended_mm)
            ),
        );
        if let Some(e) = &r.fit_error {
            let _ = writeln!(out, "  the fit failed: {e}");
        }
    }
    let _ = writeln!(
        out,
        "\ndefaults → the fitted profile; practice: a held-out session of the library's sequences; tasks: the paper's three, each run {} times",
        AtypicalOptions::default().runs
    );
    out
}
