//! A person's setup from several files (`--config A --config B`): later
//! files override earlier ones key by key, a later library (`[[sequence]]`
//! list) replaces the whole library, and every setting remembers the file
//! it came from, so `config` can say so and `fit` can keep what it did not
//! measure. Every command that takes `--config` reads it here.
//!
//! Each file is checked on its own first (syntax, unknown keys, wrong
//! types: its own lines), then the merged settings are checked together,
//! each problem named by the file that set the key. All problems of all
//! files come at once.

use std::collections::BTreeMap;
use std::fmt;
use std::path::PathBuf;

use toml::{Table, Value};

use crate::config::error::Problems;
use crate::config::lines::{KeyLines, in_file_order, syntax_error};
use crate::config::{Config, ConfigError, ConfigFileError, read, validate};

/// The key of the library: a later file's list replaces an earlier one.
const LIBRARY: &str = "sequence";

/// One file of a setup: where it is and what it says.
#[derive(Debug, Clone, PartialEq)]
pub struct Layer {
    /// The file as named on the command line.
    pub path: PathBuf,
    /// Its text (its comments are the reasons `config --diff` shows).
    pub text: String,
}

/// The configuration several files make, with the file each setting came
/// from. Nothing given: the built-in configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct Layered {
    config: Config,
    layers: Vec<Layer>,
    /// Dotted key (`detector.long_burst_ms`, `sequence`) → the layer that
    /// set it last.
    sources: BTreeMap<String, usize>,
}

impl Default for Layered {
    fn default() -> Self {
        Layered::of(Config::default())
    }
}

impl Layered {
    /// A configuration built in code, every setting "built-in".
    pub fn of(config: Config) -> Layered {
        Layered {
            config,
            layers: Vec::new(),
            sources: BTreeMap::new(),
        }
    }

    /// Reads `paths` in order, each over the ones before; every problem of
    /// every file at once.
    pub fn read(paths: &[PathBuf]) -> Result<Layered, LayersError> {
        let mut problems = Vec::new();
        let mut layers = Vec::new();
        for path in paths {
            match std::fs::read_to_string(path) {
                Ok(text) => layers.push(Layer {
                    path: path.clone(),
                    text,
                }),
                // One file: said as `Config::from_file` says it.
                Err(error) if paths.len() == 1 => {
                    return Err(LayersError::One(ConfigFileError::Read {
                        path: path.clone(),
                        error,
                    }));
                }
                Err(error) => problems.push(LayerProblem::Unreadable {
                    path: path.clone(),
                    error: error.to_string(),
                }),
            }
        }
        if layers.len() == 1 && problems.is_empty() {
            // One file: exactly what `Config::from_file` says of it.
            let layer = &layers[0];
            return match Config::from_toml_str(&layer.text) {
                Ok(config) => {
                    let sources = sources_of(&layers);
                    Ok(Layered {
                        config,
                        layers,
                        sources,
                    })
                }
                Err(errors) => Err(LayersError::One(ConfigFileError::Invalid {
                    path: layer.path.clone(),
                    errors,
                })),
            };
        }
        let mut tables = Vec::new();
        for layer in &layers {
            match layer.text.parse::<Table>() {
                Ok(table) => {
                    let sections: Vec<String> = table.keys().cloned().collect();
                    let mut found = Problems::default();
                    read::file(table.clone(), &mut found);
                    let errors = in_file_order(&layer.text, &sections, found.errors);
                    problems.extend(errors.0.into_iter().map(|error| LayerProblem::In {
                        path: Some(layer.path.clone()),
                        error,
                    }));
                    tables.push(table);
                }
                Err(e) => problems.push(LayerProblem::In {
                    path: Some(layer.path.clone()),
                    error: syntax_error(&layer.text, &e),
                }),
            }
        }
        let sources = sources_of(&layers);
        let mut merged = Table::new();
        for table in tables {
            merge(&mut merged, table);
        }
        // The merged files read (what one file got wrong is mended, and
        // said above with its own line), then checked together.
        let mut mended = Problems::default();
        let (core, sensor, arm, output, rt) = read::file(merged, &mut mended).into_parts();
        let mut found = Problems::default();
        if problems.is_empty() {
            found.errors = mended.errors;
        }
        validate::config(&mut found, &core, &sensor, &arm, &output, &rt);
        if found.errors.is_empty() && problems.is_empty() {
            let config = Config {
                core,
                sensor,
                arm,
                output,
                rt,
            };
            return Ok(Layered {
                config,
                layers,
                sources,
            });
        }
        let mut named: Vec<(Option<usize>, ConfigError)> = found
            .errors
            .into_iter()
            .map(|mut error| {
                let at = source_of(&sources, &error.key);
                if let Some(i) = at {
                    let lines = KeyLines::of(&layers[i].text);
                    let entry = error.key.split_once('.').map_or(&*error.key, |(e, _)| e);
                    (error.line, error.column) =
                        lines.find(&error.key).or_else(|| lines.find(entry)).unzip();
                }
                (at, error)
            })
            .collect();
        named.sort_by_key(|(at, error)| (at.unwrap_or(usize::MAX), error.line));
        problems.extend(named.into_iter().map(|(at, error)| LayerProblem::In {
            path: at.map(|i| layers[i].path.clone()),
            error,
        }));
        // File by file, in the order given; within a file, by line.
        let rank = |p: &LayerProblem| -> (usize, usize) {
            match p {
                LayerProblem::Unreadable { path, .. } => (
                    paths.iter().position(|q| q == path).unwrap_or(usize::MAX),
                    0,
                ),
                LayerProblem::In { path, error } => (
                    (path.as_ref())
                        .and_then(|path| paths.iter().position(|q| q == path))
                        .unwrap_or(usize::MAX),
                    error.line.unwrap_or(usize::MAX),
                ),
            }
        };
        problems.sort_by_key(rank);
        problems.dedup();
        Err(LayersError::Several(problems))
    }

