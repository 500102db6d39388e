//! A gesture set's check in words, for the clinician: per gesture the
//! leave-one-out result, the confusion matrix, the activations ordinary
//! movement caused, the gestures too alike, and the thresholds'
//! trade-off.

use std::fmt::Write as _;

use crate::gestures::check::Check;
use crate::gestures::thresholds::Choice;

/// The check as text.
pub fn text(check: &Check) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "leave-one-out: {}/{} examples recognised as themselves ({:.1} %)",
        check.right,
        check.examples,
        check.accuracy_pct()
    );
    let _ = writeln!(
        out,
        "ordinary movement: {} activation{} in {:.2} h ({:.1} per hour)",
        check.activations.len(),
        if check.activations.len() == 1 {
            ""
        } else {
            "s"
        },
        check.ordinary_hours,
        check.activations_per_hour()
    );
    let _ = writeln!(out);
    let _ = writeln!(
        out,
        "| gesture | threshold | right | taken for | rejected | ordinary taken for it |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|");
    for g in &check.gestures {
        let confused: Vec<String> = g
            .confused
            .iter()
            .map(|(name, n)| format!("{name} ×{n}"))
            .collect();
        let _ = writeln!(
            out,
            "| {} | {:.3} | {}/{} | {} | {} | {} |",
            g.name,
            g.threshold,
            g.right,
            g.examples,
            if confused.is_empty() {
                "—".to_string()
            } else {
                confused.join(", ")
            },
            g.rejected,
            g.ordinary_activations
        );
    }
    let _ = writeln!(out);
    let _ = writeln!(out, "confusion (rows: made; columns: recognised):");
    let names: Vec<&str> = check.gestures.iter().map(|g| g.name.as_str()).collect();
    let width = names.iter().map(|n| n.len()).max().unwrap_or(0).max(8);
    let _ = write!(out, "{:width$}", "");
    for name in names.iter().chain(["rejected"].iter()) {
        let _ = write!(out, " {name:>w$}", w = name.len().max(3));
    }
    let _ = writeln!(out);
    for (name, row) in names.iter().zip(&check.confusion) {
        let _ = write!(out, "{name:width$}");
        for (count, column) in row.iter().zip(names.iter().chain(["rejected"].iter())) {
            let _ = write!(out, " {count:>w$}", w = column.len().max(3));
        }
        let _ = writeln!(out);
    }
    if !check.activations.is_empty() {
        let _ = writeln!(out);
        let _ = writeln!(out, "activations in ordinary movement:");
        for a in &check.activations {
            let _ = writeln!(
                out,
                "  {} at {:.1}–{:.1} s: taken for '{}' (distance {:.3})",
                a.source,
                a.start as f64 / 1000.0,
                a.end as f64 / 1000.0,
                a.gesture,
                a.distance
            );
        }
    }
    if !check.imitated.is_empty() {
        let _ = writeln!(out);
        let _ = writeln!(out, "imitated by ordinary movement:");
        for line in &check.imitated {
            let _ = writeln!(out, "  {line}");
        }
    }
    if !check.too_alike.is_empty() {
        let _ = writeln!(out);
        let _ = writeln!(out, "too alike:");
        for pair in &check.too_alike {
            let _ = writeln!(out, "  {}", pair.advice);
        }
    }
    let _ = writeln!(out);
    let _ = writeln!(
        out,
        "trade-off (every threshold scaled): scale, leave-one-out accuracy, activations per hour"
    );
    for row in &check.trade_off {
        let _ = writeln!(
            out,
            "  ×{:<4} {:>5.1} % {:>7.1} /h{}",
            row.scale,
            row.accuracy_pct,
            row.activations_per_hour,
            if row.scale == 1.0 {
                "  (the set's)"
            } else {
                ""
            }
        );
    }
    out
}

/// How each threshold was chosen, one line per gesture (for a set just
/// recorded).
pub fn choices(names: &[String], choices: &[Choice]) -> Vec<String> {
    names
        .iter()
        .zip(choices)
        .map(|(name, c)| {
            let ordinary = c.ordinary_min.map_or("no ordinary movement came near".to_string(), |d| {
                format!("the nearest ordinary movement at {d:.3}")
            });
            let left_out = if c.own_rejected > 0 {
                format!(
                    "; it leaves out {} of its own examples, to reject the ordinary movement",
                    c.own_rejected
                )
            } else {
                String::new()
            };
            format!(
                "{name}: threshold {:.3} (each of its examples within {:.3} of another; {ordinary}){left_out}",
                c.threshold, c.own_max
            )
        })
        .collect()
}
