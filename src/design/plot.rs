//! An analysis drawn: one row per entry, a bar for its expected time and
//! beside it a bar for its chance of landing in another entry, the most
//! used first.

use std::fmt::Write;

use crate::design::analysis::{Analysis, written};

/// The analysis as an SVG document.
pub fn analysis_svg(a: &Analysis, title: &str) -> String {
    let mut rows: Vec<_> = a.entries.iter().collect();
    rows.sort_by(|x, y| y.usage.total_cmp(&x.usage));
    let (row_h, top, label_w, bar_w) = (22.0, 72.0, 260.0, 300.0);
    let width = label_w + 2.0 * bar_w + 80.0;
    let height = top + row_h * rows.len() as f64 + 40.0;
    let max_ms = rows
        .iter()
        .map(|e| e.expected_ms)
        .filter(|v| v.is_finite())
        .fold(1.0, f64::max);
    let max_p = rows.iter().map(|e| e.p_wrong).fold(0.01, f64::max);
    let mut svg = format!(
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" font-family="sans-serif" font-size="13">
<rect width="100%" height="100%" fill="white"/>
<text x="10" y="20" font-size="15">{}</text>
<text x="10" y="40" fill="#555">{:.2} s per selection, {:.2} % of attempts select a wrong entry ({})</text>
<text x="{label_w}" y="{}" fill="#555">expected time to select, s</text>
<text x="{}" y="{}" fill="#555">chance an attempt lands elsewhere, %</text>
"##,
        escape(title),
        a.expected_ms_per_selection / 1000.0,
        100.0 * a.p_wrong_per_selection,
        escape(&a.user),
        top - 4.0,
        label_w + bar_w + 40.0,
        top - 4.0,
    );
    for (k, e) in rows.iter().enumerate() {
        let y = top + row_h * k as f64 + 4.0;
        let time_w = (bar_w - 10.0) * (e.expected_ms.min(max_ms) / max_ms);
        let p_w = (bar_w - 10.0) * (e.p_wrong / max_p);
        let _ = writeln!(
            svg,
            r##"<text x="10" y="{:.1}">{} ({}) · {:.0} %</text>
<rect x="{label_w}" y="{y:.1}" width="{time_w:.1}" height="{:.1}" fill="#4a7ab5"/>
<text x="{:.1}" y="{:.1}">{:.2}</text>
<rect x="{:.1}" y="{y:.1}" width="{p_w:.1}" height="{:.1}" fill="#c0504d"/>
<text x="{:.1}" y="{:.1}">{:.2}</text>"##,
            y + 13.0,
            escape(&e.target.label()),
            written(&e.actions),
            100.0 * e.usage,
            row_h - 6.0,
            label_w + time_w + 4.0,
            y + 13.0,
            e.expected_ms / 1000.0,
            label_w + bar_w + 40.0,
            row_h - 6.0,
            label_w + bar_w + 40.0 + p_w + 4.0,
            y + 13.0,
            100.0 * e.p_wrong,
        );
    }
    svg += "</svg>\n";
    svg
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}
