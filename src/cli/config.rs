//! `sipnpuff config`: check a configuration and print it, complete, each
//! setting with the file it came from; or, with `--diff`, only what the
//! files change from the built-in one.

use std::path::PathBuf;

use anyhow::Context;

use crate::cli::args::ConfigArg;
use crate::cli::output;
use crate::config::Config;
use crate::config::diff;
use crate::config::layers::Layered;

/// `config`'s options.
#[derive(clap::Args, Debug)]
pub struct ConfigArgs {
    #[command(flatten)]
    config: ConfigArg,
    /// Print only what the configuration changes from the built-in one: a
    /// table of each key that differs, its default, its value and the
    /// comment above the key in its file (its reason); with several
    /// `--config` files, the file each value came from. `--diff FILE` is
    /// FILE layered last (`--config FILE --diff`).
    #[arg(long, value_name = "FILE", num_args = 0..=1)]
    diff: Option<Option<PathBuf>>,
}

/// Prints the effective configuration as TOML, or the changes table.
pub fn config(args: ConfigArgs) -> anyhow::Result<()> {
    let mut files = args.config.clone();
    if let Some(Some(path)) = &args.diff {
        files.config.push(path.clone());
    }
    let setup = files.layered()?;
    let text = match &args.diff {
        Some(_) => changes(&setup)?,
        None => setup.to_toml()?,
    };
    output::stdout(&text).context("stdout")
}

/// The table of what the setup changes from the built-in configuration.
fn changes(setup: &Layered) -> anyhow::Result<String> {
    let base = Config::default();
    match setup.layers() {
        [] => Ok(diff::table("the built-in configuration", &[])),
        [one] => {
            let rows = diff::changes(&base, setup.config(), &one.text)?;
            Ok(diff::table(&one.path.display().to_string(), &rows))
        }
        _ => {
            let rows = diff::layered_changes(&base, setup)?;
            Ok(diff::layered_table(&setup.describe(), &rows))
        }
    }
}
