//! A library analysed for one person and one usage mix: per entry, the
//! expected time from deciding to select it to being in it (retries
//! included), the chance an attempt selects another entry instead, which
//! entries one misreading apart; over the library, the usage-weighted
//! time and error per selection, and findings in plain words.
//!
//! Each attempt is one [`reading`](crate::design::reading::readings) of
//! the meant sequence. An attempt that selects the entry ends it; one
//! that resets is tried again at once; one that selects another entry
//! costs the time to notice and undo it (by default the inactivity
//! timeout that returns to selection) and is tried again. Attempts being
//! independent, the expected time is the mean attempt time over the
//! chance of success (Wald's identity).

use serde::Serialize;

use crate::config::Config;
use crate::control::action::{Action, ActionSeq};
use crate::control::selection::SequenceEntry;
use crate::control::target::Target;
use crate::design::breathing::{Breathing, RatesFrom};
use crate::design::reading::{Decision, Deviation, SequenceReading, outcome, readings};
use crate::design::usage::Usage;

/// The times an attempt is made of, ms.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AttemptTiming {
    /// From the interface ready to the first burst.
    pub reaction_ms: f64,
    /// Between bursts.
    pub gap_ms: f64,
    /// Each burst's rise and fall beyond its length.
    pub edge_ms: f64,
    /// `matcher.sequence_timeout_ms`: the wait on a prefix.
    pub timeout_ms: f64,
    /// From a burst's end to the detector reading it.
    pub latency_ms: f64,
    /// A wrong selection's cost beyond the attempt: the time to notice
    /// and undo it.
    pub wrong_cost_ms: f64,
}

impl AttemptTiming {
    /// The person's reaction and gaps under `config`; a wrong selection
    /// costs `wrong_cost_ms`, or the inactivity timeout (the user lets
    /// the wrong mode return to selection) if `None`.
    pub fn of(who: &Breathing, config: &Config, wrong_cost_ms: Option<f64>) -> AttemptTiming {
        let core = config.core();
        AttemptTiming {
            reaction_ms: who.reaction_ms,
            gap_ms: who.gap_ms,
            edge_ms: who.edge_ms,
            timeout_ms: f64::from(core.matcher().sequence_timeout_ms),
            latency_ms: f64::from(core.detector().glitch_ms),
            wrong_cost_ms: wrong_cost_ms
                .unwrap_or_else(|| f64::from(core.command().inactivity_timeout_ms)),
        }
    }
}

/// One entry, analysed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EntryAnalysis {
    /// The bursts, as the paper codes them.
    pub actions: Vec<i8>,
    /// What it selects or fires (`"mode": "translate_x"`, `"key": …`).
    #[serde(flatten)]
    pub target: Target,
    /// Its share of selections.
    pub usage: f64,
    /// Expected time from deciding to select it to being in it, retries
    /// and undoing wrong selections included, ms.
    pub expected_ms: f64,
    /// One attempt breathed right, ms.
    pub attempt_ms: f64,
    /// The timeout it waits because a longer entry starts with it, ms.
    pub wait_ms: f64,
    /// Chance an attempt selects another entry.
    pub p_wrong: f64,
    /// Chance an attempt selects nothing (a reset, tried again).
    pub p_retry: f64,
    /// Chance per selection (any entry meant) that this entry is selected
    /// when another was meant.
    pub p_selected_by_mistake: f64,
    /// The entries an attempt lands in instead, and how.
    pub confusions: Vec<Misselection>,
}

/// An attempt at one entry landing in another.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Misselection {
    /// The entry it lands in (its index in the library).
    pub entry: usize,
    /// Its label.
    pub label: String,
    /// Chance per attempt.
    pub p: f64,
    /// The misreading, in words ("the 2nd burst at the other length").
    pub how: String,
}

/// A library analysed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Analysis {
    /// Whose breathing.
    pub user: String,
    /// Which usage mix.
    pub usage: String,
    /// The times used.
    pub timing: AttemptTiming,
    /// Each entry, in the library's order.
    pub entries: Vec<EntryAnalysis>,
    /// Usage-weighted expected time per selection, ms.
    pub expected_ms_per_selection: f64,
    /// Usage-weighted chance that an attempt selects a wrong entry.
    pub p_wrong_per_selection: f64,
    /// The rates the analysis uses, each with where it comes from.
    pub rates: Vec<Rate>,
    /// What stands out, in plain words.
    pub findings: Vec<String>,
}

