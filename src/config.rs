//! Configuration: TOML read once, key by key, into validated types.
//!
//! Every problem is collected with the key it belongs to and reported at
//! once, so a clinician fitting the interface fixes a file in one pass.
//! Unknown keys are errors (a misspelt key must never be silently ignored).
//! Nothing here runs on the control thread: it may allocate.

use std::collections::HashSet;
use std::fmt;
use std::path::Path;

use serde::de::DeserializeOwned;
use toml::{Table, Value};

use crate::action::{Action, ActionSeq, MAX_SEQUENCE_LEN};
use crate::modes::Mode;

/// Largest library the matcher accepts.
pub const MAX_SEQUENCES: usize = 256;

/// Upper bound for every timer, to catch unit mistakes (seconds typed as
/// milliseconds ×1000) and keep tick arithmetic far from overflow.
pub const MAX_TIMER_MS: u32 = 600_000;

/// Burst detector settings (`[detector]`), validated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectorConfig {
    /// Sensor output at rest, in volts. The detector starts from it and then
    /// tracks slow drift.
    pub neutral_volts: f64,
    /// A puff starts above this voltage (relative to the tracked neutral, it
    /// moves with the neutral by the same offset).
    pub puff_threshold_volts: f64,
    /// A sip starts below this voltage (moves with the neutral likewise).
    pub sip_threshold_volts: f64,
    /// A burst ends when the signal is back past its threshold by this much.
    pub hysteresis_volts: f64,
    /// Bursts shorter than this are ignored.
    pub min_burst_ms: u32,
    /// Bursts at least this long are long; shorter ones are short.
    pub long_burst_ms: u32,
    /// Longest glitch (spike, dropout) ignored: a change of state must last
    /// longer than this to count.
    pub glitch_ms: u32,
    /// Time constant of the neutral tracker (exponential average of the
    /// resting signal, updated only while no breath is in progress).
    pub neutral_tracking_ms: u32,
    /// Samples further than this outside 0–5 V are sensor faults.
    pub fault_margin_volts: f64,
    /// After a fault, the signal must be valid and at rest this long before
    /// detection resumes.
    pub fault_recovery_ms: u32,
}

impl Default for DetectorConfig {
    fn default() -> Self {
        DetectorConfig {
            neutral_volts: 2.5,
            puff_threshold_volts: 3.0,
            sip_threshold_volts: 2.0,
            hysteresis_volts: 0.1,
            min_burst_ms: 40,
            long_burst_ms: 500,
            glitch_ms: 5,
            neutral_tracking_ms: 1000,
            fault_margin_volts: 0.5,
            fault_recovery_ms: 250,
        }
    }
}

/// Sequence matcher settings (`[matcher]`), validated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MatcherConfig {
    /// How long the matcher waits for the next burst of a sequence that is a
    /// prefix of a longer one, counted from the end of the last burst.
    pub sequence_timeout_ms: u32,
}

impl Default for MatcherConfig {
    fn default() -> Self {
        MatcherConfig {
            sequence_timeout_ms: 1000,
        }
    }
}

/// Command mode settings (`[command]`), validated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CommandConfig {
    /// No breath for this long (from the match or the end of the last breath)
    /// returns to detection mode.
    pub inactivity_timeout_ms: u32,
}

impl Default for CommandConfig {
    fn default() -> Self {
        CommandConfig {
            inactivity_timeout_ms: 2000,
        }
    }
}

/// One user-defined sequence and the mode it selects.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SequenceEntry {
    /// The actions, non-empty, at most [`MAX_SEQUENCE_LEN`].
    pub actions: ActionSeq,
    /// The arm mode it selects.
    pub mode: Mode,
}

/// The built-in library: prefix-free (no selection ever waits for the
/// timeout), two bursts each so a single cough or sigh never changes mode.
/// Two short bursts select the most used modes (translations, fingers); a
/// long puff first selects a rotation; a long sip first a saved point.
pub const DEFAULT_SEQUENCES: [(&[Action], Mode); 9] = {
    use Action::{LongPuff, LongSip, ShortPuff, ShortSip};
    [
        (&[ShortPuff, ShortPuff], Mode::TranslateX),
        (&[ShortPuff, ShortSip], Mode::TranslateY),
        (&[ShortSip, ShortSip], Mode::TranslateZ),
        (&[ShortSip, ShortPuff], Mode::Fingers),
        (&[LongPuff, ShortPuff], Mode::RotateX),
        (&[LongPuff, ShortSip], Mode::RotateY),
        (&[LongPuff, LongPuff], Mode::RotateZ),
        (&[LongSip, ShortPuff], Mode::SavePoint),
        (&[LongSip, ShortSip], Mode::GotoPoint),
    ]
};

