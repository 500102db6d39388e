//! Reading: TOML into the file's serde types ([`File`]), every problem in
//! one pass. serde stops at the first problem in a file; the reader
//! records it with its key, mends the file and reads again, until it
//! reads. Mending: an unknown key is dropped, a name that is none of the
//! choices is dropped from its list, a missing or wrong value takes the
//! built-in one (so the checks that follow still run). A file with
//! problems is refused: the mended values are never used.

use serde_path_to_error::Segment;
use toml::{Table, Value};

use crate::config::error::Problems;
use crate::config::file::File;
use crate::config::library::TARGET_KEYS;

/// One step into a TOML tree: a key of a table or an index in an array.
#[derive(Debug, Clone, PartialEq)]
enum Step {
    Key(String),
    Index(usize),
}

/// Where in the file serde stopped, and why.
#[derive(Debug, PartialEq)]
struct Stop {
    path: Vec<Step>,
    message: String,
}

/// Reads a parsed file; each problem goes to `problems` with its key.
/// The result is meaningful only when there are none.
pub(super) fn file(root: Table, problems: &mut Problems) -> File {
    let sample = File::sample();
    let mut reader = Reader {
        file: Value::Table(root),
        sample: &sample,
        problems,
        mended: Vec::new(),
    };
    loop {
        match read(&reader.file) {
            Ok(file) => return file,
            Err(stop) => {
                if !reader.mend(stop) {
                    return File::default();
                }
            }
        }
    }
}

/// The file read through serde, or where it stops.
fn read(file: &Value) -> Result<File, Stop> {
    serde_path_to_error::deserialize(file.clone()).map_err(|error| Stop {
        path: error
            .path()
            .iter()
            .filter_map(|segment| match segment {
                Segment::Map { key } => Some(Step::Key(key.clone())),
                Segment::Seq { index } => Some(Step::Index(*index)),
                _ => None,
            })
            .collect(),
        message: error.inner().message().trim().to_string(),
    })
}

/// The file being mended, the built-in configuration it is checked
/// against (same layout), and what was found.
struct Reader<'a> {
    file: Value,
    sample: &'a Value,
    problems: &'a mut Problems,
    /// Values already replaced by the built-in ones.
    mended: Vec<Vec<Step>>,
}

