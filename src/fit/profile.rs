//! A user's profile: a configuration file with only the settings that
//! differ from the defaults, each after its reason, under a header saying
//! who, when, how and what was measured. `run`, `replay` and `config`
//! read it as any other configuration.

use std::fmt::Write;

use crate::config::Config;
use crate::config::layers::{Layered, Setting};
use crate::config::print::entry_toml;
use crate::fit::Fit;
use crate::fit::check::ConfusionMatrix;
use crate::fit::predict::{KindRates, Rates};

/// Who and when, for the header.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ProfileHeader {
    /// The user's label (a name or a code).
    pub label: String,
    /// The date of the fit, `YYYY-MM-DD`.
    pub date: String,
    /// What was fitted (a file, or "a guided session").
    pub source: String,
}

/// The profile's text.
pub fn text(fit: &Fit, header: &ProfileHeader) -> String {
    text_keeping(fit, header, &Layered::default())
}

/// The profile's text for a person whose setup is `setup`: the fitted
/// settings, then every setting of the setup the fit does not measure
/// (their library, outputs, timings…), each under `# kept from FILE`, so
/// the profile alone is their whole setup.
pub fn text_keeping(fit: &Fit, header: &ProfileHeader, setup: &Layered) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# sipnpuff profile for \"{}\", fitted {} by sipnpuff {} from {}",
        header.label,
        header.date,
        env!("CARGO_PKG_VERSION"),
        header.source
    );
    if fit.ordinary_use {
        let _ = writeln!(out, "# ordinary use: {}", fit.protocol.describe_found());
    } else {
        let _ = writeln!(out, "# protocol: {}", fit.protocol.describe());
    }
    let rest = &fit.found.rest;
    let _ = writeln!(
        out,
        "# rest: {:.3} V, largest excursion +{:.3} / −{:.3} V (sample-to-sample noise sd {:.3} V, spread sd {:.3} V), {} spikes",
        rest.level, rest.excursion_up, rest.excursion_down, rest.white_sd, rest.sd, rest.spikes
    );
    for c in &fit.classes {
        let _ = writeln!(out, "# {} × {}: {}", c.breaths, c.ask.words(), c.measured());
    }
    let _ = writeln!(
        out,
        "# predicted misreadings, this profile vs the settings before: {}",
        rates_line(&fit.predicted[1], &fit.predicted[0])
    );
    let _ = writeln!(
        out,
        "# the calibration replayed: {} vs {} breaths read right",
        right(&fit.replayed[1]),
        right(&fit.replayed[0])
    );
    for w in &fit.worse {
        let _ = writeln!(out, "# worse than before: {w}");
    }
    if let Some(overlap) = &fit.overlap {
        let _ = writeln!(out, "# WARNING: {overlap}");
    }
    let defaults = values(&Config::default());
    // Each table's lines, tables in the order they first come.
    let mut tables: Vec<(String, String)> = Vec::new();
    let mut add = |table: &str, lines: String| match tables.iter_mut().find(|(t, _)| t == table) {
        Some((_, body)) => *body += &lines,
        None => tables.push((table.to_string(), lines)),
    };
    for s in &fit.proposal.settings {
        let (table, key) = s.key.split_once('.').unwrap_or(("", s.key));
        if defaults.get(s.key).is_some_and(|d| same(d, &s.value)) {
            continue;
        }
        add(table, format!("# {}\n{key} = {}\n", s.reason, s.value));
    }
    let mut library = None;
    for kept in kept(fit, setup) {
        let from = setup.layers()[kept.layer].path.display().to_string();
        if kept.key == "sequence" {
            library = Some(from);
            continue;
        }
        let Some((table, key)) = kept.key.rsplit_once('.') else {
            continue;
        };
        add(
            table,
            format!("# kept from {from}\n{key} = {}\n", kept.value),
        );
    }
    for (table, body) in &tables {
        let _ = write!(out, "\n[{table}]\n{body}");
    }
    if let Some(from) = library {
        let entries = setup.config().core().sequences();
        let _ = writeln!(
            out,
            "\n# kept from {from}: the library ({} entries)",
            entries.len()
        );
        for entry in entries {
            if let Ok(text) = entry_toml(entry) {
                out += &text;
            }
        }
    }
    out
}

/// The settings of `setup` that `fit` does not measure (every one the
/// files give that is not among the fit's proposal), each with the file
/// it comes from.
pub fn kept(fit: &Fit, setup: &Layered) -> Vec<Setting> {
    let fitted: Vec<&str> = fit.proposal.settings.iter().map(|s| s.key).collect();
    setup
        .settings()
        .into_iter()
        .filter(|s| !fitted.contains(&s.key.as_str()))
        .collect()
}

/// "32/32".
fn right(c: &ConfusionMatrix) -> String {
    let (r, a) = c.right();
    format!("{r}/{a}")
}