/// One rate the analysis uses and where it comes from: measured by the
/// fit, modelled, or assumed (the study population's, or nobody's).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Rate {
    /// What happens ("long puff read as short puff").
    pub what: String,
    /// Its value: a fraction, or per hour for false bursts.
    pub value: f64,
    /// `"fraction"` or `"per_hour"`.
    pub unit: &'static str,
    /// "measured (fit)", "assumed (the study's population)", ….
    pub source: String,
}

/// The rates `who` brings, measured apart from assumed.
pub fn rates(who: &Breathing) -> Vec<Rate> {
    let detector = who.rates_from.label();
    let rate = |what: String, value: f64, unit: &'static str, source: &str| Rate {
        what,
        value,
        unit,
        source: source.to_string(),
    };
    let mut out = Vec::new();
    for a in Action::ALL {
        let b = who.burst(a);
        out.push(rate(
            format!("{a} read as {}", crate::design::reading::other_length(a)),
            b.other_length,
            "fraction",
            detector,
        ));
        out.push(rate(format!("{a} missed"), b.missed, "fraction", detector));
    }
    out.push(rate(
        "false bursts".into(),
        who.false_per_hour,
        "per_hour",
        match who.rates_from {
            RatesFrom::FitLengths => "assumed (the profile predicts none)",
            other => other.label(),
        },
    ));
    out.push(rate(
        "selections breathed with one burst at the wrong length".into(),
        who.error_rate,
        "fraction",
        "assumed (the study's population)",
    ));
    out.push(rate(
        "bursts read as the other breath".into(),
        who.swap_rate,
        "fraction",
        if who.swap_rate > 0.0 {
            "given (--swap-rate)"
        } else {
            "assumed (nothing measures it; --swap-rate gives one)"
        },
    ));
    out
}

/// The rates in lines, one per source.
fn rates_text(rates: &[Rate]) -> String {
    let mut sources: Vec<&str> = Vec::new();
    for r in rates {
        if !sources.contains(&r.source.as_str()) {
            sources.push(&r.source);
        }
    }
    let mut out = String::new();
    for source in sources {
        let items: Vec<String> = rates
            .iter()
            .filter(|r| r.source == source)
            .map(|r| match r.unit {
                "per_hour" => format!("{} {:.2} per hour", r.what, r.value),
                _ => format!("{} {:.2} %", r.what, 100.0 * r.value),
            })
            .collect();
        out += &format!("rates {source}: {}\n", items.join(", "));
    }
    out
}

/// The cost of one entry in a library of sequences.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EntryCost {
    /// Expected time to be in it, ms.
    pub expected_ms: f64,
    /// One attempt breathed right, ms (timeout wait included).
    pub attempt_ms: f64,
    /// Chance an attempt selects another entry.
    pub p_wrong: f64,
    /// Chance an attempt selects nothing.
    pub p_retry: f64,
    /// Whether a longer entry starts with it.
    pub waits: bool,
}

/// Time from the decision to the end of the first `k` bursts of `read`:
/// the last one's fall is still to come, half its edge.
fn breathed_ms(read: &[Action], k: usize, who: &Breathing, t: &AttemptTiming) -> f64 {
    t.reaction_ms
        + read[..k].iter().map(|a| who.burst(*a).mean_ms).sum::<f64>()
        + k.saturating_sub(1) as f64 * t.gap_ms
        + (k as f64 - 0.5).max(0.0) * t.edge_ms
}

/// The cost of entry `meant` of `library` (each entry's bursts), and
/// where its wrong attempts land (`landed(entry, p, deviation)`).
pub fn entry_cost<'a>(
    meant: usize,
    library: &'a [&'a [Action]],
    who: &Breathing,
    t: &AttemptTiming,
    landed: impl FnMut(usize, f64, Deviation),
) -> EntryCost {
    entry_cost_of(
        &readings(library[meant], who),
        meant,
        library,
        who,
        t,
        landed,
    )
}