/// The whole validated configuration. Only [`Config::default`] and
/// [`Config::from_toml_str`] make one, so every `Config` is valid.
#[derive(Debug, Clone, PartialEq)]
pub struct Config {
    detector: DetectorConfig,
    matcher: MatcherConfig,
    command: CommandConfig,
    sequences: Vec<SequenceEntry>,
}

impl Default for Config {
    fn default() -> Self {
        let sequences = DEFAULT_SEQUENCES
            .iter()
            .map(|&(actions, mode)| SequenceEntry {
                actions: ActionSeq::from_slice(actions).expect("default sequences are short"),
                mode,
            })
            .collect();
        Config {
            detector: DetectorConfig::default(),
            matcher: MatcherConfig::default(),
            command: CommandConfig::default(),
            sequences,
        }
    }
}

/// One problem in a configuration: the key and what is wrong with it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConfigError {
    /// Dotted key, e.g. `detector.min_burst_ms` or `sequence #3.mode`
    /// (sequences counted from 1 in file order).
    pub key: String,
    /// What is wrong, in plain words.
    pub message: String,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.key, self.message)
    }
}

/// All the problems found in a configuration, in file order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConfigErrors(pub Vec<ConfigError>);

impl fmt::Display for ConfigErrors {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let count = self.0.len();
        writeln!(
            f,
            "{count} problem{} in the configuration:",
            if count == 1 { "" } else { "s" }
        )?;
        for error in &self.0 {
            writeln!(f, "  - {error}")?;
        }
        Ok(())
    }
}

impl std::error::Error for ConfigErrors {}

impl Config {
    /// Reads and validates a configuration file.
    pub fn from_file(path: &Path) -> anyhow::Result<Config> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| anyhow::anyhow!("cannot read config {}: {e}", path.display()))?;
        Config::from_toml_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
    }

    /// Parses and validates TOML text. Missing keys take the built-in
    /// defaults; a `[[sequence]]` list, if present, replaces the built-in
    /// library entirely.
    pub fn from_toml_str(text: &str) -> Result<Config, ConfigErrors> {
        let mut root: Table = text.parse().map_err(|e: toml::de::Error| {
            ConfigErrors(vec![ConfigError {
                key: "(file)".into(),
                message: format!("not valid TOML: {}", e.message().trim()),
            }])
        })?;
        let mut reader = Reader::default();
        let defaults = Config::default();

        let detector = reader.detector(&mut root, defaults.detector);
        let matcher = reader.matcher(&mut root, defaults.matcher);
        let command = reader.command(&mut root, defaults.command);
        let sequences = reader.sequences(&mut root).unwrap_or(defaults.sequences);
        for key in root.keys() {
            reader.error(
                key.clone(),
                "unknown section or key (known: detector, matcher, command, sequence)",
            );
        }

        if reader.errors.is_empty() {
            Ok(Config {
                detector,
                matcher,
                command,
                sequences,
            })
        } else {
            Err(ConfigErrors(reader.errors))
        }
    }

    /// Burst detector settings.
    pub fn detector(&self) -> &DetectorConfig {
        &self.detector
    }

    /// Sequence matcher settings.
    pub fn matcher(&self) -> &MatcherConfig {
        &self.matcher
    }

    /// Command mode settings.
    pub fn command(&self) -> &CommandConfig {
        &self.command
    }

    /// The user-defined sequences, in file order.
    pub fn sequences(&self) -> &[SequenceEntry] {
        &self.sequences
    }
}

/// Walks the TOML table, taking known keys out and collecting errors.
#[derive(Default)]
struct Reader {
    errors: Vec<ConfigError>,
}

impl Reader {
    fn error(&mut self, key: impl Into<String>, message: impl Into<String>) {
        self.errors.push(ConfigError {
            key: key.into(),
            message: message.into(),
        });
    }

