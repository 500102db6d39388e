//! The designed library as a configuration file: a header saying for
//! whom, against what and how close to the best it is; the person's
//! settings that differ from the built-in ones; each entry after its
//! reason. `run`, `study` and `design --check` read it.

use std::fmt::Write;

use crate::config::Config;
use crate::config::print::entry_toml;
use crate::design::analysis::Analysis;
use crate::design::search::SearchResult;
use crate::fit::profile::{same, values};

/// What the file says.
pub struct Designed<'a> {
    /// The settings and the designed library.
    pub config: &'a Config,
    /// The designed library analysed.
    pub analysis: &'a Analysis,
    /// The library it replaces, analysed.
    pub before: &'a Analysis,
    /// The search.
    pub found: &'a SearchResult,
    /// The replaced library's name.
    pub library_name: &'a str,
}

/// The file's text.
pub fn text(d: &Designed) -> Result<String, toml::ser::Error> {
    let mut out = String::new();
    let a = d.analysis;
    let _ = writeln!(
        out,
        "# sipnpuff library designed by sipnpuff {} for {}",
        env!("CARGO_PKG_VERSION"),
        a.user
    );
    let _ = writeln!(out, "# usage: {}", a.usage);
    let _ = writeln!(
        out,
        "# expected {:.2} s per selection, {:.2} % of attempts wrong; {} {:.2} s, {:.2} %",
        a.expected_ms_per_selection / 1000.0,
        100.0 * a.p_wrong_per_selection,
        d.library_name,
        d.before.expected_ms_per_selection / 1000.0,
        100.0 * d.before.p_wrong_per_selection
    );
    let _ = writeln!(
        out,
        "# search: {} partial libraries in {:.1} s, {}",
        d.found.nodes,
        d.found.seconds,
        if d.found.complete {
            "the whole space: no library costs less".to_string()
        } else {
            format!(
                "stopped at the time limit within {:.2} % of the bound",
                d.found.gap_pct()
            )
        }
    );
    let defaults = values(&Config::default());
    let mut section = String::new();
    for (key, value) in values(d.config) {
        if key.starts_with("sequence") || defaults.get(&key).is_some_and(|v| same(v, &value)) {
            continue;
        }
        let (table, name) = key.split_once('.').unwrap_or(("", &key));
        if table != section {
            let _ = writeln!(out, "\n[{table}]");
            section = table.to_string();
        }
        let _ = writeln!(out, "{name} = {value}");
    }
    for (entry, e) in d.config.core().sequences().iter().zip(&a.entries) {
        let bursts: Vec<String> = entry
            .actions
            .as_slice()
            .iter()
            .map(ToString::to_string)
            .collect();
        let _ = writeln!(
            out,
            "\n# {:.0} % of selections; {}: {:.2} s{}, {:.2} % of attempts land elsewhere",
            100.0 * e.usage,
            bursts.join(", "),
            e.expected_ms / 1000.0,
            if e.wait_ms > 0.0 {
                " (waits the timeout: a longer sequence starts with it)"
            } else {
                ""
            },
            100.0 * e.p_wrong
        );
        out += entry_toml(entry)?.trim_end();
        out.push('\n');
    }
    Ok(out)
}
