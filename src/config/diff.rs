//! What a configuration file changes from the built-in configuration, with
//! the reason written above each changed key: the short table a clinician
//! prints or photographs (`sipnpuff config --diff`), where `sipnpuff
//! config` gives every key.
//!
//! Both configurations are compared as `config` prints them, through the
//! file's serde layout, value text against value text: every key is
//! compared and named as the file names it, no key is listed here. The
//! library is compared mode by mode, since a file's `[[sequence]]` list
//! replaces the built-in one whole. Pure: configurations and text in,
//! rows and text out.

use toml::{Table, Value};

use crate::config::Config;
use crate::config::file::File;
use crate::config::layers::Layered;
use crate::config::lines::KeyLines;
use crate::control::selection::SequenceEntry;
use crate::control::target::Target;

/// How wide [`table`] is meant to be, in characters: a printed page, a
/// photographed screen.
pub const TABLE_WIDTH: usize = 100;

/// One key whose value differs from the built-in one.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Change {
    /// The full dotted key as errors name it (`detector.long_burst_ms`);
    /// for the library, `sequence` (its size), then one row per mode whose
    /// sequences changed: `sequence #N (mode)`, N the file's entry (`#N,
    /// #M` for several; no number for a mode the file dropped).
    pub key: String,
    /// The built-in value as `config` prints it, with its unit if the key
    /// names one (`500 ms`, `3.0 V`).
    pub default: String,
    /// The file's value, likewise.
    pub value: String,
    /// The comment line(s) directly above the key in the file, joined;
    /// empty if none.
    pub reason: String,
    /// The file the value came from, as named on the command line (empty
    /// when only one file is compared).
    pub from: String,
}

/// Every key whose value in `config` differs from `base`'s, in the order
/// `config` prints them, each with its reason from `text`, the file
/// `config` was read from.
pub fn changes(
    base: &Config,
    config: &Config,
    text: &str,
) -> Result<Vec<Change>, toml::ser::Error> {
    let mut diff = Diff {
        files: vec![FileText::of(text)],
        names: vec![String::new()],
        source: &|_| Some(0),
        base: base.core().sequences(),
        file: config.core().sequences(),
        rows: Vec::new(),
    };
    diff.tables(&tree(base)?, &tree(config)?, "")?;
    Ok(diff.rows)
}

/// Every key whose value in a setup of several files differs from
/// `base`'s, as [`changes`], each with its reason from the file that set
/// it and that file's name.
pub fn layered_changes(base: &Config, setup: &Layered) -> Result<Vec<Change>, toml::ser::Error> {
    let source = |key: &str| setup.source_index(key);
    let mut diff = Diff {
        files: setup
            .layers()
            .iter()
            .map(|l| FileText::of(&l.text))
            .collect(),
        names: (setup.layers().iter())
            .map(|l| l.path.display().to_string())
            .collect(),
        source: &source,
        base: base.core().sequences(),
        file: setup.config().core().sequences(),
        rows: Vec::new(),
    };
    diff.tables(&tree(base)?, &tree(setup.config())?, "")?;
    Ok(diff.rows)
}

/// One file's text, indexed: where each key is, and its lines.
struct FileText<'a> {
    lines: KeyLines,
    text: Vec<&'a str>,
}

impl<'a> FileText<'a> {
    fn of(text: &'a str) -> FileText<'a> {
        FileText {
            lines: KeyLines::of(text),
            text: text.lines().collect(),
        }
    }

    /// The lines above 1-based `line`, nearest first.
    fn above(&self, line: usize) -> impl Iterator<Item = &&'a str> {
        let before = self.text.get(..line.saturating_sub(1));
        before.unwrap_or_default().iter().rev()
    }
}

/// A configuration as `config` prints it, as a TOML tree.
fn tree(config: &Config) -> Result<Table, toml::ser::Error> {
    let file = File::new(
        config.core().clone(),
        config.sensor().clone(),
        config.arm().clone(),
        config.output().clone(),
        config.rt().clone(),
    );
    Table::try_from(file)
}

