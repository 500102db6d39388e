//! Drift: how a user's breaths in a new session differ from those their
//! profile was fitted on, read from the profile's header (each kind's
//! plateau and length, as [`profile`](super::profile) writes them), and
//! whether the settings in use still read them: the verdict a re-fit
//! ends with.

use crate::fit::summary::Class;
use crate::fit::{Fit, MAX_CONFUSION};

/// A change this large (a fraction of the fitted value) is worth a re-fit.
pub const REFIT_FRACTION: f64 = 0.2;

/// A change must also stand this many standard errors clear of the
/// person's own spread to be judged: a session's few breaths of a kind
/// scatter about their mean by the spread over the root of their count,
/// so three or four long puffs can differ by 20 % by chance alone.
pub const CLEAR_BY_STANDARD_ERRORS: f64 = 3.0;

/// One kind's plateau and length at fitting, from a profile's header.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fitted {
    /// Its words, e.g. "long puff".
    pub words: &'static str,
    /// How many breaths of it the fit measured.
    pub breaths: usize,
    /// Mean plateau, volts.
    pub plateau_volts: f64,
    /// The plateaus' standard deviation, volts.
    pub plateau_sd: f64,
    /// Mean length, ms.
    pub ms: f64,
    /// The lengths' standard deviation, ms.
    pub ms_sd: f64,
}

/// The kinds a profile's header lists: lines like `# 8 × short puff:
/// plateau 1.13 ± 0.05 V (weakest 1.06), 146 ± 30 ms (106–186)`.
pub fn fitted(profile_text: &str) -> Vec<Fitted> {
    let asks = [
        "short puff",
        "long puff",
        "short sip",
        "long sip",
        "longest comfortable puff",
        "longest comfortable sip",
    ];
    profile_text
        .lines()
        .filter_map(|line| {
            let (breaths, rest) = line.strip_prefix("# ")?.split_once(" × ")?;
            let (words, rest) = rest.split_once(": plateau ")?;
            let words = *asks.iter().find(|a| **a == words)?;
            let (plateau, rest) = rest.split_once(" ± ")?;
            let (plateau_sd, rest) = rest.split_once(" V")?;
            let (_, rest) = rest.split_once("), ")?;
            let (ms, rest) = rest.split_once(" ± ")?;
            let (ms_sd, _) = rest.split_once(" ms")?;
            Some(Fitted {
                words,
                breaths: breaths.parse().ok()?,
                plateau_volts: plateau.parse().ok()?,
                plateau_sd: plateau_sd.parse().ok()?,
                ms: ms.parse().ok()?,
                ms_sd: ms_sd.parse().ok()?,
            })
        })
        .collect()
}

/// What the session's breaths of one kind say against the fitting.
#[derive(Debug, Clone, PartialEq)]
pub struct Drifts {
    /// Each change of more than [`REFIT_FRACTION`] that stands
    /// [`CLEAR_BY_STANDARD_ERRORS`] clear of chance, in plain words.
    pub moved: Vec<String>,
    /// Each change of more than [`REFIT_FRACTION`] that the person's own
    /// spread could give by chance with this few breaths: not judged.
    pub unclear: Vec<String>,
}

/// Each kind whose plateau or length moved by more than
/// [`REFIT_FRACTION`]: judged when the change stands clear of chance,
/// said as unclear when it does not.
pub fn drift(then: &[Fitted], now: &[Class]) -> Drifts {
    let mut found = Drifts {
        moved: Vec::new(),
        unclear: Vec::new(),
    };
    for class in now.iter().filter(|c| c.breaths > 0) {
        let words = class.ask.words();
        let Some(was) = then.iter().find(|f| f.words == words) else {
            continue;
        };
        // The standard error of the difference of the two means, in
        // units of the person's spread (the larger of the fitting's and
        // this session's: one session's breaths may scatter more).
        let se = (1.0 / class.breaths as f64 + 1.0 / was.breaths.max(1) as f64).sqrt();
        for (what, before, after, sd, unit) in [
            (
                "shorter",
                was.ms,
                class.duration_ms.mean,
                was.ms_sd.max(class.duration_ms.sd),
                "ms",
            ),
            (
                "weaker",
                was.plateau_volts,
                class.plateau_volts.mean,
                was.plateau_sd.max(class.plateau_volts.sd),
                "V",
            ),
        ] {
            if before <= 0.0 {
                continue;
            }
            let change = (after - before) / before;
            if change.abs() <= REFIT_FRACTION {
                continue;
            }
            let word = match (what, change < 0.0) {
                ("shorter", true) => "shorter",
                ("shorter", false) => "longer",
                (_, true) => "weaker",
                (_, false) => "stronger",
            };
            let said = format!(
                "your {words}s are {:.0} % {word} than at fitting ({before:.2} → {after:.2} {unit})",
                100.0 * change.abs()
            );
            if (after - before).abs() > CLEAR_BY_STANDARD_ERRORS * sd * se {
                found.moved.push(format!("{said}: re-fit suggested"));
            } else {
                let digits = if unit == "ms" { 0 } else { 2 };
                found.unclear.push(format!(
                    "{said} over {} breath{}, which the spread of your breaths (± {sd:.digits$} {unit}) could give by chance: not judged",
                    class.breaths,
                    if class.breaths == 1 { "" } else { "s" }
                ));
            }
        }
    }
    found
}