/// The rates side by side, in percent.
pub fn rates_line(new: &Rates, old: &Rates) -> String {
    let pct = |a: f64, b: f64| format!("{:.1} vs {:.1} %", 100.0 * a, 100.0 * b);
    format!(
        "puffs missed {}, sips missed {}, short read as long {} (puffs) {} (sips), long read as short {} (puffs) {} (sips), false bursts {:.2} vs {:.2} per hour",
        pct(new.puff.missed, old.puff.missed),
        pct(new.sip.missed, old.sip.missed),
        pct(new.puff.short_as_long, old.puff.short_as_long),
        pct(new.sip.short_as_long, old.sip.short_as_long),
        pct(new.puff.long_as_short, old.puff.long_as_short),
        pct(new.sip.long_as_short, old.sip.long_as_short),
        new.false_per_hour,
        old.false_per_hour
    )
}

/// A configuration's values by dotted key (`detector.long_burst_ms`), as
/// TOML writes them.
pub fn values(config: &Config) -> std::collections::BTreeMap<String, String> {
    let mut map = std::collections::BTreeMap::new();
    let Ok(text) = config.to_toml() else {
        return map;
    };
    let Ok(table) = text.parse::<toml::Table>() else {
        return map;
    };
    for (section, value) in &table {
        if let Some(inner) = value.as_table() {
            for (key, value) in inner {
                map.insert(format!("{section}.{key}"), value.to_string());
            }
        }
    }
    map
}

/// Whether two TOML values are the same number (or text).
pub fn same(a: &str, b: &str) -> bool {
    match (a.parse::<f64>(), b.parse::<f64>()) {
        (Ok(x), Ok(y)) => x == y,
        _ => a == b,
    }
}

/// What a profile's header says about the person: each burst's length
/// and the predicted misreadings at the profile's settings, read back
/// from the lines [`text`] writes.
#[derive(Debug, Clone, PartialEq)]
pub struct Measured {
    /// Length (mean, SD) in ms of each burst, in [`Action::ALL`]'s order.
    ///
    /// [`Action::ALL`]: crate::control::action::Action::ALL
    pub lengths_ms: [(f64, f64); 4],
    /// The shorter of the two longest comfortable holds, ms.
    pub hold_ms: Option<f64>,
    /// The predicted misreadings, this profile's column.
    pub rates: Option<Rates>,
}

impl Measured {
    /// The length (mean, SD) of `a`, ms.
    pub fn length_ms(&self, a: crate::control::action::Action) -> (f64, f64) {
        self.lengths_ms[a.index()]
    }
}

/// The header of a profile [`text`] wrote, read back. An error says
/// which measurement is missing (a configuration not written by `fit`
/// has none).
pub fn measured(text: &str) -> Result<Measured, String> {
    use crate::control::action::{Action, Breath};
    use crate::fit::protocol::Ask;
    let class = |ask: Ask| -> Option<(f64, f64)> {
        let words = ask.words();
        text.lines().find_map(|line| {
            let rest = line.strip_prefix("# ")?;
            let (_, after) = rest.split_once(" × ")?;
            let after = after.strip_prefix(words)?.strip_prefix(": ")?;
            // "plateau … V (weakest …), 224 ± 38 ms (143–257)"
            let (_, lengths) = after.split_once("), ")?;
            let (mean, rest) = lengths.split_once(" ± ")?;
            let (sd, _) = rest.split_once(" ms")?;
            Some((mean.parse().ok()?, sd.parse().ok()?))
        })
    };
    let mut lengths_ms = [(0.0, 0.0); 4];
    let mut missing = Vec::new();
    for (i, a) in Action::ALL.into_iter().enumerate() {
        match class(Ask::Breath(a)) {
            Some(l) => lengths_ms[i] = l,
            None => missing.push(a.to_string()),
        }
    }
    if !missing.is_empty() {
        return Err(format!(
            "no measured {} (the `# 8 × short puff: …` lines `sipnpuff fit` writes at the top of a profile)",
            missing.join(", ")
        ));
    }
    let hold_ms = [Breath::Puff, Breath::Sip]
        .into_iter()
        .filter_map(|b| class(Ask::Hold(b)).map(|(mean, _)| mean))
        .reduce(f64::min);
    Ok(Measured {
        lengths_ms,
        hold_ms,
        rates: text.lines().find_map(predicted_rates),
    })
}

/// The profile's column of the "predicted misreadings" line: the number
/// before each " vs ", in the order [`rates_line`] writes them.
fn predicted_rates(line: &str) -> Option<Rates> {
    let (_, rates) = line.split_once("this profile vs the settings before: ")?;
    let firsts: Vec<f64> = rates
        .split(" vs ")
        .filter_map(|before| before.rsplit(' ').next()?.parse().ok())
        .collect();
    let [pm, sm, psl, ssl, pls, sls, false_per_hour] = firsts.as_slice() else {
        return None;
    };
    let kind = |missed: f64, short_as_long: f64, long_as_short: f64| KindRates {
        missed: missed / 100.0,
        short_as_long: short_as_long / 100.0,
        long_as_short: long_as_short / 100.0,
    };
    Some(Rates {
        puff: kind(*pm, *psl, *pls),
        sip: kind(*sm, *ssl, *sls),
        false_per_hour: *false_per_hour,
    })
}