/// The comparison under way.
struct Diff<'a> {
    /// The files compared, in order.
    files: Vec<FileText<'a>>,
    /// Their names, as the rows give them.
    names: Vec<String>,
    /// The file (in `files`) that set a key.
    source: &'a dyn Fn(&str) -> Option<usize>,
    base: &'a [SequenceEntry],
    file: &'a [SequenceEntry],
    rows: Vec<Change>,
}

impl Diff<'_> {
    /// Compares two tables key by key, `prefix` naming them.
    fn tables(&mut self, base: &Table, file: &Table, prefix: &str) -> Result<(), toml::ser::Error> {
        let only_in_file = file.keys().filter(|key| !base.contains_key(*key));
        for key in base.keys().chain(only_in_file) {
            let name = format!("{prefix}{key}");
            match (base.get(key), file.get(key)) {
                (Some(Value::Table(b)), Some(Value::Table(f))) => {
                    self.tables(b, f, &format!("{name}."))?;
                }
                (b, f) if printed(b) == printed(f) => {}
                (b, f) if is_table_list(b) || is_table_list(f) => self.library(&name)?,
                (b, f) => {
                    let reason = self.reason_at(&name);
                    let from = self.from(&name);
                    self.rows.push(Change {
                        default: shown(b, key),
                        value: shown(f, key),
                        key: name,
                        reason,
                        from,
                    });
                }
            }
        }
        Ok(())
    }

    /// The library (`name`, the `[[sequence]]` list) changed: its size,
    /// with the comment above the first `[[sequence]]` (the list's
    /// reason), then each mode whose sequences changed, the file's modes
    /// in its order, then those it dropped.
    fn library(&mut self, name: &str) -> Result<(), toml::ser::Error> {
        let at = self.rows.len();
        let from = self.from(name);
        let reason = self.file_of(name).map_or(String::new(), |file| {
            (file.lines.find(&format!("{name} #1")))
                .map_or(String::new(), |(line, _)| comment(file.above(line)))
        });
        self.rows.push(Change {
            key: name.to_string(),
            default: entries(self.base.len()),
            value: entries(self.file.len()),
            reason,
            from: from.clone(),
        });
        let mut targets: Vec<Target> = Vec::new();
        for entry in self.file.iter().chain(self.base) {
            if !targets.contains(&entry.target) {
                targets.push(entry.target);
            }
        }
        for mode in targets {
            let (base, file) = (sequences(self.base, mode)?, sequences(self.file, mode)?);
            if sorted(&base) == sorted(&file) {
                continue;
            }
            let numbers: Vec<usize> = (1..=self.file.len())
                .filter(|n| self.file[n - 1].target == mode)
                .collect();
            let (key, reason) = match numbers.first() {
                None => (format!("{name} ({})", mode.label()), String::new()),
                Some(&first) => {
                    let numbers: Vec<String> = numbers.iter().map(|n| format!("#{n}")).collect();
                    let key = format!("{name} {} ({})", numbers.join(", "), mode.label());
                    (key, self.entry_reason(name, first))
                }
            };
            self.rows.push(Change {
                key,
                default: either(&base),
                value: either(&file),
                reason,
                from: from.clone(),
            });
        }
        if self.rows.len() == at + 1 {
            self.rows[at].value += ", in another order";
        }
        Ok(())
    }

    /// The file that set `key`, if one did.
    fn file_of(&self, key: &str) -> Option<&FileText<'_>> {
        (self.source)(key).and_then(|i| self.files.get(i))
    }

    /// The name of the file that set `key` (`built-in` if none did).
    fn from(&self, key: &str) -> String {
        match (self.source)(key).and_then(|i| self.names.get(i)) {
            Some(name) => name.clone(),
            None => "built-in".into(),
        }
    }

    /// The comment right above `key`'s line in the file that set it.
    fn reason_at(&self, key: &str) -> String {
        self.file_of(key)
            .and_then(|file| {
                let (line, _) = file.lines.find(key)?;
                Some(comment(file.above(line)))
            })
            .unwrap_or_default()
    }

    /// The comment right above the `[[sequence]]` header of the list
    /// `name`'s entry `number`, or, if none, right below it (above the
    /// entry's first key). The first entry's, only below: the one above is
    /// the library's.
    fn entry_reason(&self, name: &str, number: usize) -> String {
        let Some(file) = self.file_of(name) else {
            return String::new();
        };
        let Some((line, _)) = file.lines.find(&format!("{name} #{number}")) else {
            return String::new();
        };
        let above = if number == 1 {
            String::new()
        } else {
            comment(file.above(line))
        };
        if above.is_empty() {
            let mut below: Vec<&str> = (file.text.get(line..).unwrap_or_default().iter())
                .take_while(|l| l.trim_start().starts_with('#'))
                .copied()
                .collect();
            below.reverse();
            comment(below.iter())
        } else {
            above
        }
    }
}