    /// The validated configuration.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The configuration, without its sources.
    pub fn into_config(self) -> Config {
        self.config
    }

    /// The files, in the order given.
    pub fn layers(&self) -> &[Layer] {
        &self.layers
    }

    /// The file that set `key` (dotted, as errors and `config --diff` name
    /// it: `detector.long_burst_ms`, `sequence #3.mode`, `arm.ros2`);
    /// `None`: the built-in value.
    pub fn source(&self, key: &str) -> Option<&Layer> {
        source_of(&self.sources, key).map(|i| &self.layers[i])
    }

    /// Index of the file that set `key`, in [`Layered::layers`].
    pub fn source_index(&self, key: &str) -> Option<usize> {
        source_of(&self.sources, key)
    }

    /// Every setting the files give (a leaf key, or a list such as the
    /// library as one key), in the order the merged files hold them, each
    /// with the value the last file gave and that file's index.
    pub fn settings(&self) -> Vec<Setting> {
        let mut merged = Table::new();
        for layer in &self.layers {
            if let Ok(table) = layer.text.parse::<Table>() {
                merge(&mut merged, table);
            }
        }
        let mut out = Vec::new();
        flatten(&merged, "", &self.sources, &mut out);
        out
    }

    /// Where `key` came from, in words: `from FILE` or `built-in`.
    pub fn origin(&self, key: &str) -> String {
        match self.source(key) {
            Some(layer) => format!("from {}", layer.path.display()),
            None => "built-in".to_string(),
        }
    }

    /// The files in words: `A`, `A, then B`, or `the built-in
    /// configuration`.
    pub fn describe(&self) -> String {
        if self.layers.is_empty() {
            return "the built-in configuration".into();
        }
        let names: Vec<String> = self
            .layers
            .iter()
            .map(|l| l.path.display().to_string())
            .collect();
        names.join(", then ")
    }

