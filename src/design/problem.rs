//! The search's problem from the request: the bursts the person can
//! breathe and the gestures they can make, the entries that keep their
//! sequence, the sequences' lengths, the time allowed.

use std::time::Duration;

use anyhow::bail;

use crate::config::invalid::invalid;
use crate::control::selection::SequenceEntry;
use crate::control::token::Token;
use crate::design::analysis::symbols_of;
use crate::design::inputs::Inputs;
use crate::design::request::{Request, Without};
use crate::design::search::{Problem, candidates};
use crate::design::symbol::{Symbol, SymbolSeq};

/// What the search places entries on: the person's bursts and gestures
/// less `--without`'s, and why, in words when the person has gestures.
pub struct Alphabet {
    /// The symbols allowed.
    pub allowed: Vec<Symbol>,
    /// Why breaths are left out when the library has none and
    /// `--with-breaths` is not given.
    pub no_breaths_why: Option<&'static str>,
}

/// The symbols the search may place entries on; a `--without` gesture
/// the person's set lacks is an invalid start.
pub fn alphabet(request: &Request, inputs: &Inputs) -> anyhow::Result<Alphabet> {
    let who = &inputs.who;
    for w in &request.without {
        if let Without::Gesture(name) = w
            && who.symbol(Token::Gesture(*name)).is_none()
        {
            let has = who.gestures.as_ref().map(|g| {
                let names: Vec<String> = g.gestures.iter().map(|g| g.name.to_string()).collect();
                format!("the gesture set {} has {}", g.source, names.join(", "))
            });
            return invalid(Err(anyhow::anyhow!(
                "--without {name}: not a burst (short_sip, long_sip, short_puff, long_puff, breaths) and {}",
                has.unwrap_or_else(|| {
                    "no gesture set is given (--gestures, or [gestures] set in a --config)".into()
                })
            )));
        }
    }
    let library = inputs.config.core().sequences();
    let library_breathes = library
        .iter()
        .any(|e| e.actions.as_slice().iter().any(|t| t.action().is_some()));
    let no_breaths_why = (who.gestures.is_some() && !library_breathes && !request.with_breaths)
        .then_some("the library has none, so the person may have no breath sensor: --with-breaths places them too");
    let allowed = who
        .alphabet()
        .into_iter()
        .filter(|s| match (s.action(), who.token(*s)) {
            (Some(a), _) => {
                no_breaths_why.is_none() && !request.without.iter().any(|w| w.covers(a))
            }
            (None, Token::Gesture(name)) => !request.without.contains(&Without::Gesture(name)),
            (None, Token::Breath(_)) => false,
        })
        .collect();
    Ok(Alphabet {
        allowed,
        no_breaths_why,
    })
}

/// The search's problem; leaving nothing to place entries on, or naming
/// an entry the library lacks, is an invalid start.
pub fn problem(request: &Request, inputs: &Inputs) -> anyhow::Result<Problem> {
    let library = inputs.config.core().sequences();
    let allowed = alphabet(request, inputs)?.allowed;
    if allowed.is_empty() {
        return invalid(Err(anyhow::anyhow!(if inputs.who.gestures.is_some() {
            "--without leaves no burst or gesture to make"
        } else {
            "--without leaves no burst to breathe"
        })));
    }
    let mut fixed: Vec<Option<SymbolSeq>> = vec![None; library.len()];
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
        fixed[i] = Some(symbols_of(&library[i], &inputs.who));
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
        let words: Vec<String> = allowed.iter().map(|s| inputs.who.word(*s)).collect();
        let (min, max) = (request.min_breaths, request.max_breaths);
        if inputs.who.gestures.is_some() {
            bail!(
                "{places} entries to place but only {free} sequences of up to {max} of {} ({min} or more of bursts alone): allow longer sequences (--max-breaths) or more bursts and gestures",
                words.join(", ")
            );
        }
        bail!(
            "{places} entries to place but only {free} sequences of {min}–{max} bursts of {}: allow longer sequences (--max-breaths) or more bursts",
            words.join(", ")
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
            gestures: None,
            mix: None,
            wrong_cost_ms: None,
            swap_rate: 0.0,
            min_breaths: 2,
            max_breaths: 2,
            without: Vec::new(),
            with_breaths: false,
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
