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
use crate::control::action::Action;
use crate::control::selection::SequenceEntry;
use crate::control::sequence::Sequence;
use crate::control::target::Target;
use crate::control::token::Token;
use crate::design::breathing::{Breathing, RatesFrom};
use crate::design::gesturing::Gesturing;
use crate::design::reading::{Decision, Deviation, SequenceReading, outcome, readings};
use crate::design::symbol::{Symbol, SymbolSeq};
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
    /// From a burst's end to the detector reading it (a gesture's wait
    /// for rest is in its time).
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
    /// The bursts, as the paper codes them, and the gestures, by name.
    pub actions: Sequence,
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
    /// The misreading, in words ("its 2nd burst (short puff) read as
    /// long puff").
    pub how: String,
}

/// A library analysed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Analysis {
    /// Whose breathing (and gestures).
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
    /// The person's gestures, when they use a set: each one's time and
    /// how it is read.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gestures: Option<Gesturing>,
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

/// The rates `who` brings, measured apart from assumed: their breaths'
/// unless `breathes` is false (a library of gestures alone for a person
/// with gestures), then their gestures'.
pub fn rates(who: &Breathing, breathes: bool) -> Vec<Rate> {
    let mut out = if breathes {
        breath_rates(who)
    } else {
        Vec::new()
    };
    if let Some(g) = &who.gestures {
        out.extend(gesture_rates(g));
    }
    out
}

