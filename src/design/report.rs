//! A designed library for the people who read it: the search's result,
//! the saving and the verdict in words, each entry's time and errors, and
//! the study's figures beside the model's; or the same as one JSON
//! object.

use serde::Serialize;

use crate::design::analysis::{self, Analysis};
use crate::design::designing::Designed;
use crate::design::search::SearchResult;
use crate::design::study_check::StudyCheck;
use crate::sim::study::libraries;

/// `design`'s JSON.
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

/// The designed library as one JSON object.
pub fn json(d: &Designed) -> serde_json::Result<String> {
    let report = DesignReport {
        search: &d.found,
        gap_pct: d.found.gap_pct(),
        verdict: verdict(&d.designed, &d.before, &d.library_name),
        designed: &d.designed,
        before: &d.before,
        study: d.study.as_ref(),
        out: d.out.as_ref().map(|p| p.display().to_string()),
    };
    serde_json::to_string(&report)
}

/// The designed library in words and tables, with the study's figures.
pub fn text(d: &Designed) -> String {
    let mut out = search_text(&d.found, &d.designed, &d.before, &d.library_name);
    if let Some(s) = &d.study {
        out += &format!(
            "\nIn the study ({} against the designed library, sequence matching):\n\n{}",
            d.library_name,
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
    out
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