    /// The complete configuration as TOML (as [`Config::to_toml`]), each
    /// setting followed by where it came from (`# from FILE`, `# built-in`),
    /// each library entry's header too.
    pub fn to_toml(&self) -> Result<String, toml::ser::Error> {
        let text = self.config.to_toml()?;
        let mut out = String::new();
        let mut section = String::new();
        let mut in_library = false;
        let mut first = true;
        for line in text.lines() {
            let trimmed = line.trim();
            if first {
                first = false;
                out += line;
                out.push('\n');
                if !self.layers.is_empty() {
                    out += &format!(
                        "# layered from {}: a later file overrides an earlier one key by key; a later library replaces the whole library.\n",
                        self.describe()
                    );
                }
                continue;
            }
            if trimmed.starts_with("[[") {
                in_library = trimmed.starts_with(&format!("[[{LIBRARY}]]"));
                out += line;
                if in_library {
                    out += &format!(
                        "{}({})",
                        if line.contains('#') { " " } else { "  # " },
                        self.origin(LIBRARY)
                    );
                }
            } else if let Some(name) = trimmed.strip_prefix('[').and_then(|s| s.strip_suffix(']')) {
                in_library = false;
                section = name.to_string();
                out += line;
            } else if let Some((key, _)) = trimmed.split_once(" = ")
                && !in_library
                && !trimmed.starts_with('#')
            {
                let full = if section.is_empty() {
                    key.to_string()
                } else {
                    format!("{section}.{key}")
                };
                out += &format!("{line}  # {}", self.origin(&full));
            } else {
                out += line;
            }
            out.push('\n');
        }
        Ok(out)
    }
}

/// One setting a file gives.
#[derive(Debug, Clone, PartialEq)]
pub struct Setting {
    /// Its dotted key: `detector.glitch_ms`, `arm.ros2.topic`, `sequence`.
    pub key: String,
    /// Its value as the file wrote it.
    pub value: Value,
    /// The file that gave it, in [`Layered::layers`].
    pub layer: usize,
}

/// The leaves of `table` under `prefix`, each with its file.
fn flatten(table: &Table, prefix: &str, sources: &BTreeMap<String, usize>, out: &mut Vec<Setting>) {
    for (key, value) in table {
        let name = format!("{prefix}{key}");
        match value {
            Value::Table(inner) => flatten(inner, &format!("{name}."), sources, out),
            _ => {
                if let Some(&layer) = sources.get(&name) {
                    out.push(Setting {
                        key: name,
                        value: value.clone(),
                        layer,
                    });
                }
            }
        }
    }
}

/// Each leaf key of the files (`detector.long_burst_ms`; a list, such as
/// the library, as one key) → the last file that set it.
fn sources_of(layers: &[Layer]) -> BTreeMap<String, usize> {
    let mut sources = BTreeMap::new();
    for (i, layer) in layers.iter().enumerate() {
        if let Ok(table) = layer.text.parse::<Table>() {
            record(&table, "", i, &mut sources);
        }
    }
    sources
}

/// Records every leaf of `table` under `prefix` as set by layer `i`; a
/// value that is not a table replaces whatever was under its key.
fn record(table: &Table, prefix: &str, i: usize, sources: &mut BTreeMap<String, usize>) {
    for (key, value) in table {
        let name = format!("{prefix}{key}");
        match value {
            Value::Table(inner) => record(inner, &format!("{name}."), i, sources),
            _ => {
                let under = format!("{name}.");
                sources.retain(|k, _| !k.starts_with(&under));
                sources.insert(name, i);
            }
        }
    }
}

/// The layer that set `key` or the part of it that holds it: the key
/// itself, a key above it (`sequence` for `sequence #3.mode`), or the
/// last of the keys under it (`arm.ros2` for `arm.ros2.topic`).
fn source_of(sources: &BTreeMap<String, usize>, key: &str) -> Option<usize> {
    let mut name = key.split(" #").next().unwrap_or(key).to_string();
    loop {
        if let Some(&i) = sources.get(&name) {
            return Some(i);
        }
        match name.rsplit_once('.') {
            Some((above, _)) => name = above.to_string(),
            None => break,
        }
    }
    let under = format!("{key}.");
    sources
        .iter()
        .filter(|(k, _)| k.starts_with(&under))
        .map(|(_, &i)| i)
        .max()
}