/// [`entry_cost`] with the meant entry's readings given.
pub fn entry_cost_of<'a>(
    readings: &[SequenceReading],
    meant: usize,
    library: &'a [&'a [Action]],
    who: &Breathing,
    t: &AttemptTiming,
    mut landed: impl FnMut(usize, f64, Deviation),
) -> EntryCost {
    let lookup = |i: usize| library.get(i).copied();
    let (mut mean_attempt, mut p_ok, mut p_wrong, mut p_retry) = (0.0, 0.0, 0.0, 0.0);
    let mut attempt_ms = 0.0;
    let mut waits = false;
    for r in readings {
        let read = r.read.as_slice();
        let all = breathed_ms(read, read.len(), who, t);
        let ms = match outcome(read, lookup) {
            Decision::Match { entry, at, waited } if entry == meant => {
                p_ok += r.p;
                let ms = breathed_ms(read, at, who, t)
                    + t.latency_ms
                    + if waited { t.timeout_ms } else { 0.0 };
                if r.deviation == Deviation::None {
                    attempt_ms = ms;
                    waits = waited;
                }
                ms
            }
            Decision::Match { entry, waited, .. } => {
                p_wrong += r.p;
                landed(entry, r.p, r.deviation);
                all + if waited { t.timeout_ms } else { 0.0 } + t.wrong_cost_ms
            }
            Decision::Nothing { waited } => {
                p_retry += r.p;
                all + t.latency_ms + if waited { t.timeout_ms } else { 0.0 }
            }
        };
        mean_attempt += r.p * ms;
    }
    EntryCost {
        expected_ms: if p_ok > 0.0 {
            mean_attempt / p_ok
        } else {
            f64::INFINITY
        },
        attempt_ms,
        p_wrong,
        p_retry,
        waits,
    }
}

/// Analyses `library` for `who` under `usage` and `timing`.
pub fn analyse(
    library: &[SequenceEntry],
    who: &Breathing,
    usage: &Usage,
    timing: &AttemptTiming,
) -> Analysis {
    let breaths: Vec<ActionSeq> = library.iter().map(breaths_of).collect();
    let sequences: Vec<&[Action]> = breaths.iter().map(ActionSeq::as_slice).collect();
    let n = library.len();
    // landed_in[j][i]: chance an attempt at i lands in j.
    let mut landed_in = vec![vec![0.0; n]; n];
    let mut entries = Vec::with_capacity(n);
    for (i, entry) in library.iter().enumerate() {
        let mut confusions: Vec<Misselection> = Vec::new();
        let cost = entry_cost(i, &sequences, who, timing, |j, p, deviation| {
            landed_in[j][i] += p;
            let how = how(deviation, sequences[i]);
            match confusions.iter_mut().find(|c| c.entry == j && c.how == how) {
                Some(c) => c.p += p,
                None => confusions.push(Misselection {
                    entry: j,
                    label: library[j].target.label(),
                    p,
                    how,
                }),
            }
        });
        confusions.sort_by(|a, b| b.p.total_cmp(&a.p));
        entries.push(EntryAnalysis {
            actions: breaths_of(entry).codes().collect(),
            target: entry.target,
            usage: usage.shares.get(i).copied().unwrap_or(0.0),
            expected_ms: cost.expected_ms,
            attempt_ms: cost.attempt_ms,
            wait_ms: if cost.waits { timing.timeout_ms } else { 0.0 },
            p_wrong: cost.p_wrong,
            p_retry: cost.p_retry,
            p_selected_by_mistake: 0.0,
            confusions,
        });
    }
    for (j, e) in entries.iter_mut().enumerate() {
        e.p_selected_by_mistake = landed_in[j]
            .iter()
            .zip(&usage.shares)
            .map(|(p, share)| p * share)
            .sum();
    }
    let weighted =
        |f: fn(&EntryAnalysis) -> f64| -> f64 { entries.iter().map(|e| e.usage * f(e)).sum() };
    let mut analysis = Analysis {
        user: who.source.clone(),
        usage: usage.source.clone(),
        timing: *timing,
        expected_ms_per_selection: weighted(|e| e.expected_ms),
        p_wrong_per_selection: weighted(|e| e.p_wrong),
        entries,
        rates: rates(who),
        findings: Vec::new(),
    };
    analysis.findings = findings(&analysis, library, who);
    analysis
}

