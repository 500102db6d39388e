//! `study --plot FILE.svg`: completion times per task and interface, one
//! point per simulated participant (a colour each, as in the paper's
//! Figure 4) with the mean ± SD beside them.

use std::fmt::Write;
use std::path::Path;

use super::TaskResults;
use super::stats::{mean, sample_sd};

const WIDTH: f64 = 780.0;
const HEIGHT: f64 = 420.0;
const TOP: f64 = 50.0;
const BOTTOM: f64 = 360.0;
const LEFT: f64 = 70.0;
const COLOURS: [&str; 8] = [
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#17becf",
];

/// Writes the SVG document to `path`.
pub fn write_completion_svg(path: &Path, results: &[TaskResults]) -> std::io::Result<()> {
    std::fs::write(path, completion_svg(results))
}

/// The SVG document.
fn completion_svg(results: &[TaskResults]) -> String {
    let all = results
        .iter()
        .flat_map(|r| r.asp.iter().chain(&r.bsp))
        .map(|run| run.completion_s);
    let top_value = all.fold(0.0f64, f64::max);
    // Round the axis up to a multiple of 20 s.
    let y_max = ((top_value / 20.0).ceil() * 20.0).max(20.0);
    let y = |s: f64| BOTTOM - (BOTTOM - TOP) * s / y_max;

    let mut svg = String::new();
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{HEIGHT}" viewBox="0 0 {WIDTH} {HEIGHT}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(svg, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        svg,
        r#"<text x="{}" y="24" text-anchor="middle" font-size="15">Task completion time by interface (simulated participants)</text>"#,
        WIDTH / 2.0
    );
    // Axis and grid.
    let _ = writeln!(
        svg,
        r#"<line x1="{LEFT}" y1="{TOP}" x2="{LEFT}" y2="{BOTTOM}" stroke="black"/>"#
    );
    // Grid every 10, 20, 30, 50 or 100 s: the first that gives at most 8 lines.
    let step = [10.0, 20.0, 30.0, 50.0, 100.0]
        .into_iter()
        .find(|step| y_max / step <= 8.0)
        .unwrap_or(y_max / 5.0);
    let mut tick = 0.0;
    while tick <= y_max + 1e-9 {
        let _ = writeln!(
            svg,
            r##"<line x1="{LEFT}" y1="{0:.1}" x2="{1}" y2="{0:.1}" stroke="#ddd"/><text x="{2}" y="{3:.1}" text-anchor="end">{tick:.0}</text>"##,
            y(tick),
            WIDTH - 20.0,
            LEFT - 6.0,
            y(tick) + 4.0
        );
        tick += step;
    }
    let _ = writeln!(
        svg,
        r#"<text x="20" y="{0}" transform="rotate(-90 20 {0})" text-anchor="middle">completion time (s)</text>"#,
        (TOP + BOTTOM) / 2.0
    );

    let panel = (WIDTH - LEFT - 20.0) / results.len().max(1) as f64;
    for (i, r) in results.iter().enumerate() {
        let x0 = LEFT + panel * i as f64;
        let _ = writeln!(
            svg,
            r#"<text x="{:.1}" y="{}" text-anchor="middle" font-size="13">Task {}</text>"#,
            x0 + panel / 2.0,
            BOTTOM + 40.0,
            r.task.number
        );
        for (k, (name, runs)) in [("ASP", &r.asp), ("BSP", &r.bsp)].iter().enumerate() {
            let cx = x0 + panel * (0.3 + 0.4 * k as f64);
            let times: Vec<f64> = runs.iter().map(|run| run.completion_s).collect();
            let _ = writeln!(
                svg,
                r#"<text x="{cx:.1}" y="{}" text-anchor="middle">{name}</text>"#,
                BOTTOM + 18.0
            );
            // Points, spread sideways by participant.
            let n = times.len().max(1) as f64;
            for (u, t) in times.iter().enumerate() {
                let dx = -18.0 + 36.0 * (u as f64 + 0.5) / n;
                let _ = writeln!(
                    svg,
                    r#"<circle cx="{:.1}" cy="{:.1}" r="4" fill="{}" fill-opacity="0.85"/>"#,
                    cx - 14.0 + dx,
                    y(*t),
                    COLOURS[u % COLOURS.len()]
                );
            }
            // Mean ± SD.
            let (m, sd) = (mean(&times), sample_sd(&times));
            let bx = cx + 22.0;
            if sd.is_finite() {
                let _ = writeln!(
                    svg,
                    r#"<line x1="{bx:.1}" y1="{:.1}" x2="{bx:.1}" y2="{:.1}" stroke="black"/>"#,
                    y(m - sd),
                    y(m + sd)
                );
            }
            let _ = writeln!(
                svg,
                r#"<line x1="{0:.1}" y1="{1:.1}" x2="{2:.1}" y2="{1:.1}" stroke="black" stroke-width="2"/>"#,
                bx - 6.0,
                y(m),
                bx + 6.0
            );
        }
    }
    svg.push_str("</svg>\n");
    svg
}
