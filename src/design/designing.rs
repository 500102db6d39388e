//! Designing the library for a person, start to end: the person, their
//! settings and the library read ([`Inputs`]) and analysed ([`check`]);
//! or the search for the library that costs them least, analysed again,
//! tried in the study against the library it replaces, written as a
//! configuration and drawn ([`design`]).

use std::path::{Path, PathBuf};

use anyhow::Context;

use crate::config::invalid::invalid;
use crate::control::selection::{Interface, SequenceEntry};
use crate::control::token::Token;
use crate::design::analysis::{Analysis, analyse};
use crate::design::inputs::Inputs;
use crate::design::problem::{alphabet, problem};
use crate::design::request::{Request, Without};
use crate::design::search::{self, SearchResult};
use crate::design::study_check::{StudyCheck, study_check};
use crate::design::usage::UsageKind;
use crate::design::verdict::{self, Evidence, ModelFigures, StudyFigures, Verdict};
use crate::design::{library_file, plot};
use crate::sim::study::missing_modes;

/// A library analysed for the person.
pub struct Checked {
    /// Each entry's time and errors.
    pub analysis: Analysis,
    /// The library in words.
    pub library_name: String,
    /// The usage analysed, with why.
    pub usage_line: String,
    /// Why that usage: asked for, or the default and what decided it.
    pub usage_why: String,
}

/// The library designed for the person.
pub struct Designed {
    /// The search's result.
    pub found: SearchResult,
    /// The designed library analysed.
    pub designed: Analysis,
    /// The library it replaces, analysed.
    pub before: Analysis,
    /// The study's verdict, unless skipped.
    pub study: Option<StudyCheck>,
    /// The library it replaces, in words.
    pub library_name: String,
    /// The usage designed for, with why.
    pub usage_line: String,
    /// Whether that usage is the study's (its tasks' mode changes).
    pub study_usage: bool,
    /// The bottom line.
    pub verdict: Verdict,
    /// The configuration written, if asked for.
    pub out: Option<PathBuf>,
}

/// Analyses the library the request names for its person and usage;
/// draws it to the request's SVG, if any.
pub fn check(request: &Request) -> anyhow::Result<Checked> {
    let inputs = Inputs::read(request)?;
    let library = inputs.config.core().sequences();
    let analysis = analyse(library, &inputs.who, &inputs.usage, &inputs.timing);
    if let Some(path) = &request.svg {
        write(path, &plot::analysis_svg(&analysis, &inputs.library_name))?;
    }
    Ok(Checked {
        analysis,
        usage_line: inputs.usage_line(),
        usage_why: inputs.usage_why,
        library_name: inputs.library_name,
    })
}

/// Searches for the library that costs the person least, saying (`say`)
/// what it places and why the study is skipped; tries it in the study,
/// writes it to the request's `out` and draws it to its SVG, if asked.
pub fn design(request: &Request, say: &dyn Fn(&str)) -> anyhow::Result<Designed> {
    let inputs = Inputs::read(request)?;
    let library = inputs.config.core().sequences();
    let before = analyse(library, &inputs.who, &inputs.usage, &inputs.timing);
    let problem = problem(request, &inputs)?;
    if inputs.who.gestures.is_some() {
        let alphabet = alphabet(request, &inputs)?;
        let words: Vec<String> = alphabet
            .allowed
            .iter()
            .map(|s| inputs.who.word(*s))
            .collect();
        say(&format!(
            "placing {} entries on {} sequences of {}{}…",
            library.len(),
            problem.candidates.len(),
            words.join(", "),
            alphabet
                .no_breaths_why
                .map(|why| format!(" (no breaths: {why})"))
                .unwrap_or_default()
        ));
    } else {
        say(&format!(
            "placing {} entries on {} sequences…",
            library.len(),
            problem.candidates.len()
        ));
    }
    let found = search::search(&problem);
    let designed_library: Vec<SequenceEntry> = library
        .iter()
        .zip(&found.sequences)
        .map(|(e, s)| SequenceEntry {
            actions: inputs.who.tokens(s),
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
    let gestures = library
        .iter()
        .chain(&designed_library)
        .any(|e| e.actions.has_gesture());
    let study = if request.no_study {
        None
    } else if gestures {
        say(
            "no study: its simulated participants breathe and make no gestures (`study --head` runs head-gesture users on the paper's tasks)",
        );
        None
    } else if !missing.is_empty() {
        let names: Vec<&str> = missing.iter().map(|m| m.name()).collect();
        say(&format!(
            "no study: its tasks need {}, which the library does not select",
            names.join(", ")
        ));
        None
    } else {
        Some(study_check(
            &inputs,
            &designed_config,
            request.users,
            request.seed,
        )?)
    };
    let study_usage = inputs.usage.kind == UsageKind::Tasks;
    let unbreathable: Vec<Token> = inputs
        .who
        .alphabet()
        .into_iter()
        .map(|s| inputs.who.token(s))
        .filter(|t| {
            let left_out = match t {
                Token::Breath(a) => request.without.iter().any(|w| w.covers(*a)),
                Token::Gesture(name) => request.without.contains(&Without::Gesture(*name)),
            };
            left_out && library.iter().any(|e| e.actions.as_slice().contains(t))
        })
        .collect();
    let verdict = verdict::verdict(&Evidence {
        name: &inputs.library_name,
        usage: &inputs.usage.source,
        model: ModelFigures {
            before_ms: before.expected_ms_per_selection,
            designed_ms: designed.expected_ms_per_selection,
            before_wrong: before.p_wrong_per_selection,
            designed_wrong: designed.p_wrong_per_selection,
        },
        unbreathable,
        study: study.as_ref().map(|s| StudyFigures {
            same_usage: study_usage,
            per_change_s: (s.comparison.a_selection_s, s.comparison.b_selection_s),
            tasks: s
                .comparison
                .tasks
                .iter()
                .map(|t| (t.reduction_pct, t.p_value))
                .collect(),
            wrong: s
                .comparison
                .tasks
                .iter()
                .fold((0, 0), |(a, b), t| (a + t.a_wrong, b + t.b_wrong)),
        }),
        forced: request.force && request.out.is_some(),
    });
    if let Some(path) = &request.out {
        if !verdict.may_write() && !request.force {
            return Err(anyhow::Error::new(NotWritten {
                path: path.clone(),
                verdict: verdict.text.clone(),
            }));
        }
        let text = library_file::text(&library_file::Designed {
            config: &designed_config,
            analysis: &designed,
            before: &before,
            before_library: library,
            found: &found,
            library_name: &inputs.library_name,
            usage_line: &inputs.usage_line(),
            reasons: inputs.profile_text.as_deref(),
        })?;
        write(path, &text)?;
    }
    if let Some(path) = &request.svg {
        write(path, &plot::analysis_svg(&designed, "the designed library"))?;
    }
    Ok(Designed {
        found,
        designed,
        before,
        study,
        usage_line: inputs.usage_line(),
        library_name: inputs.library_name,
        study_usage,
        verdict,
        out: request.out.clone(),
    })
}

/// A designed library slower than the one it replaces, not written: the
/// verdict says why; `--force` writes it.
#[derive(Debug)]
pub struct NotWritten {
    /// The file not written.
    pub path: PathBuf,
    /// The bottom line.
    pub verdict: String,
}

impl std::fmt::Display for NotWritten {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: {}; --force writes it anyway",
            self.path.display(),
            self.verdict
        )
    }
}

impl std::error::Error for NotWritten {}

fn write(path: &Path, text: &str) -> anyhow::Result<()> {
    std::fs::write(path, text).with_context(|| format!("cannot write {}", path.display()))
}
