//! The designer's one bottom line: switch to the designed library or keep
//! the one it replaces, from the model on the usage it was designed for
//! and, when the study measured that same usage, from the study. A study
//! of another usage is reported beside, never silently mixed in; a
//! designed library slower than the one it replaces is not written
//! without `--force`, and the bottom line says which happened.

use serde::Serialize;

use crate::control::token::Token;

/// The model's figures for both libraries on the usage designed for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelFigures {
    /// Expected time per selection, the library replaced, ms.
    pub before_ms: f64,
    /// The designed one, ms.
    pub designed_ms: f64,
    /// Chance an attempt selects a wrong entry, the library replaced.
    pub before_wrong: f64,
    /// The designed one.
    pub designed_wrong: f64,
}

/// The study's figures, paired: the library replaced against the designed.
#[derive(Debug, Clone, PartialEq)]
pub struct StudyFigures {
    /// Whether the study's usage (its tasks' mode changes) is the one the
    /// library was designed for.
    pub same_usage: bool,
    /// Mean time per mode change, before and designed, s.
    pub per_change_s: (f64, f64),
    /// Per task: the designed library lower by this, percent, and the
    /// two-tailed p-value.
    pub tasks: Vec<(f64, f64)>,
    /// Wrong selections, all participants, before and designed.
    pub wrong: (u32, u32),
}

/// What the verdict rests on.
#[derive(Debug, Clone, PartialEq)]
pub struct Evidence<'a> {
    /// The library replaced, in words.
    pub name: &'a str,
    /// The usage designed for, in words.
    pub usage: &'a str,
    /// The model on that usage.
    pub model: ModelFigures,
    /// Bursts and gestures the replaced library uses that the person
    /// cannot make (`--without`).
    pub unbreathable: Vec<Token>,
    /// The study, unless skipped.
    pub study: Option<StudyFigures>,
    /// `--force` with `--out`: the designed library is written whatever
    /// the verdict.
    pub forced: bool,
}

/// The decision.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Decision {
    /// Use the designed library.
    Switch,
    /// Keep the library it replaces (near-optimal, or no measurable
    /// difference).
    Keep,
    /// The designed library is slower: keep the one it replaces; not
    /// written without `--force`.
    Slower,
}

/// The bottom line.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Verdict {
    /// The decision.
    pub decision: Decision,
    /// It in words, with the figures it rests on.
    pub text: String,
}

impl Verdict {
    /// Whether the designed library may be written without `--force`.
    pub fn may_write(&self) -> bool {
        self.decision != Decision::Slower
    }
}

/// Under this much faster and under [`FEWER_WRONG`] less often wrong, a
/// designed library is not worth relearning.
pub const NEAR_OPTIMAL: f64 = 0.02;
/// See [`NEAR_OPTIMAL`].
pub const FEWER_WRONG: f64 = 0.25;
/// A study's task differs when its two-tailed p is under this.
pub const SIGNIFICANT: f64 = 0.05;

/// What the study found, by the majority of its tasks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Found {
    Faster,
    Slower,
    Nothing,
}

fn found(s: &StudyFigures) -> Found {
    let count = |faster: bool| {
        s.tasks
            .iter()
            .filter(|(lower_pct, p)| *p < SIGNIFICANT && (*lower_pct > 0.0) == faster)
            .count()
    };
    let majority = s.tasks.len() / 2 + 1;
    if count(true) >= majority && s.per_change_s.1 < s.per_change_s.0 {
        Found::Faster
    } else if count(false) >= majority && s.per_change_s.1 > s.per_change_s.0 {
        Found::Slower
    } else {
        Found::Nothing
    }
}

/// "per mode change 1.37 → 1.65 s (20.4 % slower), p 0.012–0.012,
/// wrong selections 5 → 11".
fn study_words(s: &StudyFigures) -> String {
    let (a, b) = s.per_change_s;
    let ps = s.tasks.iter().map(|t| t.1);
    let (lo, hi) = ps.fold((f64::INFINITY, 0.0f64), |(lo, hi), p| {
        (lo.min(p), hi.max(p))
    });
    let p = if (hi - lo).abs() < 0.005 {
        format!("p {lo:.2}")
    } else {
        format!("p {lo:.2}–{hi:.2}")
    };
    format!(
        "per mode change {a:.2} → {b:.2} s ({}), {p}, wrong selections {} → {}",
        faster_words(1.0 - b / a),
        s.wrong.0,
        s.wrong.1
    )
}

