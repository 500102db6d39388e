//! `sipnpuff generate`: a synthetic recording of a scripted user.

use std::io::Write;
use std::path::PathBuf;

use crate::cli::args::{ConfigArg, create, parse_volts};
use crate::sim::script::{demo_script, parse_sequences, random_session, sequences_script};
use crate::sim::sensor_model::{SignalGenerator, SignalParams, write_csv};

/// `generate`'s options.
#[derive(clap::Args, Debug)]
pub struct GenerateArgs {
    /// Output CSV file.
    #[arg(long)]
    out: PathBuf,
    /// TOML configuration (its thresholds shape the breaths and its
    /// library feeds the random user).
    #[command(flatten)]
    config: ConfigArg,
    /// Length of a random session, in seconds (exact; at most a week).
    #[arg(long, default_value_t = 60, value_parser = clap::value_parser!(u64).range(1..=604_800))]
    seconds: u64,
    /// Instead of a random session, the demo user: every kind of mode,
    /// save and go to a point, a finger end stop, the reach limit.
    #[arg(long, conflicts_with = "sequences")]
    demo: bool,
    /// Instead of a random session, enter these sequences in order, e.g.
    /// `--sequences "1,2,-1 1,2 2,1"` (codes: 1 short sip, 2 long sip,
    /// -1 short puff, -2 long puff).
    #[arg(long, allow_hyphen_values = true)]
    sequences: Option<String>,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Gaussian noise, standard deviation in volts.
    #[arg(long, default_value_t = 0.0, value_parser = parse_volts)]
    noise_volts: f64,
    /// 50 Hz hum amplitude in volts.
    #[arg(long, default_value_t = 0.0, value_parser = parse_volts)]
    hum_volts: f64,
    /// Neutral drift amplitude in volts (one-minute period).
    #[arg(long, default_value_t = 0.0, value_parser = parse_volts)]
    drift_volts: f64,
    /// A one-sample spike to a rail every this many ms (0 = none).
    #[arg(long, default_value_t = 0)]
    spike_every_ms: u64,
}

/// Writes the recording.
pub fn generate(args: GenerateArgs) -> anyhow::Result<()> {
    let config = args.config.load()?;
    let params = SignalParams::clean(config.core().detector(), args.seed)
        .with_noise(args.noise_volts)
        .with_hum(args.hum_volts)
        .with_drift(args.drift_volts)
        .with_spikes_every(args.spike_every_ms);
    let (script, length) = match args.sequences {
        None if args.demo => (demo_script(&config).0, usize::MAX),
        Some(text) => {
            let sequences = parse_sequences(&text).map_err(anyhow::Error::msg)?;
            (sequences_script(&config, &sequences), usize::MAX)
        }
        None => (
            random_session(&config, args.seconds, args.seed).0,
            usize::try_from(args.seconds * 1000)?,
        ),
    };
    let mut writer = create(&args.out)?;
    let n = write_csv(
        &mut writer,
        SignalGenerator::new(params, &script).take(length),
    )?;
    writer.flush()?;
    note!(
        "wrote {n} samples ({:.1} s) to {}",
        n as f64 / 1000.0,
        args.out.display()
    );
    Ok(())
}