/// The rates of `who`'s breaths.
fn breath_rates(who: &Breathing) -> Vec<Rate> {
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

/// The rates a person's gestures bring: each one rejected and read as
/// another, from the set's leave-one-out check; what the set does not
/// measure, assumed.
fn gesture_rates(g: &Gesturing) -> Vec<Rate> {
    let measured = format!("measured (leave-one-out of {})", g.source);
    let rate = |what: String, value: f64, unit: &'static str, source: &str| Rate {
        what,
        value,
        unit,
        source: source.to_string(),
    };
    let mut out = Vec::new();
    for gesture in &g.gestures {
        out.push(rate(
            format!("{} rejected", gesture.name),
            gesture.rejected,
            "fraction",
            &measured,
        ));
        if gesture.taken_for.is_empty() {
            out.push(rate(
                format!("{} read as another gesture", gesture.name),
                0.0,
                "fraction",
                &measured,
            ));
        }
        for taken in &gesture.taken_for {
            out.push(rate(
                format!("{} read as {}", gesture.name, taken.gesture),
                taken.p,
                "fraction",
                &measured,
            ));
        }
    }
    let assumed = "assumed (the set's examples do not measure them)";
    out.push(rate(
        "gestures made wrong by the person".into(),
        0.0,
        "fraction",
        assumed,
    ));
    out.push(rate(
        "ordinary movement taken for a gesture".into(),
        0.0,
        "per_hour",
        assumed,
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

/// Time from the decision to the end of the first `k` items of `read`
/// (a gesture's end: the front end reading it): each burst's rise and
/// fall beyond its length, but a last burst's fall is still to come, half
/// its edge.
#[inline]
fn breathed_ms(read: &[Symbol], k: usize, who: &Breathing, t: &AttemptTiming) -> f64 {
    let made = &read[..k];
    let bursts = made.iter().filter(|s| s.is_burst()).count() as f64;
    let edges = match made.last() {
        Some(s) if s.is_burst() => bursts - 0.5,
        _ => bursts,
    };
    t.reaction_ms
        + made.iter().map(|s| who.time_ms(*s)).sum::<f64>()
        + k.saturating_sub(1) as f64 * t.gap_ms
        + edges.max(0.0) * t.edge_ms
}

/// From the end of the first `k` items of `read` to the matcher seeing
/// the last: the detector's latency after a burst; nothing after a
/// gesture (its wait for rest is in its time).
fn latency_ms(read: &[Symbol], k: usize, t: &AttemptTiming) -> f64 {
    match k.checked_sub(1).and_then(|last| read.get(last)) {
        Some(s) if s.action().is_none() => 0.0,
        _ => t.latency_ms,
    }
}

/// When the matcher decides on reading `r`, ms: `latency` and `wait`
/// after its `k`th item is made (at `made_ms`). A gesture taken for
/// another is read when it ends, so it is timed as made; a rejected one
/// holds the timeout while the head moves, so the matcher decides when
/// it ends if that is later.
fn decided_ms(r: &SequenceReading, made_ms: f64, k: usize, latency: f64, wait: f64) -> f64 {
    let unseen = r.unseen_by(k);
    if unseen == 0.0 {
        made_ms + latency + wait
    } else if matches!(r.deviation, Deviation::Taken(..)) {
        made_ms + unseen + latency + wait
    } else {
        (made_ms + latency + wait).max(made_ms + unseen)
    }
}

/// The cost of entry `meant` of `library` (each entry's items), and
/// where its wrong attempts land (`landed(entry, p, deviation)`).
pub fn entry_cost<'a>(
    meant: usize,
    library: &'a [&'a [Symbol]],
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
    library: &'a [&'a [Symbol]],
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
        let decision = outcome(read, lookup);
        // When the matcher decides: after the `k`th item read, its
        // latency and any wait on a prefix.
        let (k, latency, waited) = match decision {
            Decision::Match { entry, at, waited } if entry == meant => {
                (at, latency_ms(read, at, t), waited)
            }
            Decision::Match { waited, .. } => (read.len(), 0.0, waited),
            Decision::Nothing { waited } => (read.len(), latency_ms(read, read.len(), t), waited),
        };
        let wait = if waited { t.timeout_ms } else { 0.0 };
        let ms = decided_ms(r, breathed_ms(read, k, who, t), k, latency, wait);
        let ms = match decision {
            Decision::Match { entry, .. } if entry == meant => {
                p_ok += r.p;
                if r.deviation == Deviation::None {
                    attempt_ms = ms;
                    waits = waited;
                }
                ms
            }
            Decision::Match { entry, .. } => {
                p_wrong += r.p;
                landed(entry, r.p, r.deviation);
                ms + t.wrong_cost_ms
            }
            Decision::Nothing { .. } => {
                p_retry += r.p;
                ms
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
    let symbols: Vec<SymbolSeq> = library.iter().map(|e| symbols_of(e, who)).collect();
    let sequences: Vec<&[Symbol]> = symbols.iter().map(SymbolSeq::as_slice).collect();
    let n = library.len();
    // landed_in[j][i]: chance an attempt at i lands in j.
    let mut landed_in = vec![vec![0.0; n]; n];
    let mut entries = Vec::with_capacity(n);
    for (i, entry) in library.iter().enumerate() {
        let mut confusions: Vec<Misselection> = Vec::new();
        let cost = entry_cost(i, &sequences, who, timing, |j, p, deviation| {
            landed_in[j][i] += p;
            let how = how(deviation, sequences[i], who);
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
            actions: entry.actions,
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
        user: who.described(),
        usage: usage.source.clone(),
        timing: *timing,
        expected_ms_per_selection: weighted(|e| e.expected_ms),
        p_wrong_per_selection: weighted(|e| e.p_wrong),
        entries,
        rates: rates(who, breathes(library, who)),
        findings: Vec::new(),
        gestures: who.gestures.clone(),
    };
    analysis.findings = findings(&analysis, library, who);
    analysis
}

/// Whether `who`'s breaths matter to `library`: any entry has a burst,
/// or the person has no gestures.
fn breathes(library: &[SequenceEntry], who: &Breathing) -> bool {
    who.gestures.is_none()
        || library
            .iter()
            .any(|e| e.actions.as_slice().iter().any(|t| t.action().is_some()))
}

/// "its 2nd burst (short puff) read as long puff": the item by its place
/// in the sequence, what it is, and what became of it.
fn how(deviation: Deviation, meant: &[Symbol], who: &Breathing) -> String {
    let item = |i: usize| {
        let kind = match meant.get(i) {
            Some(s) if s.action().is_none() => "gesture",
            _ => "burst",
        };
        format!("its {} {kind}", ordinal(i + 1))
    };
    let word = |i: usize| meant.get(i).map_or_else(String::new, |s| who.word(*s));
    let burst = |i: usize| meant.get(i).and_then(|s| s.action());
    let read_as = |i: usize, other: Option<Action>| {
        format!(
            "{} ({}) read as {}",
            item(i),
            word(i),
            other.map_or_else(String::new, |a| a.to_string())
        )
    };
    match deviation {
        Deviation::None => "read as breathed".into(),
        Deviation::Length(i) => read_as(i, burst(i).map(crate::design::reading::other_length)),
        Deviation::Swapped(i) => read_as(i, burst(i).map(crate::design::reading::other_breath)),
        Deviation::Missed(i) if burst(i).is_none() => format!("{} ({}) rejected", item(i), word(i)),
        Deviation::Missed(i) => format!("{} ({}) missed", item(i), word(i)),
        Deviation::Extra(i) => format!("a false burst before {}", item(i)),
        Deviation::Taken(i, h) => format!("{} ({}) read as {}", item(i), word(i), who.word(h)),
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
    for a in Action::ALL.into_iter().filter(|_| breathes(library, who)) {
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
    if let Some(g) = &who.gestures {
        for gesture in &g.gestures {
            for taken in gesture.taken_for.iter().filter(|t| t.p >= 0.02) {
                out.push(format!(
                    "this person's `{}` is read as `{}` {} of the time (leave-one-out of {}): record one of them again more distinctly, or leave one out (`design --without {}`)",
                    gesture.name,
                    taken.gesture,
                    pct(taken.p),
                    g.source,
                    gesture.name
                ));
            }
            if gesture.rejected >= 0.02 {
                out.push(format!(
                    "this person's `{}` is rejected {} of the time (leave-one-out of {}): record it again, or leave it out (`design --without {}`)",
                    gesture.name,
                    pct(gesture.rejected),
                    g.source,
                    gesture.name
                ));
            }
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
    let _ = write!(out, "{}", rates_text(&a.rates));
    if let Some(g) = &a.gestures {
        let _ = writeln!(out, "{}", gesture_times(g));
    }
    let _ = writeln!(out);
    let gestures = a.entries.iter().any(|e| e.actions.has_gesture());
    let _ = writeln!(
        out,
        "| entry | {} | used | expected s | wait s | wrong % | retry % | lands in |",
        if gestures { "sequence" } else { "bursts" }
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|---|");
    for e in &a.entries {
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
            written(&e.actions),
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

/// Each gesture's time in words: "gestures timed from their examples
/// (SET): nod 0.84 s, …; each read 0.30 s after it ends (rest_ms)".
fn gesture_times(g: &Gesturing) -> String {
    let times: Vec<String> = g
        .gestures
        .iter()
        .map(|gesture| format!("{} {:.2} s", gesture.name, gesture.mean_ms / 1000.0))
        .collect();
    format!(
        "gestures timed from their examples ({}): {}; each read {:.2} s after it ends (the front end's rest_ms)",
        g.source,
        times.join(", "),
        g.read_ms / 1000.0
    )
}

/// A sequence as the tables write it: bursts by their codes, gestures
/// by name (`nod -1`).
pub fn written(sequence: &Sequence) -> String {
    sequence
        .as_slice()
        .iter()
        .map(|t| match t {
            Token::Breath(a) => a.code().to_string(),
            Token::Gesture(name) => name.to_string(),
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// An entry's symbols for `who` (a gesture not in their set is refused
/// before any analysis: [`crate::design::inputs`]).
pub(crate) fn symbols_of(entry: &SequenceEntry, who: &Breathing) -> SymbolSeq {
    who.symbols(&entry.actions).unwrap_or_default()
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

    /// The study's user with two gestures: a nod of 800 ms, taken for a
    /// shake `taken` of the time and rejected `rejected`; a shake of
    /// 1000 ms, always read right; each read 300 ms after it ends.
    fn with_gestures(taken: f64, rejected: f64) -> Breathing {
        use crate::control::gesture::name::GestureName;
        use crate::design::gesturing::{GestureStats, TakenFor};
        let name = |n: &str| GestureName::new(n).unwrap();
        let gesture = |n: &str, mean_ms: f64| GestureStats {
            name: name(n),
            mean_ms,
            examples: 5,
            rejected: 0.0,
            taken_for: Vec::new(),
        };
        let nod = GestureStats {
            rejected,
            taken_for: vec![TakenFor {
                gesture: name("shake"),
                index: 1,
                p: taken,
            }],
            ..gesture("nod", 800.0)
        };
        Breathing {
            gestures: Some(Gesturing {
                source: "sam.toml".into(),
                read_ms: 300.0,
                gestures: vec![nod, gesture("shake", 1000.0)],
            }),
            ..study_user()
        }
    }

    /// A library of a nod, a shake and a short puff then a nod.
    fn gesture_library() -> Config {
        Config::from_toml_str(
            r#"
[gestures]
set = "sam.toml"

[[sequence]]
actions = ["nod"]
mode = "translate_x"

[[sequence]]
actions = ["shake"]
mode = "translate_y"

[[sequence]]
actions = [-1, "nod"]
mode = "translate_z"
"#,
        )
        .unwrap()
    }

    /// The gesture library analysed for `who`, used uniformly, with the
    /// timing it was analysed with.
    fn analysed_gestures(who: &Breathing) -> (AttemptTiming, Analysis) {
        let config = gesture_library();
        let library = config.core().sequences();
        let t = AttemptTiming::of(who, &config, None);
        let a = analyse(library, who, &Usage::uniform(library), &t);
        (t, a)
    }

    #[test]
    fn a_gesture_always_read_right_costs_its_time_alone() {
        let (t, a) = analysed_gestures(&with_gestures(0.0, 0.0));
        // The reaction, the nod's 800 ms and the front end's 300 ms of
        // rest: no latency, no retry, no wrong entry.
        let nod = &a.entries[0];
        assert_eq!(nod.attempt_ms, t.reaction_ms + 800.0 + 300.0);
        assert_eq!(nod.expected_ms, nod.attempt_ms);
        assert_eq!((nod.p_wrong, nod.p_retry, nod.wait_ms), (0.0, 0.0, 0.0));
        // A short puff (150 ms) with its rise and fall, the gap, then the
        // nod as above; no latency after it.
        let mixed = &a.entries[2];
        assert!(
            (mixed.attempt_ms - (t.reaction_ms + 150.0 + t.edge_ms + 300.0 + 1100.0)).abs() < 1e-9,
            "{mixed:?}"
        );
        assert_eq!(written(&mixed.actions), "-1 nod");
        // Its puff breathed long (the person's 5 % mistakes) resets, and
        // the nod after it selects translate_x.
        assert_eq!(mixed.confusions[0].label, "translate_x");
        assert!((mixed.p_wrong - 0.05).abs() < 0.001, "{mixed:?}");
        assert!(a.rates.iter().any(
            |r| r.what == "nod rejected" && r.source == "measured (leave-one-out of sam.toml)"
        ));
    }

    #[test]
    fn a_gesture_taken_for_another_lands_in_its_entry() {
        let (t, a) = analysed_gestures(&with_gestures(0.2, 0.1));
        let nod = &a.entries[0];
        assert_eq!((nod.p_wrong, nod.p_retry), (0.2, 0.1));
        assert_eq!(nod.confusions[0].label, "translate_y");
        assert_eq!(nod.confusions[0].how, "its 1st gesture (nod) read as shake");
        // Every attempt takes the nod's time; a wrong one the 2 s to
        // return to selection besides; 70 % succeed.
        let attempt = t.reaction_ms + 1100.0;
        assert!(
            (nod.expected_ms - (attempt + 0.2 * 2000.0) / 0.7).abs() < 1e-9,
            "{nod:?}"
        );
        // The shake is read right: selected by mistake a fifth of the
        // nods, a third of the selections.
        let shake = &a.entries[1];
        assert_eq!(shake.p_wrong, 0.0);
        assert!((shake.p_selected_by_mistake - 0.2 / 3.0).abs() < 1e-12);
        // A puff then a nod read as a shake is no entry: tried again.
        let mixed = &a.entries[2];
        assert!(mixed.confusions.iter().all(|c| c.label != "translate_y"));
        assert!(
            a.findings
                .iter()
                .any(|f| f.starts_with("this person's `nod` is read as `shake` 20.0 % of the time")),
            "{:?}",
            a.findings
        );
    }
}
