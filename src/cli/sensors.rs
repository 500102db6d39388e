//! `sipnpuff sensors`: what sip-and-puff sensors this machine has, and
//! the `--sensor` line for each.

use crate::cli::output;
use crate::sensor::listing;

/// `sensors`' options.
#[derive(clap::Args, Debug)]
pub struct SensorsArgs {
    /// Print one JSON array instead of text.
    #[arg(long)]
    json: bool,
}

/// Lists input devices with axes or keys, IIO voltage channels and serial
/// ports.
pub fn sensors(args: SensorsArgs) -> anyhow::Result<()> {
    let found = listing::list();
    let text = if args.json {
        serde_json::to_string_pretty(&found)? + "\n"
    } else {
        listing::to_text(&found)
    };
    output::stdout(&text)?;
    Ok(())
}
