//! A designed library for the people who read it: the search's result,
//! the saving and the verdict in words, each entry's time and errors, and
//! the study's figures beside the model's; or the same as one JSON
//! object.

use serde::Serialize;

use crate::design::analysis::{self, Analysis};
use crate::design::designing::Designed;
use crate::design::search::SearchResult;
use crate::design::study_check::StudyCheck;
use crate::design::verdict::{Verdict, faster_words};
use crate::sim::study::libraries;

/// `design`'s JSON.
#[derive(Serialize)]
struct DesignReport<'a> {
    designed_for: &'a str,
    study_measures_this_usage: bool,
    search: &'a SearchResult,
    gap_pct: f64,
    verdict: &'a Verdict,
    designed: &'a Analysis,
    before: &'a Analysis,
    study: Option<&'a StudyCheck>,
    out: Option<String>,
}

/// The designed library as one JSON object.
pub fn json(d: &Designed) -> serde_json::Result<String> {
    let report = DesignReport {
        designed_for: &d.usage_line,
        study_measures_this_usage: d.study_usage,
        search: &d.found,
        gap_pct: d.found.gap_pct(),
        verdict: &d.verdict,
        designed: &d.designed,
        before: &d.before,
        study: d.study.as_ref(),
        out: d.out.as_ref().map(|p| p.display().to_string()),
    };
    serde_json::to_string(&report)
}

/// The designed library in words and tables: first the usage designed
/// for and, when the study measures another, the difference on each;
/// last the one bottom line.
pub fn text(d: &Designed) -> String {
    let mut out = format!("designed for: {}\n", d.usage_line);
    if let Some(s) = d.study.as_ref().filter(|_| !d.study_usage) {
        out += &format!(
            "the study below measures another usage, the mode changes of its three tasks: the designed library is {} than {} on {} (the model, {:.2} → {:.2} s per selection) and {} on the study's tasks (the model {:.2} → {:.2} s, the study {:.2} → {:.2} s per mode change)\n",
            faster_words(
                1.0 - d.designed.expected_ms_per_selection / d.before.expected_ms_per_selection
            ),
            d.library_name,
            d.designed.usage,
            d.before.expected_ms_per_selection / 1000.0,
            d.designed.expected_ms_per_selection / 1000.0,
            faster_words(1.0 - s.comparison.b_selection_s / s.comparison.a_selection_s),
            s.predicted_selection_s.0,
            s.predicted_selection_s.1,
            s.comparison.a_selection_s,
            s.comparison.b_selection_s
        );
    }
    out += "\n";
    out += &search_text(&d.found, &d.designed, &d.before, &d.library_name);
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
    out += &format!("\nbottom line: {}\n", d.verdict.text);
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
        "cost per selection: {} {:.0} ms, designed {:.0} ms ({}); wrong selections per attempt {:.2} % → {:.2} %\n\n",
        name,
        before.expected_ms_per_selection,
        designed.expected_ms_per_selection,
        faster_words(1.0 - designed.expected_ms_per_selection / before.expected_ms_per_selection),
        100.0 * before.p_wrong_per_selection,
        100.0 * designed.p_wrong_per_selection
    );
    out += &analysis::text(designed);
    out
}