/// "the 2nd burst at the other length".
fn how(deviation: Deviation, meant: &[Action]) -> String {
    let nth = |i: usize| ordinal(i + 1);
    match deviation {
        Deviation::None => "read as breathed".into(),
        Deviation::Length(i) => format!(
            "its {} burst ({}) read as {}",
            nth(i),
            meant[i],
            crate::design::reading::other_length(meant[i])
        ),
        Deviation::Swapped(i) => format!(
            "its {} burst ({}) read as {}",
            nth(i),
            meant[i],
            crate::design::reading::other_breath(meant[i])
        ),
        Deviation::Missed(i) => format!("its {} burst ({}) missed", nth(i), meant[i]),
        Deviation::Extra(i) => format!("a false burst before its {} burst", nth(i)),
    }
}

fn ordinal(n: usize) -> String {
    match n {
        1 => "1st".into(),
        2 => "2nd".into(),
        3 => "3rd".into(),
        n => format!("{n}th"),
    }
}

/// A finding worth a clinician's attention: each likely confusion, each
/// wait on a prefix, each burst this person's detector often misreads,
/// and the most used entry's time.
fn findings(a: &Analysis, library: &[SequenceEntry], who: &Breathing) -> Vec<String> {
    let mut out = Vec::new();
    let pct = |p: f64| {
        if p >= 0.01 {
            format!("{:.1} %", 100.0 * p)
        } else {
            format!("{:.2} %", 100.0 * p)
        }
    };
    let mut pairs: Vec<(usize, &Misselection)> = a
        .entries
        .iter()
        .enumerate()
        .flat_map(|(i, e)| e.confusions.iter().map(move |c| (i, c)))
        .filter(|(_, c)| c.p >= 0.001)
        .collect();
    pairs.sort_by(|x, y| y.1.p.total_cmp(&x.1.p));
    for (i, c) in pairs.iter().take(5) {
        out.push(format!(
            "`{}` lands in `{}` when {}: {} of `{}` attempts for this user",
            a.entries[*i].target.label(),
            c.label,
            c.how,
            pct(c.p),
            a.entries[*i].target.label()
        ));
    }
    for (i, e) in a.entries.iter().enumerate() {
        if e.wait_ms > 0.0 {
            let longer = library
                .iter()
                .filter(|o| {
                    o.actions.len() > library[i].actions.len()
                        && o.actions
                            .as_slice()
                            .starts_with(library[i].actions.as_slice())
                })
                .map(|o| format!("`{}`", o.target.label()))
                .collect::<Vec<_>>();
            out.push(format!(
                "`{}` is the start of {}: every `{}` waits the {:.0} ms timeout",
                e.target.label(),
                longer.join(", "),
                e.target.label(),
                e.wait_ms
            ));
        }
    }
    for a in Action::ALL {
        let b = who.burst(a);
        if b.other_length >= 0.02 {
            out.push(format!(
                "this user's {a}s are read at the other length {} of the time ({}): a library without them is more reliable (`design --without {}`)",
                pct(b.other_length),
                who.rates_from.label(),
                a.to_string().replace(' ', "_")
            ));
        }
        if b.missed >= 0.02 {
            out.push(format!(
                "this user's {a}s are missed {} of the time ({})",
                pct(b.missed),
                who.rates_from.label()
            ));
        }
    }
    if let Some(top) = a
        .entries
        .iter()
        .max_by(|x, y| x.usage.total_cmp(&y.usage))
        .filter(|top| a.entries.iter().any(|e| e.usage < top.usage))
    {
        out.push(format!(
            "the most used entry, `{}` ({:.0} % of selections), takes {:.2} s",
            top.target.label(),
            100.0 * top.usage,
            top.expected_ms / 1000.0
        ));
    }
    out
}

