//! `sipnpuff generate`: a synthetic recording of a scripted user, or of a
//! simulated person with known breathing (a breather) in ordinary use or
//! following the calibration protocol, with the truth beside it.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Context;
use serde::Serialize;

use crate::cli::args::{ConfigArg, create, parse_volts};
use crate::config::Config;
use crate::control::mode::Mode;
use crate::fit::protocol::{DEFAULT_COUNT, DEFAULT_HOLDS, Protocol};
use crate::sim::breather::{Breather, Session, practice_session, protocol_session};
use crate::sim::script::{
    demo_script, outputs_session, parse_sequences, random_session, sequences_script,
};
use crate::sim::sensor_model::{Crossings, SignalGenerator, SignalParams, write_csv};

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
    /// Instead of a random session, every entry of the configured
    /// library in turn, used: each mode held a puff and a sip, each key,
    /// click and home event fired, a drag around a pointer move (e.g.
    /// with `--config fixtures/computer-and-home.toml`, to drive
    /// `run --output`).
    #[arg(long, conflicts_with_all = ["sequences", "demo"])]
    each_entry: bool,
    /// Instead of a random session, enter these sequences in order, e.g.
    /// `--sequences "1,2,-1 1,2 2,1"` (codes: 1 short sip, 2 long sip,
    /// -1 short puff, -2 long puff).
    #[arg(long, allow_hyphen_values = true)]
    sequences: Option<String>,
    /// Instead of the configured user, a simulated person with known
    /// breathing: typical, weak, short_capacity, slow, tremulous or
    /// asymmetric. Without `--protocol`, `--seconds` of random sequences
    /// from the configured library. Their own rest level, noise, drift and
    /// true crossings shape the signal, not the configuration's.
    #[arg(
        long,
        value_name = "NAME",
        value_parser = parse_breather,
        conflicts_with_all = ["demo", "sequences", "noise_volts", "hum_volts", "drift_volts", "spike_every_ms"]
    )]
    breather: Option<Breather>,
    /// With `--breather`: the calibration session instead (rest, then
    /// blocks of short puffs, long puffs, short sips and long sips).
    #[arg(long, requires = "breather", conflicts_with = "seconds")]
    protocol: bool,
    /// With `--protocol`: breaths per block.
    #[arg(long, default_value_t = DEFAULT_COUNT, requires = "protocol", value_parser = clap::value_parser!(u32).range(1..=1000))]
    count: u32,
    /// With `--protocol`: then 3 longest comfortable puffs and 3 sips.
    #[arg(long, requires = "protocol")]
    holds: bool,
    /// With `--breather`: also write the truth as JSON (the breather's
    /// parameters, the true crossings, and each breath's kind, first tick
    /// and length in ms).
    #[arg(long, value_name = "FILE.json", requires = "breather")]
    truth: Option<PathBuf>,
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

/// A built-in breather's name; the error lists them all.
fn parse_breather(name: &str) -> Result<Breather, String> {
    Breather::named(name).ok_or_else(|| {
        let names: Vec<&str> = Breather::all().iter().map(|b| b.name).collect();
        format!("no breather {name:?}: one of {}", names.join(", "))
    })
}

/// Writes the recording.
pub fn generate(args: GenerateArgs) -> anyhow::Result<()> {
    let config = args.config.load()?;
    if let Some(breather) = args.breather {
        return generate_breather(&args, &config, &breather);
    }
    let params = SignalParams::clean(config.core().detector(), args.seed)
        .with_noise(args.noise_volts)
        .with_hum(args.hum_volts)
        .with_drift(args.drift_volts)
        .with_spikes_every(args.spike_every_ms);
    let (script, length) = match &args.sequences {
        None if args.demo => (demo_script(&config).0, usize::MAX),
        None if args.each_entry => (outputs_session(&config), usize::MAX),
        Some(text) => {
            let sequences = parse_sequences(text).map_err(anyhow::Error::msg)?;
            (sequences_script(&config, &sequences), usize::MAX)
        }
        None => (
            random_session(&config, args.seconds, args.seed).0,
            usize::try_from(args.seconds * 1000)?,
        ),
    };
    write_signal(
        &args.out,
        SignalGenerator::new(params, &script).take(length),
    )
}

/// `--breather`: a practice or protocol session, and its truth (its file
/// created first, so a bad path fails before any work).
fn generate_breather(
    args: &GenerateArgs,
    config: &Config,
    breather: &Breather,
) -> anyhow::Result<()> {
    let truth = args
        .truth
        .as_deref()
        .map(|path| create(path).map(|writer| (path, writer)))
        .transpose()?;
    if args.protocol {
        let holds = if args.holds { DEFAULT_HOLDS } else { 0 };
        let protocol = Protocol::new(args.count, holds);
        let session = protocol_session(breather, &protocol, args.seed);
        write_signal(&args.out, session.signal())?;
        if let Some((path, writer)) = truth {
            write_truth(path, writer, breather, args.seed, &session, Some(&protocol))?;
        }
    } else {
        let session =
            practice_session(breather, config.core().sequences(), args.seconds, args.seed);
        write_signal(&args.out, session.signal())?;
        if let Some((path, writer)) = truth {
            write_truth(path, writer, breather, args.seed, &session, None)?;
        }
    }
    Ok(())
}

/// Writes samples as the `tick,volts` CSV.
fn write_signal(out: &Path, samples: impl Iterator<Item = f64>) -> anyhow::Result<()> {
    let mut writer = create(out)?;
    let n = write_csv(&mut writer, samples)?;
    writer.flush()?;
    note!(
        "wrote {n} samples ({:.1} s) to {}",
        n as f64 / 1000.0,
        out.display()
    );
    Ok(())
}

/// `--truth`'s JSON: who breathed, where each breath truly lies.
#[derive(Serialize)]
struct Truth<'a, B> {
    /// The breather's true parameters.
    breather: &'a Breather,
    /// The true start and end levels, volts from the rest level.
    crossings: Crossings,
    seed: u64,
    /// Samples in the CSV.
    samples: u64,
    /// The protocol followed (a calibration session only).
    #[serde(skip_serializing_if = "Option::is_none")]
    protocol: Option<&'a Protocol>,
    /// Library entries entered, in order (ordinary use only).
    #[serde(skip_serializing_if = "<[Mode]>::is_empty")]
    modes: &'a [Mode],
    /// Every breath: `kind` ("short puff", "longest comfortable sip"),
    /// `start_tick`, `ms`.
    breaths: &'a [B],
}

fn write_truth<B: Serialize>(
    path: &Path,
    mut writer: impl Write,
    breather: &Breather,
    seed: u64,
    session: &Session<B>,
    protocol: Option<&Protocol>,
) -> anyhow::Result<()> {
    let truth = Truth {
        breather,
        crossings: breather.crossings(),
        seed,
        samples: session.ticks,
        protocol,
        modes: &session.modes,
        breaths: &session.breaths,
    };
    serde_json::to_writer_pretty(&mut writer, &truth)
        .map_err(std::io::Error::from)
        .and_then(|()| writeln!(writer))
        .and_then(|()| writer.flush())
        .with_context(|| format!("cannot write {}", path.display()))?;
    note!(
        "wrote the truth of {} breaths to {}",
        session.breaths.len(),
        path.display()
    );
    Ok(())
}