    /// Removes a sub-table from `root`; an absent section is empty.
    fn section(&mut self, root: &mut Table, name: &str) -> Table {
        match root.remove(name) {
            None => Table::new(),
            Some(Value::Table(table)) => table,
            Some(other) => {
                self.error(name, format!("must be a table, found {}", other.type_str()));
                Table::new()
            }
        }
    }

    /// Takes one typed key out of a table; on a type error records it and
    /// returns `None` (the caller falls back to the default so that the
    /// remaining checks still run).
    fn take<T: DeserializeOwned>(&mut self, table: &mut Table, path: &str, key: &str) -> Option<T> {
        let value = table.remove(key)?;
        let found = value.type_str();
        match value.try_into::<T>() {
            Ok(v) => Some(v),
            Err(e) => {
                self.error(
                    format!("{path}.{key}"),
                    format!("wrong type ({found}): {}", e.message().trim()),
                );
                None
            }
        }
    }

    /// Every key left in a section after the known ones were taken is unknown.
    fn unknown_keys(&mut self, table: Table, path: &str, known: &[&str]) {
        for key in table.keys() {
            self.error(
                format!("{path}.{key}"),
                format!("unknown key (known: {})", known.join(", ")),
            );
        }
    }

    fn positive_ms(&mut self, key: &str, value: u32) {
        if value == 0 {
            self.error(key, "must be greater than 0 ms");
        } else if value > MAX_TIMER_MS {
            self.error(
                key,
                format!("{value} ms is more than the {MAX_TIMER_MS} ms allowed"),
            );
        }
    }

    fn detector(&mut self, root: &mut Table, d: DetectorConfig) -> DetectorConfig {
        const P: &str = "detector";
        let mut t = self.section(root, P);
        let c = DetectorConfig {
            neutral_volts: self
                .take(&mut t, P, "neutral_volts")
                .unwrap_or(d.neutral_volts),
            puff_threshold_volts: self
                .take(&mut t, P, "puff_threshold_volts")
                .unwrap_or(d.puff_threshold_volts),
            sip_threshold_volts: self
                .take(&mut t, P, "sip_threshold_volts")
                .unwrap_or(d.sip_threshold_volts),
            hysteresis_volts: self
                .take(&mut t, P, "hysteresis_volts")
                .unwrap_or(d.hysteresis_volts),
            min_burst_ms: self
                .take(&mut t, P, "min_burst_ms")
                .unwrap_or(d.min_burst_ms),
            long_burst_ms: self
                .take(&mut t, P, "long_burst_ms")
                .unwrap_or(d.long_burst_ms),
            glitch_ms: self.take(&mut t, P, "glitch_ms").unwrap_or(d.glitch_ms),
            neutral_tracking_ms: self
                .take(&mut t, P, "neutral_tracking_ms")
                .unwrap_or(d.neutral_tracking_ms),
            fault_margin_volts: self
                .take(&mut t, P, "fault_margin_volts")
                .unwrap_or(d.fault_margin_volts),
            fault_recovery_ms: self
                .take(&mut t, P, "fault_recovery_ms")
                .unwrap_or(d.fault_recovery_ms),
        };
        self.unknown_keys(
            t,
            P,
            &[
                "neutral_volts",
                "puff_threshold_volts",
                "sip_threshold_volts",
                "hysteresis_volts",
                "min_burst_ms",
                "long_burst_ms",
                "glitch_ms",
                "neutral_tracking_ms",
                "fault_margin_volts",
                "fault_recovery_ms",
            ],
        );
        self.validate_detector(&c);
        c
    }

