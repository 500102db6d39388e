//! `sipnpuff config`: check a configuration and print it, complete.

use anyhow::Context;

use crate::cli::args::ConfigArg;
use crate::cli::output;

/// `config`'s options.
#[derive(clap::Args, Debug)]
pub struct ConfigArgs {
    #[command(flatten)]
    config: ConfigArg,
}

/// Prints the effective configuration as TOML.
pub fn config(args: ConfigArgs) -> anyhow::Result<()> {
    let text = args.config.load()?.to_toml()?;
    output::stdout(&text).context("stdout")
}
