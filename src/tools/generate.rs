//! A synthetic recording written as the `tick,volts` CSV: a scripted
//! user on the sensor model (with noise, hum, drift and spikes as asked),
//! or a simulated person with known breathing (a breather) in ordinary
//! use or following the calibration protocol, with the truth beside it.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Context;
use serde::Serialize;

use crate::config::Config;
use crate::control::mode::Mode;
use crate::fit::protocol::Protocol;
use crate::sim::breather::{Breather, Session, practice_session, protocol_session};
use crate::sim::script::{
    demo_script, outputs_session, parse_sequences, random_session, sequences_script,
};
use crate::sim::sensor_model::{Crossings, SignalGenerator, SignalParams, write_csv};
use crate::tools::output_file::create;

/// Whose signal to write.
#[derive(Debug, Clone)]
pub enum Who {
    /// The configured user, scripted, on the configured sensor model.
    Scripted {
        /// What they breathe.
        script: Script,
        /// What disturbs the signal.
        disturbances: Disturbances,
    },
    /// A simulated person with known breathing: their own rest level,
    /// noise, drift and true crossings shape the signal.
    Breather {
        /// Who.
        breather: Breather,
        /// What they breathe.
        session: BreatherSession,
        /// Where to write the truth as JSON, if asked.
        truth: Option<PathBuf>,
    },
}

/// What a scripted user breathes.
#[derive(Debug, Clone)]
pub enum Script {
    /// Every kind of mode, save and go to a point, a finger end stop, the
    /// reach limit.
    Demo,
    /// Every entry of the configured library in turn, used.
    EachEntry,
    /// These sequences in order (`1,2,-1 1,2`: the action codes).
    Sequences(String),
    /// Random sequences from the library, this many seconds (exact).
    Random {
        /// The session's length, s.
        seconds: u64,
    },
}

/// What disturbs a scripted user's signal.
#[derive(Debug, Clone, Copy)]
pub struct Disturbances {
    /// Gaussian noise, standard deviation, V.
    pub noise_volts: f64,
    /// 50 Hz hum amplitude, V.
    pub hum_volts: f64,
    /// Neutral drift amplitude, V (one-minute period).
    pub drift_volts: f64,
    /// A one-sample spike to a rail every this many ms (0 = none).
    pub spike_every_ms: u64,
}

/// What a breather breathes.
#[derive(Debug, Clone)]
pub enum BreatherSession {
    /// The calibration protocol.
    Protocol(Protocol),
    /// Random sequences from the configured library, this many seconds.
    Practice {
        /// The session's length, s.
        seconds: u64,
    },
}

/// Writes the signal of `who`, seeded by `seed`, to `out` as the
/// `tick,volts` CSV (and a breather's truth, if asked); says (`say`)
/// what it wrote.
pub fn generate(
    config: &Config,
    who: &Who,
    seed: u64,
    out: &Path,
    say: &dyn Fn(&str),
) -> anyhow::Result<()> {
    let (script, disturbances) = match who {
        Who::Scripted {
            script,
            disturbances,
        } => (script, disturbances),
        Who::Breather {
            breather,
            session,
            truth,
        } => return generate_breather(config, breather, session, truth.as_deref(), seed, out, say),
    };
    let params = SignalParams::clean(config.core().detector(), seed)
        .with_noise(disturbances.noise_volts)
        .with_hum(disturbances.hum_volts)
        .with_drift(disturbances.drift_volts)
        .with_spikes_every(disturbances.spike_every_ms);
    let (script, length) = match script {
        Script::Demo => (demo_script(config).0, usize::MAX),
        Script::EachEntry => (outputs_session(config), usize::MAX),
        Script::Sequences(text) => {
            let sequences = parse_sequences(text).map_err(anyhow::Error::msg)?;
            (sequences_script(config, &sequences), usize::MAX)
        }
        Script::Random { seconds } => (
            random_session(config, *seconds, seed).0,
            usize::try_from(seconds * 1000)?,
        ),
    };
    write_signal(out, SignalGenerator::new(params, &script).take(length), say)
}

/// A breather's practice or protocol session, and its truth (its file
/// created first, so a bad path fails before any work).
fn generate_breather(
    config: &Config,
    breather: &Breather,
    session: &BreatherSession,
    truth: Option<&Path>,
    seed: u64,
    out: &Path,
    say: &dyn Fn(&str),
) -> anyhow::Result<()> {
    let truth = truth
        .map(|path| create(path).map(|writer| (path, writer)))
        .transpose()?;
    match session {
        BreatherSession::Protocol(protocol) => {
            let session = protocol_session(breather, protocol, seed);
            write_signal(out, session.signal(), say)?;
            if let Some((path, writer)) = truth {
                write_truth(path, writer, breather, seed, &session, Some(protocol), say)?;
            }
        }
        BreatherSession::Practice { seconds } => {
            let session = practice_session(breather, config.core().sequences(), *seconds, seed);
            write_signal(out, session.signal(), say)?;
            if let Some((path, writer)) = truth {
                write_truth(path, writer, breather, seed, &session, None, say)?;
            }
        }
    }
    Ok(())
}

/// Writes samples as the `tick,volts` CSV.
fn write_signal(
    out: &Path,
    samples: impl Iterator<Item = f64>,
    say: &dyn Fn(&str),
) -> anyhow::Result<()> {
    let mut writer = create(out)?;
    let n = write_csv(&mut writer, samples)?;
    writer.flush()?;
    say(&format!(
        "wrote {n} samples ({:.1} s) to {}",
        n as f64 / 1000.0,
        out.display()
    ));
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
    say: &dyn Fn(&str),
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
    say(&format!(
        "wrote the truth of {} breaths to {}",
        session.breaths.len(),
        path.display()
    ));
    Ok(())
}