    fn validate_detector(&mut self, c: &DetectorConfig) {
        for (key, v) in [
            ("detector.neutral_volts", c.neutral_volts),
            ("detector.puff_threshold_volts", c.puff_threshold_volts),
            ("detector.sip_threshold_volts", c.sip_threshold_volts),
        ] {
            if !(0.0..=5.0).contains(&v) {
                self.error(key, format!("{v} V is outside the sensor's 0–5 V range"));
            }
        }
        if c.puff_threshold_volts <= c.neutral_volts {
            self.error(
                "detector.puff_threshold_volts",
                format!(
                    "{} V must be above detector.neutral_volts ({} V): a puff raises the voltage",
                    c.puff_threshold_volts, c.neutral_volts
                ),
            );
        }
        if c.sip_threshold_volts >= c.neutral_volts {
            self.error(
                "detector.sip_threshold_volts",
                format!(
                    "{} V must be below detector.neutral_volts ({} V): a sip lowers the voltage",
                    c.sip_threshold_volts, c.neutral_volts
                ),
            );
        }
        let nearest =
            (c.puff_threshold_volts - c.neutral_volts).min(c.neutral_volts - c.sip_threshold_volts);
        if c.hysteresis_volts.is_nan() || c.hysteresis_volts < 0.0 {
            self.error("detector.hysteresis_volts", "must be 0 V or more");
        } else if nearest > 0.0 && c.hysteresis_volts >= nearest {
            self.error(
                "detector.hysteresis_volts",
                format!(
                    "{} V must be smaller than the distance from the neutral to the nearest threshold ({nearest:.3} V)",
                    c.hysteresis_volts
                ),
            );
        }
        if !(c.fault_margin_volts > 0.0 && c.fault_margin_volts <= 5.0) {
            self.error(
                "detector.fault_margin_volts",
                format!(
                    "{} V must be above 0 V and at most 5 V",
                    c.fault_margin_volts
                ),
            );
        }
        self.positive_ms("detector.min_burst_ms", c.min_burst_ms);
        self.positive_ms("detector.long_burst_ms", c.long_burst_ms);
        self.positive_ms("detector.neutral_tracking_ms", c.neutral_tracking_ms);
        self.positive_ms("detector.fault_recovery_ms", c.fault_recovery_ms);
        if c.long_burst_ms <= c.min_burst_ms {
            self.error(
                "detector.long_burst_ms",
                format!(
                    "{} ms must be greater than detector.min_burst_ms ({} ms)",
                    c.long_burst_ms, c.min_burst_ms
                ),
            );
        }
        if c.glitch_ms >= c.min_burst_ms {
            self.error(
                "detector.glitch_ms",
                format!(
                    "{} ms must be smaller than detector.min_burst_ms ({} ms): a glitch is shorter than any burst",
                    c.glitch_ms, c.min_burst_ms
                ),
            );
        }
    }

    fn matcher(&mut self, root: &mut Table, d: MatcherConfig) -> MatcherConfig {
        const P: &str = "matcher";
        let mut t = self.section(root, P);
        let c = MatcherConfig {
            sequence_timeout_ms: self
                .take(&mut t, P, "sequence_timeout_ms")
                .unwrap_or(d.sequence_timeout_ms),
        };
        self.unknown_keys(t, P, &["sequence_timeout_ms"]);
        self.positive_ms("matcher.sequence_timeout_ms", c.sequence_timeout_ms);
        c
    }

    fn command(&mut self, root: &mut Table, d: CommandConfig) -> CommandConfig {
        const P: &str = "command";
        let mut t = self.section(root, P);
        let c = CommandConfig {
            inactivity_timeout_ms: self
                .take(&mut t, P, "inactivity_timeout_ms")
                .unwrap_or(d.inactivity_timeout_ms),
        };
        self.unknown_keys(t, P, &["inactivity_timeout_ms"]);
        self.positive_ms("command.inactivity_timeout_ms", c.inactivity_timeout_ms);
        c
    }

