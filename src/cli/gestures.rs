//! `sipnpuff gestures`: a person's own head gestures from an IMU. `record
//! --from` makes a gesture set from a recording that follows the protocol
//! ([`crate::session::gestures::record_from`]); `check` says how well a
//! set separates its gestures and rejects ordinary movement
//! ([`crate::session::gestures::check_set`]).

use std::path::PathBuf;

use crate::cli::output::{self, invalid};
use crate::gestures::report;
use crate::session::gestures::{check_set, record_from};

/// `gestures`' subcommands.
#[derive(clap::Subcommand, Debug)]
pub enum GesturesCommand {
    /// Make a gesture set from a recording that follows the protocol: rest
    /// ≥ 3 s; for each gesture in the order given, 5 examples with 1.5–3 s
    /// of rest between them and ≥ 3 s between gestures; then ≥ 60 s of
    /// ordinary movement that must trigger nothing.
    Record(RecordArgs),
    /// Check a gesture set: leave-one-out accuracy per gesture, the
    /// confusion matrix, activations per hour on ordinary movement, the
    /// gestures too alike, and the thresholds' trade-off.
    Check(CheckArgs),
}

/// `gestures record`'s options.
#[derive(clap::Args, Debug)]
pub struct RecordArgs {
    /// The recording: a CSV with the header `tick,ax,ay,az,gx,gy,gz`
    /// (any subset with the three rates; tick in ms; m/s² and rad/s).
    #[arg(long)]
    from: PathBuf,
    /// The gestures, in the order recorded: `nod,shake,tilt_left`.
    #[arg(long, value_delimiter = ',', required = true)]
    gestures: Vec<String>,
    /// Where to write the set.
    #[arg(long)]
    out: PathBuf,
    /// Print the check as one JSON object instead of words.
    #[arg(long)]
    json: bool,
}

/// `gestures check`'s options.
#[derive(clap::Args, Debug)]
pub struct CheckArgs {
    /// The gesture set.
    set: PathBuf,
    /// Recordings of ordinary movement (CSV) to count false activations
    /// on; without any, the ordinary stretch of the set's own recording.
    recordings: Vec<PathBuf>,
    /// Print the check as one JSON object instead of words.
    #[arg(long)]
    json: bool,
}

/// Runs a `gestures` subcommand.
pub fn gestures(command: GesturesCommand) -> anyhow::Result<u8> {
    let (check, json) = match command {
        GesturesCommand::Record(args) => {
            let recorded = invalid(record_from(&args.from, &args.gestures, &args.out))?;
            let names: Vec<String> = recorded
                .recorded
                .set
                .gestures
                .iter()
                .map(|g| g.name.clone())
                .collect();
            for line in report::choices(&names, &recorded.recorded.choices) {
                note!("{line}");
            }
            note!("wrote the gesture set to {}", args.out.display());
            (recorded.check, args.json)
        }
        GesturesCommand::Check(args) => {
            (invalid(check_set(&args.set, &args.recordings))?, args.json)
        }
    };
    if json {
        output::stdout_line(&serde_json::to_string(&check)?)?;
    } else {
        output::stdout(&report::text(&check))?;
    }
    Ok(output::COMPLETED)
}