/// The comment lines at the start of `lines` (read upwards), in file
/// order, joined without their `#`s.
fn comment<'a>(lines: impl Iterator<Item = &'a &'a str>) -> String {
    let mut words: Vec<&str> = lines
        .map(|line| line.trim())
        .take_while(|line| line.starts_with('#'))
        .map(|line| line.trim_start_matches('#').trim())
        .collect();
    words.reverse();
    words.retain(|line| !line.is_empty());
    words.join(" ")
}

/// A value as `config` prints it (nothing for a key one side lacks).
fn printed(value: Option<&Value>) -> Option<String> {
    value.map(Value::to_string)
}

/// A value as `config` prints it, with the unit `key` names.
fn shown(value: Option<&Value>, key: &str) -> String {
    let Some(value) = value else {
        return "(none)".into();
    };
    let number = |v: &Value| matches!(v, Value::Integer(_) | Value::Float(_));
    let numeric = match value {
        Value::Array(items) => !items.is_empty() && items.iter().all(number),
        other => number(other),
    };
    match unit(key) {
        Some(unit) if numeric => format!("{value} {unit}"),
        _ => value.to_string(),
    }
}

/// The unit a key's name ends with (`_ms`, `_volts`, …), if any.
fn unit(key: &str) -> Option<&'static str> {
    let (_, suffix) = key.rsplit_once('_')?;
    Some(match suffix {
        "ms" => "ms",
        "volts" => "V",
        "hz" => "Hz",
        "m" => "m",
        "mps" => "m/s",
        "mps2" => "m/s²",
        "mps3" => "m/s³",
        "rad" => "rad",
        "radps" => "rad/s",
        "radps2" => "rad/s²",
        "radps3" => "rad/s³",
        _ => return None,
    })
}

/// Whether a value is a list of tables (`[[sequence]]`).
fn is_table_list(value: Option<&Value>) -> bool {
    matches!(value, Some(Value::Array(items)) if items.iter().any(Value::is_table))
}

/// "9 entries".
fn entries(count: usize) -> String {
    format!("{count} {}", if count == 1 { "entry" } else { "entries" })
}

/// The sequences that select or fire `target`, each as `config` prints
/// it.
fn sequences(library: &[SequenceEntry], target: Target) -> Result<Vec<String>, toml::ser::Error> {
    library
        .iter()
        .filter(|entry| entry.target == target)
        .map(|entry| Value::try_from(entry.actions).map(|v| v.to_string()))
        .collect()
}

/// `list` in order, to compare as a set.
fn sorted(list: &[String]) -> Vec<&String> {
    let mut sorted: Vec<&String> = list.iter().collect();
    sorted.sort();
    sorted
}

/// Sequences that each select the mode: `[1, 2] or [2, 2]`; `none`.
fn either(sequences: &[String]) -> String {
    if sequences.is_empty() {
        "none".into()
    } else {
        sequences.join(" or ")
    }
}

