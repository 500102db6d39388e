//! What the person gave is wrong: a configuration that does not validate,
//! an option that names nothing, found before anything started. Any layer
//! that reads what the command line names may say so; the command line
//! turns it into its exit status for an invalid start (2).

use std::fmt;

/// An invalid command line or configuration, found before anything
/// started.
#[derive(Debug)]
pub struct Invalid(pub anyhow::Error);

impl fmt::Display for Invalid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:#}", self.0)
    }
}

impl std::error::Error for Invalid {}

/// `result`'s error, as an invalid command line or configuration.
pub fn invalid<T>(result: anyhow::Result<T>) -> anyhow::Result<T> {
    result.map_err(|e| Invalid(e).into())
}
