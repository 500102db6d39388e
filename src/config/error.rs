//! What is wrong with a configuration, in words a clinician can act on:
//! every problem with its key and line, all at once.

use std::fmt;

/// One problem in a configuration: the key, where it is, what is wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConfigError {
    /// Dotted key, e.g. `detector.min_burst_ms` or `sequence #3.mode`
    /// (sequences counted from 1 in file order); empty for a syntax error
    /// with a line, `(file)` for one without.
    pub key: String,
    /// 1-based line of the key (or of the syntax error) in the file, when
    /// it is there (a key left at its default has none).
    pub line: Option<usize>,
    /// 1-based column, with `line`.
    pub column: Option<usize>,
    /// What is wrong, in plain words.
    pub message: String,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(line) = self.line {
            write!(f, "line {line}")?;
            if let Some(column) = self.column {
                write!(f, ", column {column}")?;
            }
            f.write_str(": ")?;
        }
        if !self.key.is_empty() {
            write!(f, "{}: ", self.key)?;
        }
        f.write_str(&self.message)
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

/// The problems found so far in a configuration, in the order found:
/// the reader and the checks add to it.
#[derive(Debug, Default)]
pub(super) struct Problems {
    pub(super) errors: Vec<ConfigError>,
}

impl Problems {
    /// Records a problem with `key`.
    pub(super) fn add(&mut self, key: impl Into<String>, message: impl Into<String>) {
        self.errors.push(ConfigError {
            key: key.into(),
            line: None,
            column: None,
            message: message.into(),
        });
    }

    /// Whether a problem with `key` is recorded already.
    pub(super) fn has(&self, key: &str) -> bool {
        self.errors.iter().any(|e| e.key == key)
    }
}

/// A configuration file that cannot be used: unreadable, or with problems.
#[derive(Debug)]
pub enum ConfigFileError {
    /// The file cannot be read.
    Read {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// The file has problems.
    Invalid {
        /// The file.
        path: std::path::PathBuf,
        /// Every problem.
        errors: ConfigErrors,
    },
}

impl fmt::Display for ConfigFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ConfigFileError::Read { path, error } => {
                write!(f, "cannot read config {}: {error}", path.display())
            }
            ConfigFileError::Invalid { path, errors } => write!(f, "{}: {errors}", path.display()),
        }
    }
}

impl std::error::Error for ConfigFileError {}
