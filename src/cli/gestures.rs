//! `sipnpuff gestures`: a person's own head gestures from an IMU. `record`
//! makes a gesture set from a live session, guided
//! ([`crate::session::gesture_session::record_live`]), or from a
//! recording that follows the protocol
//! ([`crate::session::gestures::record_from`]); `check` says how well a
//! set separates its gestures and rejects ordinary movement
//! ([`crate::session::gestures::check_set`]).

use std::path::PathBuf;

use crate::cli::args::ConfigArg;
use crate::cli::display::DisplayArgs;
use crate::cli::output::{self, Terminal, invalid};
use crate::gestures::report;
use crate::sensor::SensorSpec;
use crate::session::gesture_session::{LiveRecord, record_live};
use crate::session::gestures::{check_set, record_from};

/// `gestures`' subcommands.
#[derive(clap::Subcommand, Debug)]
pub enum GesturesCommand {
    /// Make a gesture set: live, guided prompt by prompt in the terminal
    /// (`--sensor IMU`: hold still; each gesture 5 times, "nod — now";
    /// then a minute of ordinary movement that must trigger nothing), or
    /// from a recording that follows the protocol (`--from FILE.csv`: rest
    /// ≥ 3 s; for each gesture in the order given, 5 examples with 1.5–3 s
    /// of rest between them and ≥ 3 s between gestures; then ≥ 60 s of
    /// ordinary movement).
    Record(RecordArgs),
    /// Check a gesture set: leave-one-out accuracy per gesture, the
    /// confusion matrix, activations per hour on ordinary movement, the
    /// gestures too alike, and the thresholds' trade-off.
    Check(CheckArgs),
}

/// `gestures record`'s options.
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("source").required(true).args(["from", "sensor"])))]
pub struct RecordArgs {
    /// The recording: a CSV with the header `tick,ax,ay,az,gx,gy,gz`
    /// (any subset with the three rates; tick in ms; m/s² and rad/s).
    #[arg(long)]
    from: Option<PathBuf>,
    /// Record live from this IMU, guided: `evdev:name=SUBSTRING`,
    /// `evdev:/dev/input/eventN`, `iio:/sys/bus/iio/devices/iio:deviceN`,
    /// `serial:PATH[,baud=N]` (lines `ax,ay,az,gx,gy,gz`), or
    /// `synthetic[:NAME]` (a simulated person who follows the prompts:
    /// typical, slow_small, fast_large, tremor, wheelchair, drifting).
    #[arg(long, value_parser = SensorSpec::parse, conflicts_with = "from")]
    sensor: Option<SensorSpec>,
    /// With `--sensor`: where the session's recording is kept (default:
    /// the set's path with `.csv`); never over an existing file.
    #[arg(long, value_name = "FILE.csv", requires = "sensor")]
    recording: Option<PathBuf>,
    #[command(flatten)]
    config: ConfigArg,
    #[command(flatten)]
    display: DisplayArgs,
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
            let recorded = match (&args.from, &args.sensor) {
                (Some(from), _) => invalid(record_from(from, &args.gestures, &args.out))?,
                (None, Some(sensor)) => {
                    if args.display.tui {
                        return invalid(Err(anyhow::anyhow!(
                            "gestures record has no terminal view (--tui): its prompts are printed, and shown on the page"
                        )));
                    }
                    let config = args.config.load()?;
                    let recording = args
                        .recording
                        .clone()
                        .unwrap_or_else(|| args.out.with_extension("csv"));
                    let live = LiveRecord {
                        sensor,
                        names: &args.gestures,
                        out: &args.out,
                        recording: &recording,
                        config: &config,
                        display: args.display.choice(),
                    };
                    record_live(&live, &Terminal)?
                }
                (None, None) => anyhow::bail!("give --from FILE.csv or --sensor IMU"),
            };
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
