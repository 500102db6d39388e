//! The designed library as a configuration file: a header saying for
//! whom, against what and how close to the best it is; the person's
//! settings that differ from the built-in ones; each entry after its
//! reason. `run`, `study` and `design --check` read it.

use std::collections::BTreeMap;
use std::fmt::Write;

use crate::config::Config;
use crate::config::print::entry_toml;
use crate::control::selection::SequenceEntry;
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
    /// The library it replaces, entry by entry as the designed one.
    pub before_library: &'a [SequenceEntry],
    /// The search.
    pub found: &'a SearchResult,
    /// The replaced library's name.
    pub library_name: &'a str,
    /// The usage designed for, with why.
    pub usage_line: &'a str,
    /// The text of the file the settings come from (the profile), whose
    /// comments give each setting's reason.
    pub reasons: Option<&'a str>,
}

/// The file's text.
pub fn text(d: &Designed) -> Result<String, toml::ser::Error> {
    let mut out = String::new();
    let a = d.analysis;
    let _ = writeln!(
        out,
        "# sipnpuff library designed by sipnpuff {}; user: {}",
        env!("CARGO_PKG_VERSION"),
        a.user
    );
    let _ = writeln!(out, "# designed for: {}", d.usage_line);
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
    let reasons = d.reasons.map(reasons).unwrap_or_default();
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
        for line in reasons.get(&key).into_iter().flatten() {
            let _ = writeln!(out, "{line}");
        }
        let _ = writeln!(out, "{name} = {value}");
    }
    for ((entry, e), was) in d
        .config
        .core()
        .sequences()
        .iter()
        .zip(&a.entries)
        .zip(d.before_library)
    {
        let bursts: Vec<String> = entry
            .actions
            .as_slice()
            .iter()
            .map(ToString::to_string)
            .collect();
        let _ = writeln!(
            out,
            "\n# {:.0} % of selections; {} ({}): {:.2} s{}, {:.2} % of attempts land elsewhere",
            100.0 * e.usage,
            bursts.join(", "),
            if was.actions == entry.actions {
                "kept".to_string()
            } else {
                format!("was {:?}", was.actions)
            },
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

/// Each setting's reason in a configuration's text: the comment lines
/// right above its `key = value` line, by dotted key (`detector.glitch_ms`).
pub fn reasons(text: &str) -> BTreeMap<String, Vec<String>> {
    let mut out = BTreeMap::new();
    let mut table = String::new();
    let mut comments: Vec<String> = Vec::new();
    for line in text.lines().map(str::trim) {
        if line.starts_with('#') {
            comments.push(line.to_string());
        } else if let Some(name) = line.strip_prefix('[') {
            table = name
                .trim_matches(|c| c == '[' || c == ']')
                .trim()
                .to_string();
            comments.clear();
        } else if let Some((key, _)) = line.split_once('=') {
            if !comments.is_empty() {
                out.insert(
                    format!("{table}.{}", key.trim()),
                    std::mem::take(&mut comments),
                );
            }
        } else {
            comments.clear();
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_reason_is_the_comment_right_above_its_setting() {
        let text = "# header\n\n[detector]\n# the breaths' weakest is 0.6 V\n# (two lines)\npuff_on_v = 0.45\nglitch_ms = 5\n\n# loose\n\n[matcher]\n# slower\nsequence_timeout_ms = 1400\n";
        let r = reasons(text);
        assert_eq!(
            r["detector.puff_on_v"],
            ["# the breaths' weakest is 0.6 V", "# (two lines)"]
        );
        assert_eq!(r["matcher.sequence_timeout_ms"], ["# slower"]);
        assert_eq!(r.len(), 2);
    }
}