/// The profile a designed library was made for, from its header's first
/// line (`# sipnpuff library designed by … for measured by the profile
/// PATH`): its fitted measurements are the person's.
pub fn designed_for(library_text: &str) -> Option<&str> {
    let first = library_text.lines().next()?;
    let rest = first.strip_prefix("# sipnpuff library designed by ")?;
    let (_, path) = rest.split_once(" the profile ")?;
    Some(path.trim()).filter(|p| !p.is_empty())
}

/// Share of the session's breaths the settings in use must read as meant
/// for them to be kept.
pub const KEEP_READ_RIGHT: f64 = 0.95;

/// What a re-fit concludes: the lines to say, in order, the last one the
/// verdict.
#[derive(Debug, Clone, PartialEq)]
pub struct Verdict {
    /// Each finding, then the verdict.
    pub lines: Vec<String>,
    /// Whether a re-fit is suggested.
    pub refit: bool,
}

/// The verdict on `fit`, a session read with the settings in use:
/// against the fitted measurements `then` (from `source`; `None`: there
/// are none, and `source` says why), and whether those settings read the
/// session's breaths as meant (`meant`: "as you made them" in ordinary
/// use, "as asked" in a calibration). Always ends with a verdict line,
/// "no drift" included.
pub fn verdict(then: Option<&[Fitted]>, source: &str, fit: &Fit, meant: &str) -> Verdict {
    let mut lines = Vec::new();
    let mut reasons = Vec::new();
    match then {
        Some(then) => {
            let Drifts { moved, unclear } = drift(then, &fit.classes);
            if moved.is_empty() {
                let which = if unclear.is_empty() {
                    ""
                } else {
                    " or too few to tell from chance"
                };
                lines.push(format!(
                    "drift: none — every kind of breath in this session is within {:.0} % of its length and strength at fitting{which} ({source})",
                    100.0 * REFIT_FRACTION
                ));
            } else {
                reasons.push(format!(
                    "{} moved more than {:.0} % since fitting",
                    moved.len(),
                    100.0 * REFIT_FRACTION
                ));
                lines.extend(moved.into_iter().map(|m| format!("drift: {m}")));
            }
            lines.extend(unclear.into_iter().map(|f| format!("drift: {f}")));
        }
        None => lines.push(format!(
            "drift: not measured: {source}; the session is judged by how the settings in use read it"
        )),
    }
    let (right, asked) = fit.replayed[0].right();
    let now = &fit.predicted[0];
    let worst = now.worst_confusion();
    let missed = now.puff.missed.max(now.sip.missed);
    lines.push(format!(
        "the settings in use read {right}/{asked} of the session's breaths {meant}; predicted: {:.1} % of one length read as the other, {:.1} % missed",
        100.0 * worst,
        100.0 * missed
    ));
    if (right as f64) < KEEP_READ_RIGHT * asked as f64 {
        reasons.push(format!(
            "the settings in use read only {right}/{asked} of your breaths {meant}"
        ));
    }
    if worst > MAX_CONFUSION || missed > MAX_CONFUSION {
        reasons.push(format!(
            "the settings in use are predicted to misread {:.0} % of a kind of breath",
            100.0 * worst.max(missed)
        ));
    }
    let faults = fit.replayed[0].faults;
    if faults > 0 {
        reasons.push(format!(
            "the settings in use stopped the arm {faults} time{} (a breath held past detector.max_hold_ms = {} ms, or a sensor fault)",
            if faults == 1 { "" } else { "s" },
            fit.current.max_hold_ms
        ));
    }
    let refit = !reasons.is_empty();
    lines.push(if refit {
        format!("verdict: re-fit suggested: {}", reasons.join("; "))
    } else {
        "verdict: no drift — the settings in use still read you; no re-fit needed".to_string()
    });
    Verdict { lines, refit }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_profiles_header_is_read_back() {
        let text = "# sipnpuff profile\n# 8 × long puff: plateau 1.28 ± 0.12 V (weakest 1.09), 795 ± 166 ms (586–1013)\n# 3 × longest comfortable sip: plateau 0.40 ± 0.02 V (weakest 0.38), 4100 ± 200 ms (3900–4300)\n[detector]\n";
        assert_eq!(
            fitted(text),
            [
                Fitted {
                    words: "long puff",
                    breaths: 8,
                    plateau_volts: 1.28,
                    plateau_sd: 0.12,
                    ms: 795.0,
                    ms_sd: 166.0,
                },
                Fitted {
                    words: "longest comfortable sip",
                    breaths: 3,
                    plateau_volts: 0.40,
                    plateau_sd: 0.02,
                    ms: 4100.0,
                    ms_sd: 200.0,
                }
            ]
        );
    }

    #[test]
    fn a_designed_librarys_profile_is_found() {
        let text = "# sipnpuff library designed by sipnpuff 0.1.0 for measured by the profile /p/anna.toml\n# usage: x\n";
        assert_eq!(designed_for(text), Some("/p/anna.toml"));
        assert_eq!(
            designed_for(
                "# sipnpuff library designed by sipnpuff 0.1.0 for the study's simulated user\n"
            ),
            None
        );
        assert_eq!(designed_for("# sipnpuff profile for \"a\"\n"), None);
    }
}
