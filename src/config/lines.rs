//! Where things are in the file: the line and column of each key (and of
//! each `[[sequence]]`), and of a syntax error, so every message can point
//! at the line to fix, and the problems can be listed in file order.

use std::collections::HashMap;

use toml::de::{DeTable, DeValue};

use crate::config::error::{ConfigError, ConfigErrors};

/// 1-based line and column of each dotted key in a file, keyed as the
/// errors name them (`detector.min_burst_ms`, `sequence #2`,
/// `sequence #2.mode`).
pub(super) struct KeyLines {
    lines: HashMap<String, (usize, usize)>,
}

impl KeyLines {
    /// Indexes a file that parsed (an unparsable one has no keys).
    pub(super) fn of(text: &str) -> KeyLines {
        let mut lines = HashMap::new();
        if let Ok(root) = DeTable::parse(text) {
            let at = |offset: usize| line_column(text, offset);
            index(root.get_ref(), "", &mut lines, &at);
        }
        KeyLines { lines }
    }

    /// Line and column of `key`, if it is in the file.
    pub(super) fn find(&self, key: &str) -> Option<(usize, usize)> {
        self.lines.get(key).copied()
    }
}

/// Indexes every key of `table` (and of its tables, at any depth:
/// `sensor.evdev.axis`) under `prefix`; array entries are `name #N`.
fn index(
    table: &DeTable<'_>,
    prefix: &str,
    lines: &mut HashMap<String, (usize, usize)>,
    at: &impl Fn(usize) -> (usize, usize),
) {
    for (key, value) in table {
        let name = format!("{prefix}{}", key.get_ref());
        lines.insert(name.clone(), at(key.span().start));
        match value.get_ref() {
            DeValue::Table(sub) => index(sub, &format!("{name}."), lines, at),
            DeValue::Array(items) => {
                for (i, item) in items.iter().enumerate() {
                    let entry = format!("{name} #{}", i + 1);
                    lines.insert(entry.clone(), at(item.span().start));
                    if let DeValue::Table(sub) = item.get_ref() {
                        index(sub, &format!("{entry}."), lines, at);
                    }
                }
            }
            _ => {}
        }
    }
}

/// The problems of a file, each with its line and column, in file order:
/// section by section as `sections` (the file's) lists them, a section's
/// problems by line. A key missing from a `[[sequence]]` entry goes with
/// its entry; the others not in the file (left at their defaults) go
/// after the section's others, in the order found.
pub(super) fn in_file_order(
    text: &str,
    sections: &[String],
    mut errors: Vec<ConfigError>,
) -> ConfigErrors {
    let lines = KeyLines::of(text);
    for error in &mut errors {
        (error.line, error.column) = lines.find(&error.key).unzip();
    }
    errors.sort_by_key(|error| {
        let section = error.key.split(['.', ' ']).next().unwrap_or_default();
        let rank = sections.iter().position(|s| s == section);
        let entry = error
            .key
            .split_once('.')
            .map(|(entry, _)| entry)
            .filter(|entry| entry.contains(" #"));
        let line = error
            .line
            .or_else(|| entry.and_then(|e| lines.find(e)).map(|(line, _)| line));
        (rank.unwrap_or(usize::MAX), line.unwrap_or(usize::MAX))
    });
    ConfigErrors(errors)
}

/// A syntax error, with its line and column.
pub(super) fn syntax_error(text: &str, error: &toml::de::Error) -> ConfigError {
    let (line, column) = error
        .span()
        .map(|span| line_column(text, span.start))
        .unzip();
    ConfigError {
        // Where the parser gives no position, at least say it is the file.
        key: if line.is_some() {
            String::new()
        } else {
            "(file)".into()
        },
        line,
        column,
        message: format!("not valid TOML: {}", error.message().trim()),
    }
}

/// 1-based line and column (in characters) of a byte offset.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let before = text.get(..offset).unwrap_or(text);
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_and_sequences_have_their_lines() {
        let text = "# a comment\n[detector]\nmin_burst_ms = 0\n\n[[sequence]]\nactions = [1]\n  mode = \"fingers\"\n";
        let lines = KeyLines::of(text);
        assert_eq!(lines.find("detector.min_burst_ms"), Some((3, 1)));
        assert_eq!(lines.find("sequence #1.mode"), Some((7, 3)));
        assert_eq!(lines.find("sequence #1.actions"), Some((6, 1)));
        assert_eq!(lines.find("detector.glitch_ms"), None);
        let nested = KeyLines::of("[sensor]\nreconnect = true\n[sensor.evdev]\naxis = \"ABS_Y\"\n");
        assert_eq!(nested.find("sensor.evdev.axis"), Some((4, 1)));
        assert_eq!(nested.find("sensor.reconnect"), Some((2, 1)));
    }

    #[test]
    fn a_syntax_error_has_its_line_and_column() {
        let text = "[detector]\nmin_burst_ms = 40\nmin_burst_ms = 50\n";
        let error = text.parse::<toml::Table>().unwrap_err();
        let e = syntax_error(text, &error);
        assert_eq!(e.line, Some(3));
        assert_eq!(e.column, Some(1));
        assert!(
            e.message.starts_with("not valid TOML: duplicate key"),
            "{e}"
        );
    }
}
