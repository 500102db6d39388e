//! A fit for the people who read it: the report a clinician reads (the
//! rest, the breaths measured, the settings proposed with their reasons,
//! the misreadings predicted and replayed), and the same as one JSON
//! object.

use std::fmt::Write as _;

use crate::control::detector::DetectorConfig;
use crate::fit::Fit;
use crate::fit::check::{COLUMNS, ConfusionMatrix};
use crate::fit::predict::{KindRates, Rates};

/// The fit as JSON.
pub fn json(fit: &Fit) -> serde_json::Result<String> {
    let value = serde_json::json!({
        "rest": {
            "level_volts": fit.found.rest.level,
            "noise_sd_volts": fit.found.rest.white_sd,
            "spread_sd_volts": fit.found.rest.sd,
            "excursion_up_volts": fit.found.rest.excursion_up,
            "excursion_down_volts": fit.found.rest.excursion_down,
            "spikes": fit.found.rest.spikes,
            "ms": fit.found.rest.ms,
        },
        "classes": fit.classes,
        "gaps_ms": fit.gaps,
        "notes": fit.answers.notes,
        "proposed": fit.proposal.settings,
        "predicted": { "current": fit.predicted[0], "proposed": fit.predicted[1] },
        "replayed": { "current": fit.replayed[0], "proposed": fit.replayed[1] },
        "hold_decision": hold_decision(fit),
        "overlap": fit.overlap,
        "worse": fit.worse,
    });
    serde_json::to_string(&value)
}

/// The report a clinician reads.
pub fn text(fit: &Fit) -> String {
    let mut out = String::new();
    let rest = &fit.found.rest;
    let _ = writeln!(
        out,
        "rest: {:.3} V over {:.1} s, largest excursion +{:.3} / −{:.3} V (sample-to-sample noise sd {:.3} V, spread sd {:.3} V), {} spikes",
        rest.level,
        rest.ms as f64 / 1000.0,
        rest.excursion_up,
        rest.excursion_down,
        rest.white_sd,
        rest.sd,
        rest.spikes
    );
    for note in &fit.answers.notes {
        let _ = writeln!(out, "note: {note}");
    }
    let _ = writeln!(out, "\nmeasured (durations at the proposed thresholds):");
    for c in &fit.classes {
        let _ = writeln!(
            out,
            "  {:<26} {:>2}  {}",
            c.ask.words(),
            c.breaths,
            c.measured()
        );
    }
    let _ = writeln!(
        out,
        "  pauses between breaths: {:.0} ± {:.0} ms",
        fit.gaps.mean, fit.gaps.sd
    );
    let _ = writeln!(out, "\nproposed settings:");
    for s in &fit.proposal.settings {
        let _ = writeln!(out, "  {} = {}\n      {}", s.key, s.value, s.reason);
    }
    if let Some(decision) = hold_decision(fit) {
        let _ = writeln!(out, "\n{decision}");
    }
    let _ = writeln!(out, "\npredicted misreadings        current  proposed");
    rates(&mut out, &fit.predicted[0], &fit.predicted[1]);
    let _ = writeln!(
        out,
        "\nthe session replayed through the detector (rows: asked or, in ordinary use, as you meant them; columns: read)"
    );
    for (name, c) in [
        ("current", &fit.replayed[0]),
        ("proposed", &fit.replayed[1]),
    ] {
        matrix(&mut out, name, c);
    }
    for w in &fit.worse {
        let _ = writeln!(out, "worse than the current settings: {w}");
    }
    if let Some(overlap) = &fit.overlap {
        let _ = writeln!(out, "\n{overlap}");
    }
    out
}

/// A hold limit under [`SHORT_MOVES_MS`] makes every arm move short: a
/// trade between the length of a move and how soon a stuck sensor stops
/// the arm, which the clinician decides with the person.
fn hold_decision(fit: &Fit) -> Option<String> {
    let proposed = fit.proposal.detector.max_hold_ms;
    let built_in = DetectorConfig::default().max_hold_ms;
    (proposed < SHORT_MOVES_MS).then(|| {
        format!(
            "decision for the clinician: detector.max_hold_ms = {proposed} ms stops the arm whenever one breath is held longer, so every arm move lasts at most {:.1} s and a longer move takes breath after breath. A higher limit (up to the built-in {:.1} s) gives longer moves to a person who can hold a breath that long, and lets a stuck sensor move the arm as long before it stops",
            f64::from(proposed) / 1000.0,
            f64::from(built_in) / 1000.0
        )
    })
}

/// Below this hold limit the report asks the clinician to decide: a move
/// of a few seconds is how the arm crosses a table at its speeds.
const SHORT_MOVES_MS: u32 = 3000;

fn rates(out: &mut String, now: &Rates, new: &Rates) {
    let pct = |v: f64| format!("{:>6.1} %", 100.0 * v);
    type Rate = fn(&KindRates) -> f64;
    let rows: [(&str, Rate); 3] = [
        ("missed", |k| k.missed),
        ("short read as long", |k| k.short_as_long),
        ("long read as short", |k| k.long_as_short),
    ];
    for (kind, a, b) in [
        ("puffs", &now.puff, &new.puff),
        ("sips", &now.sip, &new.sip),
    ] {
        for (what, f) in rows {
            let _ = writeln!(
                out,
                "  {:<26} {} {}",
                format!("{kind} {what}"),
                pct(f(a)),
                pct(f(b))
            );
        }
    }
    let _ = writeln!(
        out,
        "  {:<26} {:>6.2}/h {:>6.2}/h",
        "false bursts at rest", now.false_per_hour, new.false_per_hour
    );
}

fn matrix(out: &mut String, name: &str, c: &ConfusionMatrix) {
    let (right, asked) = c.right();
    let _ = writeln!(
        out,
        "  {name}: {right}/{asked} read right, {} bursts nobody was asked for, {} faults",
        c.unprompted, c.faults
    );
    let header: Vec<String> = COLUMNS.iter().map(|c| format!("{c:>10}")).collect();
    let _ = writeln!(out, "    {:<26}{}", "", header.join(""));
    for row in &c.rows {
        let cells: Vec<String> = row.counts.iter().map(|n| format!("{n:>10}")).collect();
        let _ = writeln!(out, "    {:<26}{}", row.ask.words(), cells.join(""));
    }
}
