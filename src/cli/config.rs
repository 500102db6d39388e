//! `sipnpuff config`: check a configuration and print it, complete.

use crate::cli::args::ConfigArg;

/// `config`'s options.
#[derive(clap::Args, Debug)]
pub struct ConfigArgs {
    #[command(flatten)]
    config: ConfigArg,
}

/// Prints the effective configuration as TOML.
pub fn config(args: ConfigArgs) -> anyhow::Result<()> {
    print!("{}", args.config.load()?.to_toml()?);
    Ok(())
}