/// The changes as a plain-text table about [`TABLE_WIDTH`] wide, under a
/// line naming the file (`name`): key, default, this file's value and
/// reason, each cell wrapped at spaces to its column; one line if nothing
/// changed.
pub fn table(name: &str, changes: &[Change]) -> String {
    grid(name, changes, false)
}

/// The changes of a setup of several files (`name` lists them), as
/// [`table`] with a column saying which file each value came from.
pub fn layered_table(name: &str, changes: &[Change]) -> String {
    grid(name, changes, true)
}

/// The table, with the `from` column or without.
fn grid(name: &str, changes: &[Change], with_from: bool) -> String {
    if changes.is_empty() {
        return format!("{name}: no changes from default\n");
    }
    let value_head = if with_from { "value" } else { "this file" };
    let mut head = vec!["key", "default", value_head];
    if with_from {
        head.push("from");
    }
    head.push("reason");
    let cells = |c: &Change| -> Vec<String> {
        let mut row = vec![c.key.clone(), c.default.clone(), c.value.clone()];
        if with_from {
            row.push(c.from.clone());
        }
        row.push(c.reason.clone());
        row
    };
    let rows: Vec<Vec<String>> = changes.iter().map(cells).collect();
    let widest = |column: usize, cap: usize| {
        rows.iter()
            .map(|row| row[column].chars().count())
            .chain([head[column].len()])
            .max()
            .unwrap_or(0)
            .min(cap)
    };
    let last = head.len() - 1;
    let mut widths: Vec<usize> = vec![widest(0, 36), widest(1, 22), widest(2, 22)];
    if with_from {
        widths.push(widest(3, 24));
    }
    let room = TABLE_WIDTH
        .saturating_sub(widths.iter().sum::<usize>() + 2 * last)
        .max(24);
    widths.push(widest(last, room));
    let mut out = format!("{name}: changes from default\n");
    let rule: Vec<String> = widths.iter().map(|&w| "-".repeat(w)).collect();
    let head: Vec<String> = head.iter().map(|h| h.to_string()).collect();
    for row in [head, rule].iter().chain(&rows) {
        let wrapped: Vec<Vec<String>> = (0..=last).map(|i| wrap(&row[i], widths[i])).collect();
        let height = wrapped.iter().map(Vec::len).max().unwrap_or(1);
        for line in 0..height {
            let mut text = String::new();
            for (i, cell) in wrapped.iter().enumerate() {
                let part = cell.get(line).map_or("", String::as_str);
                text += part;
                if i < last {
                    let pad = widths[i].saturating_sub(part.chars().count()) + 2;
                    text.extend(std::iter::repeat_n(' ', pad));
                }
            }
            out += text.trim_end();
            out.push('\n');
        }
    }
    if changes.iter().any(|c| c.key.starts_with("sequence ")) {
        out += SEQUENCE_KEY;
        out.push('\n');
    }
    out
}

/// What a sequence's numbers mean, under every table that shows one.
pub const SEQUENCE_KEY: &str = "sequences: 1 short sip, 2 long sip, -1 short puff, -2 long puff";

