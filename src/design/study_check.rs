//! The study's verdict on a designed library: the paper's tasks done by
//! simulated participants with the library before and the designed one,
//! the model's prediction set beside the study's measure.

use serde::Serialize;

use crate::config::Config;
use crate::config::invalid::invalid;
use crate::design::analysis::analyse;
use crate::design::inputs::Inputs;
use crate::design::usage::Usage;
use crate::sim::study::libraries::{self, LibraryComparison};

/// The study's verdict on the designed library, with the model's
/// prediction beside the study's measure.
#[derive(Serialize)]
pub struct StudyCheck {
    /// The study with both libraries.
    pub comparison: LibraryComparison,
    /// The model's mean time per mode change of the tasks, before and
    /// designed, s.
    pub predicted_selection_s: (f64, f64),
    /// The model's error against the study's measure, percent.
    pub prediction_error_pct: (f64, f64),
}

/// Runs the study with `users` participants (seeded by `seed`) with the
/// library before and the `designed` one, and sets the model's
/// prediction beside it.
pub fn study_check(
    inputs: &Inputs,
    designed: &Config,
    users: u64,
    seed: u64,
) -> anyhow::Result<StudyCheck> {
    let population = inputs.who.user_model();
    let comparison = invalid(
        libraries::compare(
            &inputs.config,
            designed,
            &population,
            usize::try_from(users)?,
            seed,
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
