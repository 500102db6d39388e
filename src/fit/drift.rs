//! Drift: how a user's breaths in a new session differ from those their
//! profile was fitted on, read from the profile's header (each kind's
//! plateau and length, as [`profile`](super::profile) writes them).

use crate::fit::summary::Class;

/// A change this large (a fraction of the fitted value) is worth a re-fit.
pub const REFIT_FRACTION: f64 = 0.2;

/// One kind's plateau and length at fitting, from a profile's header.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fitted {
    /// Its words, e.g. "long puff".
    pub words: &'static str,
    /// Mean plateau, volts.
    pub plateau_volts: f64,
    /// Mean length, ms.
    pub ms: f64,
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
            let (_, rest) = line.strip_prefix("# ")?.split_once(" × ")?;
            let (words, rest) = rest.split_once(": plateau ")?;
            let words = *asks.iter().find(|a| **a == words)?;
            let (plateau, rest) = rest.split_once(" ± ")?;
            let (_, rest) = rest.split_once("), ")?;
            let (ms, _) = rest.split_once(" ± ")?;
            Some(Fitted {
                words,
                plateau_volts: plateau.parse().ok()?,
                ms: ms.parse().ok()?,
            })
        })
        .collect()
}

/// Each kind whose plateau or length moved by more than
/// [`REFIT_FRACTION`], in plain words.
pub fn drift(then: &[Fitted], now: &[Class]) -> Vec<String> {
    let mut found = Vec::new();
    for class in now.iter().filter(|c| c.breaths > 0) {
        let words = class.ask.words();
        let Some(was) = then.iter().find(|f| f.words == words) else {
            continue;
        };
        for (what, before, after, unit) in [
            ("shorter", was.ms, class.duration_ms.mean, "ms"),
            ("weaker", was.plateau_volts, class.plateau_volts.mean, "V"),
        ] {
            if before <= 0.0 {
                continue;
            }
            let change = (after - before) / before;
            if change.abs() > REFIT_FRACTION {
                let word = match (what, change < 0.0) {
                    ("shorter", true) => "shorter",
                    ("shorter", false) => "longer",
                    (_, true) => "weaker",
                    (_, false) => "stronger",
                };
                found.push(format!(
                    "your {words}s are {:.0} % {word} than at fitting ({before:.2} → {after:.2} {unit}): re-fit suggested",
                    100.0 * change.abs()
                ));
            }
        }
    }
    found
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
                    plateau_volts: 1.28,
                    ms: 795.0
                },
                Fitted {
                    words: "longest comfortable sip",
                    plateau_volts: 0.40,
                    ms: 4100.0
                }
            ]
        );
    }
}