/// `text` in lines of at most `width` characters, broken at spaces (a
/// word longer than that, cut).
fn wrap(text: &str, width: usize) -> Vec<String> {
    let width = width.max(1);
    let mut lines = Vec::new();
    let mut line = String::new();
    for word in text.split_whitespace() {
        let chars: Vec<char> = word.chars().collect();
        for piece in chars.chunks(width) {
            let length = line.chars().count();
            if length > 0 && length + 1 + piece.len() > width {
                lines.push(std::mem::take(&mut line));
            }
            if !line.is_empty() {
                line.push(' ');
            }
            line.extend(piece);
        }
    }
    if !line.is_empty() || lines.is_empty() {
        lines.push(line);
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rows(text: &str) -> Vec<Change> {
        let config = Config::from_toml_str(text).unwrap();
        changes(&Config::default(), &config, text).unwrap()
    }

    fn change(key: &str, default: &str, value: &str, reason: &str) -> Change {
        Change {
            key: key.into(),
            default: default.into(),
            value: value.into(),
            reason: reason.into(),
            from: String::new(),
        }
    }

    const PROFILE: &str = r#"# sipnpuff profile: label "ana", fitted 2026-12-03 by sipnpuff 0.1.0
# protocol: rest 5 s; 8 × short puff, ...

[detector]
# puff threshold 0.31 V above rest: midway between the rest noise's
# largest excursion, 0.06 V, and your weakest short puff's plateau, 0.56 V
puff_threshold_volts = 2.81
min_burst_ms = 40
# the short/long boundary where your short and long puffs are equally far in spreads
long_burst_ms = 470

[scanning]
# slower than the default: she reads each mode aloud
dwell_ms = 2000
"#;

    #[test]
    fn each_changed_key_is_a_row_with_the_comment_above_it() {
        assert_eq!(
            rows(PROFILE),
            [
                change(
                    "detector.puff_threshold_volts",
                    "3.0 V",
                    "2.81 V",
                    "puff threshold 0.31 V above rest: midway between the rest noise's \
                     largest excursion, 0.06 V, and your weakest short puff's plateau, 0.56 V"
                ),
                change(
                    "detector.long_burst_ms",
                    "500 ms",
                    "470 ms",
                    "the short/long boundary where your short and long puffs are equally far in spreads"
                ),
                change(
                    "scanning.dwell_ms",
                    "1500 ms",
                    "2000 ms",
                    "slower than the default: she reads each mode aloud"
                ),
            ]
        );
    }

    #[test]
    fn a_key_at_its_default_value_or_not_in_the_file_is_no_row() {
        assert_eq!(rows(""), []);
        assert_eq!(
            rows("[detector]\n# as built in\nmin_burst_ms = 40\nneutral_volts = 2.5\n"),
            []
        );
        // Nested tables, a flattened `[arm]` key, strings and arrays are
        // compared and named as the file names them; a key without a
        // comment has no reason, and a blank line ends a comment.
        let text = "[arm]\nhome_fingers = 0.0\nhome_position_m = [0.2, -0.26, 0.48]\n\
                    [arm.ros2]\n# not this\n\nframe_id = \"j2n6s300_link_base\"\n\
                    [sensor.evdev]\nsip_keys = [\"BTN_TRIGGER\", \"BTN_TOP\"]\n";
        assert_eq!(
            rows(text),
            [
                change(
                    "arm.home_position_m",
                    "[0.21, -0.26, 0.48] m",
                    "[0.2, -0.26, 0.48] m",
                    ""
                ),
                change(
                    "arm.ros2.frame_id",
                    "\"base_link\"",
                    "\"j2n6s300_link_base\"",
                    ""
                ),
                change(
                    "sensor.evdev.sip_keys",
                    "[\"BTN_TRIGGER\"]",
                    "[\"BTN_TRIGGER\", \"BTN_TOP\"]",
                    ""
                ),
            ]
        );
    }

    #[test]
    fn values_are_written_as_config_prints_them() {
        let text = "[workspace]\nmax_tilt_rad = 1.2345678901234567\n\
                    [motion]\nlinear_speed_mps = 0.18\nproportional_speed = true\n\
                    [sensor.serial]\nbaud = 9600\n";
        let found = rows(text);
        assert_eq!(found.len(), 4, "{found:?}");
        let printed = Config::from_toml_str(text).unwrap().to_toml().unwrap();
        let default = Config::default().to_toml().unwrap();
        for row in &found {
            let key = row.key.rsplit('.').next().unwrap();
            let bare = |shown: &str| shown.split(' ').next().unwrap().to_string();
            let line = |value: &str| format!("\n{key} = {value}\n");
            assert!(printed.contains(&line(&bare(&row.value))), "{row:?}");
            assert!(default.contains(&line(&bare(&row.default))), "{row:?}");
        }
        assert_eq!(found[0].value, "0.18 m/s");
        assert_eq!(found[1].value, "true");
        assert_eq!(found[2].value, "1.2345678901234567 rad");
        assert_eq!(found[3].value, "9600");
    }

    #[test]
    fn a_changed_library_gives_its_size_and_each_changed_mode() {
        let text = "# only the modes she uses\n[[sequence]]\n# easier for her than two short puffs\nactions = [1, 2, -1]\nmode = \"translate_x\"\n\
                    [[sequence]]\nactions = [-1, 1]\nmode = \"translate_y\"\n\
                    # two ways to the fingers\n[[sequence]]\nactions = [1, -1]\nmode = \"fingers\"\n\
                    [[sequence]]\nactions = [2, 2]\nmode = \"fingers\"\n";
        let none =
            |mode: &str, default: &str| change(&format!("sequence ({mode})"), default, "none", "");
        assert_eq!(
            rows(text),
            [
                change(
                    "sequence",
                    "9 entries",
                    "4 entries",
                    "only the modes she uses"
                ),
                change(
                    "sequence #1 (translate_x)",
                    "[-1, -1]",
                    "[1, 2, -1]",
                    "easier for her than two short puffs"
                ),
                change(
                    "sequence #3, #4 (fingers)",
                    "[1, -1]",
                    "[1, -1] or [2, 2]",
                    "two ways to the fingers"
                ),
                none("translate_z", "[1, 1]"),
                none("rotate_x", "[-2, -1]"),
                none("rotate_y", "[-2, 1]"),
                none("rotate_z", "[-2, -2]"),
                none("save_point", "[2, -1]"),
                none("goto_point", "[2, 1]"),
            ]
        );
        // The built-in library restated is no change; reordered, it is.
        let printed = Config::default().to_toml().unwrap();
        let library = &printed[printed.find("[[sequence]]").unwrap()..];
        let library = &library[..library.find("[sensor]").unwrap()];
        assert_eq!(rows(library), []);
        let (first, rest) = library.split_at(library[1..].find("[[sequence]]").unwrap() + 1);
        assert_eq!(
            rows(&format!("{rest}{first}")),
            [change(
                "sequence",
                "9 entries",
                "9 entries, in another order",
                ""
            )]
        );
    }

    #[test]
    fn the_table_wraps_long_cells_within_its_width() {
        let table = table("ana.toml", &rows(PROFILE));
        assert_eq!(
            table,
            "\
ana.toml: changes from default
key                            default  this file  reason
-----------------------------  -------  ---------  -------------------------------------------------
detector.puff_threshold_volts  3.0 V    2.81 V     puff threshold 0.31 V above rest: midway between
                                                   the rest noise's largest excursion, 0.06 V, and
                                                   your weakest short puff's plateau, 0.56 V
detector.long_burst_ms         500 ms   470 ms     the short/long boundary where your short and long
                                                   puffs are equally far in spreads
scanning.dwell_ms              1500 ms  2000 ms    slower than the default: she reads each mode
                                                   aloud
"
        );
        assert!(table.lines().all(|l| l.chars().count() <= TABLE_WIDTH));
        let order = rows("[scanning]\norder = [\"fingers\", \"translate_x\", \"translate_y\"]\n");
        let wide = super::table("s.toml", &order);
        assert!(
            wide.lines().all(|l| l.chars().count() <= TABLE_WIDTH),
            "{wide}"
        );
        assert_eq!(
            super::table("x.toml", &[]),
            "x.toml: no changes from default\n"
        );
    }

    #[test]
    fn wrapping_breaks_at_spaces_and_cuts_only_a_longer_word() {
        assert_eq!(wrap("", 5), [""]);
        assert_eq!(wrap("ab cd ef", 5), ["ab cd", "ef"]);
        assert_eq!(wrap("abcdefgh ij", 3), ["abc", "def", "gh", "ij"]);
    }
}