    /// `[[sequence]]` entries; `None` when the file has none (use defaults).
    fn sequences(&mut self, root: &mut Table) -> Option<Vec<SequenceEntry>> {
        let list = match root.remove("sequence")? {
            Value::Array(list) => list,
            other => {
                self.error(
                    "sequence",
                    format!(
                        "must be an array of tables ([[sequence]]), found {}",
                        other.type_str()
                    ),
                );
                return None;
            }
        };
        if list.is_empty() {
            self.error("sequence", "the library has no sequence");
        }
        if list.len() > MAX_SEQUENCES {
            self.error(
                "sequence",
                format!("{} sequences, at most {MAX_SEQUENCES} allowed", list.len()),
            );
        }
        let mut entries = Vec::with_capacity(list.len());
        let mut seen: HashSet<ActionSeq> = HashSet::new();
        for (i, item) in list.into_iter().enumerate() {
            let path = format!("sequence #{}", i + 1);
            let mut t = match item {
                Value::Table(t) => t,
                other => {
                    self.error(path, format!("must be a table, found {}", other.type_str()));
                    continue;
                }
            };
            for key in ["actions", "mode"] {
                if !t.contains_key(key) {
                    self.error(format!("{path}.{key}"), "missing");
                }
            }
            let codes = self.take::<Vec<i64>>(&mut t, &path, "actions");
            let mode_name = self.take::<String>(&mut t, &path, "mode");
            self.unknown_keys(t, &path, &["actions", "mode"]);

            let actions = codes.and_then(|codes| self.actions(&path, &codes));
            let mode = mode_name.and_then(|name| {
                let mode = Mode::from_name(&name);
                if mode.is_none() {
                    self.error(
                        format!("{path}.mode"),
                        format!(
                            "unknown mode {name:?} (known: {})",
                            Mode::ALL.map(Mode::name).join(", ")
                        ),
                    );
                }
                mode
            });
            if let Some(seq) = actions {
                if !seen.insert(seq) {
                    self.error(
                        format!("{path}.actions"),
                        format!("{:?} is listed twice", seq),
                    );
                }
                if let Some(mode) = mode {
                    entries.push(SequenceEntry { actions: seq, mode });
                }
            }
        }
        Some(entries)
    }