/// "4.3 % faster", "20.4 % slower", "as fast".
pub fn faster_words(faster: f64) -> String {
    if faster.abs() < 0.0005 {
        "as fast".into()
    } else if faster > 0.0 {
        format!("{:.1} % faster", 100.0 * faster)
    } else {
        format!("{:.1} % slower", -100.0 * faster)
    }
}

/// The one bottom line from `e`.
pub fn verdict(e: &Evidence) -> Verdict {
    let m = e.model;
    let faster = 1.0 - m.designed_ms / m.before_ms;
    // Neither library ever wrong (a person whose gestures the set reads
    // without a slip): no fewer, no more.
    let never_wrong = m.before_wrong <= 0.0 && m.designed_wrong <= 0.0;
    let fewer_wrong = if never_wrong {
        0.0
    } else {
        1.0 - m.designed_wrong / m.before_wrong.max(1e-12)
    };
    let name = e.name;
    let model = format!(
        "the model expects the designed library {} and {} for {} ({:.2} → {:.2} s per selection)",
        faster_words(faster),
        if never_wrong {
            "never wrong (nor is the other)".to_string()
        } else if m.before_wrong <= 0.0 {
            format!(
                "wrong in {:.2} % of attempts (the other never is)",
                100.0 * m.designed_wrong
            )
        } else if fewer_wrong >= 0.0 {
            format!("{:.0} % less often wrong", 100.0 * fewer_wrong)
        } else {
            format!("{:.0} % more often wrong", -100.0 * fewer_wrong)
        },
        e.usage,
        m.before_ms / 1000.0,
        m.designed_ms / 1000.0
    );
    let same_study = e.study.as_ref().filter(|s| s.same_usage);
    let other_study = e
        .study
        .as_ref()
        .filter(|s| !s.same_usage)
        .map(|s| {
            format!(
                "; the study measured its tasks instead, another usage: {}",
                study_words(s)
            )
        })
        .unwrap_or_default();
    let verdict = |decision: Decision, text: String| Verdict { decision, text };
    let writing = if e.forced {
        "written because of --force"
    } else {
        "not written without --force"
    };
    if !e.unbreathable.is_empty() {
        let items: Vec<String> = e
            .unbreathable
            .iter()
            .map(|t| match t {
                Token::Breath(a) => format!("{a}s"),
                Token::Gesture(name) => format!("`{name}`"),
            })
            .collect();
        let breaths_only = e.unbreathable.iter().all(|t| t.action().is_some());
        return verdict(
            Decision::Switch,
            format!(
                "use the designed library: {name} needs {}, which this person cannot {} (--without); {model}{}",
                items.join(" and "),
                if breaths_only { "breathe" } else { "make" },
                same_study
                    .map(|s| format!("; the study: {}", study_words(s)))
                    .unwrap_or(other_study)
            ),
        );
    }
    if faster < -1e-6 {
        return verdict(
            Decision::Slower,
            format!(
                "keep {name}: {model}{}; {writing}",
                same_study
                    .map(|s| format!("; the study: {}", study_words(s)))
                    .unwrap_or(other_study)
            ),
        );
    }
    let model_better = faster >= NEAR_OPTIMAL || fewer_wrong >= FEWER_WRONG;
    if let Some(s) = same_study {
        let study = study_words(s);
        return match found(s) {
            Found::Slower => verdict(
                Decision::Slower,
                format!(
                    "keep {name}: the study measures the designed library slower, {study}, though {model}; {writing}"
                ),
            ),
            Found::Faster => verdict(
                Decision::Switch,
                format!(
                    "switch to the designed library: the study measures it faster, {study}; {model}"
                ),
            ),
            Found::Nothing if model_better => verdict(
                Decision::Keep,
                format!(
                    "no measurable difference in the study ({study}) though {model}: keep {name}"
                ),
            ),
            Found::Nothing => verdict(
                Decision::Keep,
                format!(
                    "keep {name}: it is near-optimal ({model}) and the study measures no difference ({study})"
                ),
            ),
        };
    }
    let unmeasured = if e.study.is_some() {
        ""
    } else {
        " (the model; no study)"
    };
    if model_better {
        verdict(
            Decision::Switch,
            format!(
                "switch to the designed library if the person's use is {}: {model}{unmeasured}{other_study}",
                e.usage
            ),
        )
    } else {
        verdict(
            Decision::Keep,
            format!("keep {name}: it is near-optimal, {model}{unmeasured}{other_study}"),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(
        before_ms: f64,
        designed_ms: f64,
        before_wrong: f64,
        designed_wrong: f64,
    ) -> ModelFigures {
        ModelFigures {
            before_ms,
            designed_ms,
            before_wrong,
            designed_wrong,
        }
    }

    fn study(same_usage: bool, per_change_s: (f64, f64), tasks: &[(f64, f64)]) -> StudyFigures {
        StudyFigures {
            same_usage,
            per_change_s,
            tasks: tasks.to_vec(),
            wrong: (10, 4),
        }
    }

    fn evidence(model: ModelFigures, study: Option<StudyFigures>) -> Evidence<'static> {
        Evidence {
            name: "the built-in library",
            usage: "the study's tasks",
            model,
            unbreathable: Vec::new(),
            study,
            forced: false,
        }
    }

    #[test]
    fn a_library_the_person_cannot_breathe_is_never_kept() {
        let e = Evidence {
            unbreathable: vec![Token::Breath(crate::control::action::Action::LongSip)],
            ..evidence(model(1000.0, 1010.0, 0.03, 0.03), None)
        };
        let v = verdict(&e);
        assert_eq!(v.decision, Decision::Switch);
        assert!(v.may_write());
        assert!(
            v.text.starts_with("use the designed library: the built-in library needs long sips, which this person cannot breathe"),
            "{}",
            v.text
        );
        assert!(v.text.contains("1.0 % slower"), "{}", v.text);
    }

    #[test]
    fn a_gesture_the_person_cannot_make_is_named() {
        let shake = crate::control::gesture::name::GestureName::new("shake").unwrap();
        let e = Evidence {
            unbreathable: vec![Token::Gesture(shake)],
            ..evidence(model(2000.0, 2100.0, 0.0, 0.0), None)
        };
        let v = verdict(&e);
        assert_eq!(v.decision, Decision::Switch);
        assert!(
            v.text.starts_with("use the designed library: the built-in library needs `shake`, which this person cannot make (--without); the model expects the designed library 5.0 % slower and never wrong (nor is the other) for "),
            "{}",
            v.text
        );
    }

    #[test]
    fn libraries_never_wrong_are_compared_on_time_alone() {
        // Both 0 % wrong: not "100 % less often wrong", and 1 % faster
        // is near-optimal.
        let v = verdict(&evidence(model(2000.0, 1980.0, 0.0, 0.0), None));
        assert_eq!(v.decision, Decision::Keep, "{}", v.text);
        assert!(
            v.text
                .contains("1.0 % faster and never wrong (nor is the other)"),
            "{}",
            v.text
        );
        let v = verdict(&evidence(model(2000.0, 1980.0, 0.0, 0.02), None));
        assert!(
            v.text
                .contains("wrong in 2.00 % of attempts (the other never is)"),
            "{}",
            v.text
        );
    }

    #[test]
    fn slower_in_the_model_is_kept_and_not_written() {
        let v = verdict(&evidence(model(1000.0, 1100.0, 0.03, 0.02), None));
        assert_eq!(v.decision, Decision::Slower);
        assert!(!v.may_write());
        assert_eq!(
            v.text,
            "keep the built-in library: the model expects the designed library 10.0 % slower and 33 % less often wrong for the study's tasks (1.00 → 1.10 s per selection); not written without --force"
        );
    }

    #[test]
    fn slower_but_forced_says_it_is_written() {
        let e = Evidence {
            forced: true,
            ..evidence(model(1000.0, 1100.0, 0.03, 0.02), None)
        };
        let v = verdict(&e);
        assert_eq!(v.decision, Decision::Slower);
        assert!(
            v.text
                .ends_with("(1.00 → 1.10 s per selection); written because of --force"),
            "{}",
            v.text
        );
        let s = study(
            true,
            (1.37, 1.45),
            &[(-5.0, 0.01), (-1.0, 0.02), (-4.0, 0.3)],
        );
        let e = Evidence {
            forced: true,
            ..evidence(model(1000.0, 970.0, 0.03, 0.03), Some(s))
        };
        let v = verdict(&e);
        assert_eq!(v.decision, Decision::Slower);
        assert!(
            v.text.ends_with("; written because of --force"),
            "{}",
            v.text
        );
    }

    #[test]
    fn the_model_better_but_the_study_measuring_nothing_keeps_it() {
        let s = study(
            true,
            (1.370, 1.365),
            &[(0.5, 0.16), (0.0, 0.89), (0.3, 0.4)],
        );
        let v = verdict(&evidence(model(1000.0, 982.0, 0.03, 0.0108), Some(s)));
        assert_eq!(v.decision, Decision::Keep);
        assert!(v.may_write());
        assert!(
            v.text.starts_with("no measurable difference in the study (per mode change 1.37 → 1.36 s (0.4 % faster), p 0.16–0.89, wrong selections 10 → 4) though the model expects the designed library 1.8 % faster and 64 % less often wrong"),
            "{}",
            v.text
        );
        assert!(
            v.text.ends_with(": keep the built-in library"),
            "{}",
            v.text
        );
    }

    #[test]
    fn near_optimal_and_no_difference_keeps_it() {
        let s = study(
            true,
            (1.37, 1.38),
            &[(-0.7, 0.29), (0.3, 0.26), (-0.3, 0.89)],
        );
        let v = verdict(&evidence(model(1000.0, 990.0, 0.03, 0.03), Some(s)));
        assert_eq!(v.decision, Decision::Keep);
        assert!(
            v.text
                .starts_with("keep the built-in library: it is near-optimal"),
            "{}",
            v.text
        );
    }

    #[test]
    fn the_study_measuring_it_faster_switches() {
        let s = study(
            true,
            (1.48, 1.44),
            &[(0.9, 0.059), (0.3, 0.012), (1.2, 0.013)],
        );
        let v = verdict(&evidence(model(1480.0, 1430.0, 0.05, 0.018), Some(s)));
        assert_eq!(v.decision, Decision::Switch);
        assert!(
            v.text.starts_with("switch to the designed library: the study measures it faster, per mode change 1.48 → 1.44 s (2.7 % faster), p 0.01–0.06"),
            "{}",
            v.text
        );
    }

    #[test]
    fn the_study_measuring_it_slower_on_its_usage_refuses_it() {
        let s = study(
            true,
            (1.37, 1.45),
            &[(-5.0, 0.01), (-1.0, 0.02), (-4.0, 0.3)],
        );
        let v = verdict(&evidence(model(1000.0, 970.0, 0.03, 0.03), Some(s)));
        assert_eq!(v.decision, Decision::Slower);
        assert!(!v.may_write());
    }

    #[test]
    fn a_study_of_another_usage_is_reported_beside_the_model() {
        let s = study(
            false,
            (1.37, 1.65),
            &[(-7.8, 0.012), (-1.6, 0.012), (-6.5, 0.012)],
        );
        let e = Evidence {
            usage: "every entry as often",
            ..evidence(model(1735.0, 1661.0, 0.0312, 0.0312), Some(s))
        };
        let v = verdict(&e);
        assert_eq!(v.decision, Decision::Switch);
        assert_eq!(
            v.text,
            "switch to the designed library if the person's use is every entry as often: the model expects the designed library 4.3 % faster and 0 % less often wrong for every entry as often (1.74 → 1.66 s per selection); the study measured its tasks instead, another usage: per mode change 1.37 → 1.65 s (20.4 % slower), p 0.01, wrong selections 10 → 4"
        );
    }

    #[test]
    fn near_optimal_without_a_study_says_it_is_the_model() {
        let v = verdict(&evidence(model(1000.0, 995.0, 0.03, 0.029), None));
        assert_eq!(v.decision, Decision::Keep);
        assert_eq!(
            v.text,
            "keep the built-in library: it is near-optimal, the model expects the designed library 0.5 % faster and 3 % less often wrong for the study's tasks (1.00 → 0.99 s per selection) (the model; no study)"
        );
    }
}