/// The analysis as a table and its findings.
pub fn text(a: &Analysis) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(out, "user: {}\nusage: {}", a.user, a.usage);
    let _ = writeln!(out, "{}", rates_text(&a.rates));
    let _ = writeln!(
        out,
        "| entry | bursts | used | expected s | wait s | wrong % | retry % | lands in |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|");
    for e in &a.entries {
        let bursts: Vec<String> = e.actions.iter().map(i8::to_string).collect();
        let lands = e
            .confusions
            .iter()
            .take(2)
            .map(|c| format!("{} {:.2} %", c.label, 100.0 * c.p))
            .collect::<Vec<_>>()
            .join(", ");
        let _ = writeln!(
            out,
            "| {} | {} | {:.0} % | {:.2} | {:.1} | {:.2} | {:.2} | {} |",
            e.target.label(),
            bursts.join(" "),
            100.0 * e.usage,
            e.expected_ms / 1000.0,
            e.wait_ms / 1000.0,
            100.0 * e.p_wrong,
            100.0 * e.p_retry,
            if lands.is_empty() {
                "—".into()
            } else {
                lands
            }
        );
    }
    let _ = writeln!(
        out,
        "\nper selection: {:.2} s expected, {:.2} % of attempts select a wrong entry",
        a.expected_ms_per_selection / 1000.0,
        100.0 * a.p_wrong_per_selection
    );
    for f in &a.findings {
        let _ = writeln!(out, "- {f}");
    }
    out
}

/// An entry's breaths (a library with gestures is refused before any
/// design: [`crate::design::designing`]).
pub(crate) fn breaths_of(entry: &SequenceEntry) -> ActionSeq {
    entry.breaths().unwrap_or(ActionSeq::EMPTY)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::detector::DetectorConfig;
    use crate::sim::user::UserModel;

    fn study_user() -> Breathing {
        Breathing::of_model(&UserModel::POPULATION, &DetectorConfig::default(), "study")
    }

    #[test]
    fn a_two_short_burst_entry_takes_the_bursts_the_gap_and_the_reaction() {
        let config = Config::default();
        let library = config.core().sequences();
        let who = study_user();
        let t = AttemptTiming::of(&who, &config, None);
        let a = analyse(library, &who, &Usage::uniform(library), &t);
        let x = &a.entries[0];
        assert_eq!(
            x.target,
            Target::Mode(crate::control::mode::Mode::TranslateX)
        );
        // 459 ms reaction + 150 + 300 + 150 ms, one and a half edges and
        // 5 ms latency.
        assert!(
            (x.attempt_ms - (t.reaction_ms + 605.0 + 1.5 * t.edge_ms)).abs() < 1e-9,
            "{x:?}"
        );
        assert_eq!(x.wait_ms, 0.0);
        // Half the 5 % mistakes lengthen the first puff: rotate_x (long
        // puff, short puff). The other half lengthen the second: no entry
        // is short puff, long puff, so the matcher resets and she retries.
        assert_eq!(x.p_wrong, 0.025);
        assert_eq!(x.confusions[0].label, "rotate_x");
        assert!((x.p_retry - 0.025).abs() < 0.002, "{x:?}");
    }

    #[test]
    fn a_breath_read_as_the_other_lands_in_the_mirror_entry() {
        let config = Config::default();
        let library = config.core().sequences();
        let who = Breathing {
            swap_rate: 0.01,
            ..study_user()
        };
        let t = AttemptTiming::of(&who, &config, None);
        let a = analyse(library, &who, &Usage::uniform(library), &t);
        // translate_x (short puff, short puff) with its 1st puff read as a
        // sip is fingers (short sip, short puff); with its 2nd, translate_y.
        let x = &a.entries[0];
        let to = |label: &str| x.confusions.iter().find(|c| c.label == label).unwrap();
        assert_eq!(to("fingers").p, 0.01);
        assert_eq!(
            to("fingers").how,
            "its 1st burst (short puff) read as short sip"
        );
        assert_eq!(to("translate_y").p, 0.01);
        assert!((x.p_wrong - 0.045).abs() < 1e-12, "{x:?}");
    }

    #[test]
    fn a_prefix_waits_the_timeout() {
        let config = Config::from_toml_str(crate::sim::study::PREFIX_LIBRARY).unwrap();
        let library = config.core().sequences();
        let who = study_user();
        let t = AttemptTiming::of(&who, &config, None);
        let a = analyse(library, &who, &Usage::uniform(library), &t);
        let waits = a.entries.iter().filter(|e| e.wait_ms == 1000.0).count();
        assert_eq!(waits, 3);
        assert!(
            a.findings
                .iter()
                .any(|f| f.contains("waits the 1000 ms timeout"))
        );
    }
}