impl Reader<'_> {
    /// Records the problem serde stopped at and mends the file; `false`
    /// if nothing is left to mend.
    fn mend(&mut self, stop: Stop) -> bool {
        let mut path = stop.path.clone();
        while get(&self.file, &path).is_none() {
            if path.pop().is_none() {
                return false;
            }
        }
        if let Some(field) = missing_field(&stop.message) {
            path.push(Step::Key(field.into()));
            self.problems.add(self.key(&path), "missing");
            return self.replace(path);
        }
        // serde names only the table when the key is in a part flattened
        // into it (`[arm]`'s backends).
        let path = self.culprit(&self.file, path, &stop);
        match path.split_last() {
            Some((Step::Key(key), parent)) if !self.known(parent, key) => {
                self.unknown(parent, key);
                true
            }
            Some((Step::Index(index), list)) if !self.is_table_list(list) => {
                self.mend_item(list.to_vec(), *index, &stop.message)
            }
            Some(_) => self.mend_value(path, &stop.message),
            None => false,
        }
    }

    /// The key in the table at `path` (or deeper) that alone makes serde
    /// stop as it did: `path` itself if there is none.
    fn culprit(&self, file: &Value, path: Vec<Step>, stop: &Stop) -> Vec<Step> {
        let (Some(Value::Table(table)), Some(Value::Table(sample))) =
            (get(file, &path), self.sample_at(&path))
        else {
            return path;
        };
        for (key, value) in table {
            let mut alone = sample.clone();
            alone.insert(key.clone(), value.clone());
            let mut trial = file.clone();
            set(&mut trial, &path, Value::Table(alone));
            if read(&trial).err().as_ref() == Some(stop) {
                let mut inner = path.clone();
                inner.push(Step::Key(key.clone()));
                return self.culprit(&trial, inner, stop);
            }
        }
        path
    }

    /// A value that is wrong as a whole: recorded, and replaced by the
    /// built-in one.
    fn mend_value(&mut self, mut path: Vec<Step>, message: &str) -> bool {
        if self.mended.contains(&path) {
            // The built-in value did not help: replace the table around
            // it (the problem is recorded already).
            path.pop();
            return !path.is_empty() && self.replace(path);
        }
        let key = self.key(&path);
        // A library entry whose target key was wrong (and is dropped) says
        // nothing more about having no target.
        let target_problem = TARGET_KEYS
            .iter()
            .any(|k| self.problems.has(&format!("{key}.{k}")));
        if self.is_entry(&path) && target_problem {
            return self.replace(path);
        }
        let value = get(&self.file, &path);
        let found = value.map_or("nothing", Value::type_str);
        let problem = if self.sample_at(&path).is_some_and(Value::is_table)
            && !value.is_some_and(Value::is_table)
        {
            format!("must be a table, found {found}")
        } else if self.is_table_list(&path) && !value.is_some_and(Value::is_array) {
            format!("must be an array of tables ([[{key}]]), found {found}")
        } else if is_type_error(message) {
            format!("wrong type ({found}): {message}")
        } else {
            message.to_string()
        };
        self.problems.add(key, problem);
        self.replace(path)
    }

    /// An item of a list of values (not tables): a name that is none of
    /// the choices is dropped, so that the rest of the list is checked;
    /// a value of the wrong type makes the whole list wrong.
    fn mend_item(&mut self, list: Vec<Step>, index: usize, message: &str) -> bool {
        if is_type_error(message) {
            return self.mend_value(list, message);
        }
        self.problems.add(self.key(&list), message);
        if let Some(Value::Array(items)) = get_mut(&mut self.file, &list)
            && index < items.len()
        {
            items.remove(index);
            return true;
        }
        false
    }

    /// Records and drops the unknown `key` of the table at `path`.
    fn unknown(&mut self, path: &[Step], key: &str) {
        let mut known: Vec<&str> = match self.sample_at(path) {
            Some(Value::Table(table)) => table.keys().map(String::as_str).collect(),
            _ => Vec::new(),
        };
        if self.is_entry(path) {
            known.extend(TARGET_KEYS.iter().filter(|k| **k != "mode"));
        }
        let what = if path.is_empty() {
            "unknown section or key"
        } else {
            "unknown key"
        };
        let mut full = path.to_vec();
        full.push(Step::Key(key.into()));
        self.problems.add(
            self.key(&full),
            format!("{what} (known: {})", known.join(", ")),
        );
        if let Some(Value::Table(table)) = get_mut(&mut self.file, path) {
            table.remove(key);
        }
    }

    /// Puts the built-in value at `path` (dropping the file's if there is
    /// none); `false` if there is nothing to replace.
    fn replace(&mut self, path: Vec<Step>) -> bool {
        let done = match self.sample_at(&path).cloned() {
            Some(sample) => set(&mut self.file, &path, sample),
            None => remove(&mut self.file, &path),
        };
        self.mended.push(path);
        done
    }

    /// Whether the table at `path` may hold `key`. A library entry may
    /// hold any of the target keys, though the built-in entries show only
    /// `mode`.
    fn known(&self, path: &[Step], key: &str) -> bool {
        match self.sample_at(path) {
            Some(Value::Table(table)) => {
                table.contains_key(key) || (self.is_entry(path) && TARGET_KEYS.contains(&key))
            }
            _ => true,
        }
    }

    /// Whether `path` is an entry of the library (`[[sequence]]`).
    fn is_entry(&self, path: &[Step]) -> bool {
        matches!(path, [Step::Key(list), Step::Index(_)] if list == "sequence")
    }

    /// Whether the list at `path` holds tables (`[[sequence]]`).
    fn is_table_list(&self, path: &[Step]) -> bool {
        matches!(self.sample_at(path), Some(Value::Array(items)) if items.first().is_some_and(Value::is_table))
    }

    /// The built-in value at `path`: the first entry stands for any
    /// entry of a list.
    fn sample_at(&self, path: &[Step]) -> Option<&Value> {
        path.iter().try_fold(self.sample, |value, step| match step {
            Step::Key(key) => value.get(key.as_str()),
            Step::Index(_) => value.get(0),
        })
    }

    /// The key as errors name it: `detector.min_burst_ms`,
    /// `sequence #2.mode` (entries of a list of tables counted from 1).
    fn key(&self, path: &[Step]) -> String {
        let mut name = String::new();
        for (at, step) in path.iter().enumerate() {
            match step {
                Step::Key(key) => {
                    if !name.is_empty() {
                        name.push('.');
                    }
                    name += key;
                }
                Step::Index(index) => {
                    if self.is_table_list(&path[..at]) {
                        name += &format!(" #{}", index + 1);
                    }
                }
            }
        }
        name
    }
}

/// The field a "missing field `x`" message names.
fn missing_field(message: &str) -> Option<&str> {
    message.strip_prefix("missing field `")?.strip_suffix('`')
}

/// Whether serde's message says the value has the wrong type (rather than
/// a message of ours about a value of the right type).
fn is_type_error(message: &str) -> bool {
    ["invalid type: ", "invalid value: ", "invalid length "]
        .iter()
        .any(|start| message.starts_with(start))
}

/// The value at `path`.
fn get<'v>(value: &'v Value, path: &[Step]) -> Option<&'v Value> {
    path.iter().try_fold(value, |value, step| match step {
        Step::Key(key) => value.get(key.as_str()),
        Step::Index(index) => value.get(*index),
    })
}

/// The value at `path`, to change.
fn get_mut<'v>(value: &'v mut Value, path: &[Step]) -> Option<&'v mut Value> {
    path.iter().try_fold(value, |value, step| match step {
        Step::Key(key) => value.get_mut(key.as_str()),
        Step::Index(index) => value.get_mut(*index),
    })
}

/// Puts `new` at `path`; `false` if its table or list is not there.
fn set(value: &mut Value, path: &[Step], new: Value) -> bool {
    let Some((last, parent)) = path.split_last() else {
        *value = new;
        return true;
    };
    match (get_mut(value, parent), last) {
        (Some(Value::Table(table)), Step::Key(key)) => {
            table.insert(key.clone(), new);
            true
        }
        (Some(Value::Array(items)), Step::Index(index)) if *index < items.len() => {
            items[*index] = new;
            true
        }
        _ => false,
    }
}

/// Drops the value at `path`; `false` if it is not there.
fn remove(value: &mut Value, path: &[Step]) -> bool {
    let Some((last, parent)) = path.split_last() else {
        return false;
    };
    match (get_mut(value, parent), last) {
        (Some(Value::Table(table)), Step::Key(key)) => table.remove(key).is_some(),
        (Some(Value::Array(items)), Step::Index(index)) if *index < items.len() => {
            items.remove(*index);
            true
        }
        _ => false,
    }
}
