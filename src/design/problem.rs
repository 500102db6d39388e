//! The search's problem from the request: the bursts the person can
//! breathe, the entries that keep their sequence, the sequences' lengths,
//! the time allowed.

use std::time::Duration;

use anyhow::bail;

use crate::config::invalid::invalid;
use crate::control::action::{Action, ActionSeq};
use crate::control::selection::SequenceEntry;
use crate::design::analysis::breaths_of;
use crate::design::inputs::Inputs;
use crate::design::request::Request;
use crate::design::search::{Problem, candidates};

/// The search's problem; naming no burst or an entry the library lacks
/// is an invalid start.
pub fn problem(request: &Request, inputs: &Inputs) -> anyhow::Result<Problem> {
    let library = inputs.config.core().sequences();
    let allowed: Vec<Action> = Action::ALL
        .into_iter()
        .filter(|a| !request.without.contains(a))
        .collect();
    if allowed.is_empty() {
        return invalid(Err(anyhow::anyhow!("--without leaves no burst to breathe")));
    }
    let mut fixed: Vec<Option<ActionSeq>> = vec![None; library.len()];
    for name in &request.keep {
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
        fixed[i] = Some(breaths_of(&library[i]));
    }
    let candidates = candidates(
        &allowed,
        usize::from(request.min_breaths),
        usize::from(request.max_breaths),
    );
    let free = candidates
        .iter()
        .filter(|c| !fixed.iter().any(|f| f.as_ref() == Some(c)))
        .count();
    let places = fixed.iter().filter(|f| f.is_none()).count();
    if free < places {
        bail!(
            "{places} entries to place but only {free} sequences of {}–{} bursts of {}: allow longer sequences (--max-breaths) or more bursts",
            request.min_breaths,
            request.max_breaths,
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
        time_limit: Duration::from_secs_f64(request.time_limit_s.max(0.0)),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::search::search_on;

    /// The design `sipnpuff design --max-breaths 2` runs: the built-in
    /// library on the study's tasks, for the study's simulated user (whose
    /// sips and puffs mirror each other, so libraries tie).
    fn two_burst_design() -> Problem {
        let request = crate::design::request::Request {
            library: None,
            user: None,
            config: Vec::new(),
            usage: Vec::new(),
            mix: None,
            wrong_cost_ms: None,
            swap_rate: 0.0,
            min_breaths: 2,
            max_breaths: 2,
            without: Vec::new(),
            keep: Vec::new(),
            time_limit_s: 600.0,
            out: None,
            svg: None,
            users: 8,
            seed: 1,
            no_study: true,
            force: false,
        };
        let inputs = crate::design::inputs::Inputs::read(&request).unwrap();
        problem(&request, &inputs).unwrap()
    }

    #[test]
    fn the_library_found_does_not_depend_on_the_threads() {
        let p = two_burst_design();
        let one = search_on(&p, 1);
        assert!(one.complete);
        for threads in [2, 3, 2] {
            let found = search_on(&p, threads);
            assert!(found.complete);
            assert_eq!(found.cost_ms, one.cost_ms, "{threads} threads");
            assert_eq!(found.sequences, one.sequences, "{threads} threads");
        }
    }
}