/// `top` over `base`: tables merge key by key, anything else (a value, a
/// list, the library) replaces the earlier one whole.
fn merge(base: &mut Table, top: Table) {
    for (key, value) in top {
        match (base.get_mut(&key), value) {
            (Some(Value::Table(below)), Value::Table(above)) => merge(below, above),
            (_, value) => {
                base.insert(key, value);
            }
        }
    }
}

/// One problem of a setup: a file that cannot be read, or a key.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LayerProblem {
    /// The file cannot be read.
    Unreadable {
        /// The file.
        path: PathBuf,
        /// Why.
        error: String,
    },
    /// A problem with a key.
    In {
        /// The file that set the key (`None`: a built-in value that does
        /// not fit with the files').
        path: Option<PathBuf>,
        /// The key, its line in that file, what is wrong.
        error: ConfigError,
    },
}

impl fmt::Display for LayerProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LayerProblem::Unreadable { path, error } => {
                write!(f, "{}: cannot read it: {error}", path.display())
            }
            LayerProblem::In { path, error } => {
                match (path, error.line) {
                    (Some(path), Some(line)) => {
                        write!(f, "{}:{line}", path.display())?;
                        if let Some(column) = error.column {
                            write!(f, ":{column}")?;
                        }
                        f.write_str(": ")?;
                    }
                    (Some(path), None) => write!(f, "{}: ", path.display())?,
                    (None, _) => f.write_str("(built-in value) ")?,
                }
                if !error.key.is_empty() {
                    write!(f, "{}: ", error.key)?;
                }
                f.write_str(&error.message)
            }
        }
    }
}

/// A setup that cannot be used.
#[derive(Debug)]
pub enum LayersError {
    /// One file given: as [`Config::from_file`] says it.
    One(ConfigFileError),
    /// Several files: every problem, each naming its file and line.
    Several(Vec<LayerProblem>),
}

impl fmt::Display for LayersError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LayersError::One(error) => error.fmt(f),
            LayersError::Several(problems) => {
                let count = problems.len();
                writeln!(
                    f,
                    "{count} problem{} in the configuration:",
                    if count == 1 { "" } else { "s" }
                )?;
                for problem in problems {
                    writeln!(f, "  - {problem}")?;
                }
                Ok(())
            }
        }
    }
}

impl std::error::Error for LayersError {}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(text: &str) -> Table {
        text.parse().unwrap()
    }

    #[test]
    fn later_tables_merge_key_by_key_and_lists_replace_whole() {
        let mut base = table("[a]\nx = 1\ny = [1, 2]\n[[sequence]]\nactions = [1]\n");
        merge(
            &mut base,
            table("[a]\ny = [3]\n[[sequence]]\nactions = [2]\n[[sequence]]\nactions = [-1]\n"),
        );
        assert_eq!(
            base,
            table(
                "[a]\nx = 1\ny = [3]\n[[sequence]]\nactions = [2]\n[[sequence]]\nactions = [-1]\n"
            )
        );
    }

    #[test]
    fn a_key_names_the_last_file_that_set_it_or_what_holds_it() {
        let layers = [
            Layer {
                path: "a.toml".into(),
                text: "[detector]\nmin_burst_ms = 30\nglitch_ms = 5\n[[sequence]]\nactions = [1, 1]\nmode = \"fingers\"\n".into(),
            },
            Layer {
                path: "b.toml".into(),
                text: "[detector]\nmin_burst_ms = 40\n[arm.ros2]\ntopic = \"x\"\n".into(),
            },
        ];
        let sources = sources_of(&layers);
        assert_eq!(source_of(&sources, "detector.min_burst_ms"), Some(1));
        assert_eq!(source_of(&sources, "detector.glitch_ms"), Some(0));
        assert_eq!(source_of(&sources, "sequence #1.mode"), Some(0));
        assert_eq!(source_of(&sources, "sequence"), Some(0));
        assert_eq!(source_of(&sources, "arm.ros2"), Some(1));
        assert_eq!(source_of(&sources, "matcher.sequence_timeout_ms"), None);
    }
}