    fn actions(&mut self, path: &str, codes: &[i64]) -> Option<ActionSeq> {
        let key = format!("{path}.actions");
        if codes.is_empty() {
            self.error(key, "must hold at least one action");
            return None;
        }
        if codes.len() > MAX_SEQUENCE_LEN {
            self.error(
                key,
                format!(
                    "{} actions, at most {MAX_SEQUENCE_LEN} allowed",
                    codes.len()
                ),
            );
            return None;
        }
        let bad: Vec<String> = codes
            .iter()
            .filter(|&&c| Action::from_code(c).is_none())
            .map(|c| c.to_string())
            .collect();
        if !bad.is_empty() {
            self.error(
                key,
                format!(
                    "{} not an action (1 = short sip, 2 = long sip, -1 = short puff, -2 = long puff)",
                    bad.join(", ")
                ),
            );
            return None;
        }
        let actions: Vec<Action> = codes.iter().filter_map(|&c| Action::from_code(c)).collect();
        ActionSeq::from_slice(&actions)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn errors(text: &str) -> Vec<ConfigError> {
        Config::from_toml_str(text).unwrap_err().0
    }

    fn keys(text: &str) -> Vec<String> {
        errors(text).into_iter().map(|e| e.key).collect()
    }

    #[test]
    fn empty_file_is_the_default() {
        assert_eq!(Config::from_toml_str("").unwrap(), Config::default());
    }

    #[test]
    fn issue_example_parses() {
        let c = Config::from_toml_str(
            r#"
            [detector]
            neutral_volts = 2.5
            puff_threshold_volts = 3.0
            sip_threshold_volts = 2.0
            hysteresis_volts = 0.1
            min_burst_ms = 40
            long_burst_ms = 500

            [matcher]
            sequence_timeout_ms = 1000

            [command]
            inactivity_timeout_ms = 2000

            [[sequence]]
            actions = [1, 1]
            mode = "translate_x"
            "#,
        )
        .unwrap();
        assert_eq!(c.sequences().len(), 1);
        assert_eq!(c.sequences()[0].mode, Mode::TranslateX);
        assert_eq!(
            c.sequences()[0].actions.as_slice(),
            &[Action::ShortSip, Action::ShortSip]
        );
        assert_eq!(c.matcher().sequence_timeout_ms, 1000);
    }

    #[test]
    fn integer_volts_are_accepted() {
        let c = Config::from_toml_str("[detector]\npuff_threshold_volts = 4\n").unwrap();
        assert_eq!(c.detector().puff_threshold_volts, 4.0);
    }

    #[test]
    fn every_error_is_reported_at_once_with_its_key() {
        let e = keys(
            r#"
            colour = "red"
            [detector]
            puff_threshold_volts = 2.0
            sip_threshold_volts = 2.6
            min_burst_ms = 0
            long_burst_ms = "long"
            typo_ms = 3
            [matcher]
            sequence_timeout_ms = -5
            [command]
            inactivity_timeout_ms = 0
            [[sequence]]
            actions = [1, 3]
            mode = "translate_x"
            [[sequence]]
            actions = []
            mode = "dance"
            [[sequence]]
            actions = [1, 1]
            mode = "fingers"
            [[sequence]]
            actions = [1, 1]
            mode = "rotate_z"
            speed = 2
            [[sequence]]
            mode = "rotate_y"
            "#,
        );
        let expected = [
            "detector.long_burst_ms",
            "detector.typo_ms",
            "detector.puff_threshold_volts",
            "detector.sip_threshold_volts",
            "detector.min_burst_ms",
            "detector.glitch_ms",
            "matcher.sequence_timeout_ms",
            "command.inactivity_timeout_ms",
            "sequence #1.actions",
            "sequence #2.actions",
            "sequence #2.mode",
            "sequence #4.speed",
            "sequence #4.actions",
            "sequence #5.actions",
            "colour",
        ];
        for key in expected {
            assert!(e.iter().any(|k| k == key), "no error for {key}: {e:?}");
        }
        assert_eq!(e.len(), expected.len(), "{e:?}");
    }

    #[test]
    fn messages_say_what_is_wrong() {
        let e = errors(
            "[detector]\nhysteresis_volts = 0.6\n[[sequence]]\nactions = [1, 7]\nmode = \"fingers\"\n",
        );
        assert_eq!(e.len(), 2, "{e:?}");
        assert_eq!(e[0].key, "detector.hysteresis_volts");
        assert!(e[0].message.contains("0.500"), "{}", e[0].message);
        assert_eq!(e[1].key, "sequence #1.actions");
        assert!(
            e[1].message.starts_with("7 not an action"),
            "{}",
            e[1].message
        );
        let text = ConfigErrors(e).to_string();
        assert!(
            text.starts_with("2 problems in the configuration:"),
            "{text}"
        );
    }

    #[test]
    fn long_must_exceed_min_and_glitch_must_be_shorter() {
        let e = errors("[detector]\nmin_burst_ms = 40\nlong_burst_ms = 40\nglitch_ms = 40\n");
        let keys: Vec<_> = e.iter().map(|e| e.key.as_str()).collect();
        assert_eq!(keys, ["detector.long_burst_ms", "detector.glitch_ms"]);
    }

    #[test]
    fn too_long_sequence_is_rejected() {
        let codes = vec!["1"; MAX_SEQUENCE_LEN + 1].join(", ");
        let e = errors(&format!(
            "[[sequence]]\nactions = [{codes}]\nmode = \"fingers\"\n"
        ));
        assert_eq!(e.len(), 1);
        assert!(e[0].message.contains("at most 16"), "{}", e[0].message);
    }

    #[test]
    fn nan_and_infinite_settings_are_rejected() {
        let e = keys(
            "[detector]\nneutral_volts = nan\nhysteresis_volts = nan\nfault_margin_volts = inf\n",
        );
        assert_eq!(
            e,
            [
                "detector.neutral_volts",
                "detector.hysteresis_volts",
                "detector.fault_margin_volts"
            ]
        );
    }

    #[test]
    fn syntax_error_is_reported() {
        let e = errors("[detector\n");
        assert_eq!(e[0].key, "(file)");
        assert!(e[0].message.starts_with("not valid TOML"));
    }

    #[test]
    fn default_library_is_prefix_free_and_covers_every_mode() {
        let c = Config::default();
        for mode in Mode::ALL {
            assert!(c.sequences().iter().any(|s| s.mode == mode), "{mode:?}");
        }
        for a in c.sequences() {
            for b in c.sequences() {
                if a != b {
                    assert!(!b.actions.as_slice().starts_with(a.actions.as_slice()));
                }
            }
        }
    }

    #[test]
    fn a_mode_may_have_several_sequences() {
        let c = Config::from_toml_str(
            "[[sequence]]\nactions = [1]\nmode = \"fingers\"\n[[sequence]]\nactions = [2]\nmode = \"fingers\"\n",
        )
        .unwrap();
        assert_eq!(c.sequences().len(), 2);
    }
}
