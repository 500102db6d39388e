//! `sipnpuff config`: check a configuration and print it, complete; or,
//! with `--diff`, only what a file changes from the built-in one.

use std::path::{Path, PathBuf};

use anyhow::Context;

use crate::cli::args::ConfigArg;
use crate::cli::output::{self, invalid};
use crate::config::{Config, diff};

/// `config`'s options.
#[derive(clap::Args, Debug)]
pub struct ConfigArgs {
    #[command(flatten)]
    config: ConfigArg,
    /// Check FILE as `--config` does, then print only what it changes from
    /// the built-in configuration: a table of each key that differs, its
    /// default, FILE's value and the comment above the key (its reason).
    #[arg(long, value_name = "FILE", conflicts_with = "config")]
    diff: Option<PathBuf>,
}

/// Prints the effective configuration as TOML, or the changes table.
pub fn config(args: ConfigArgs) -> anyhow::Result<()> {
    let text = match &args.diff {
        Some(path) => changes(path)?,
        None => args.config.load()?.to_toml()?,
    };
    output::stdout(&text).context("stdout")
}

/// The table of what the file at `path` changes from the built-in
/// configuration; an error is an invalid file (exit status 2), as
/// `--config`'s.
fn changes(path: &Path) -> anyhow::Result<String> {
    let (config, text) = invalid(Config::from_file_with_text(path).map_err(anyhow::Error::from))?;
    let rows = diff::changes(&Config::default(), &config, &text)?;
    Ok(diff::table(&path.display().to_string(), &rows))
}
