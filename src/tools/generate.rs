//! A synthetic recording written as the `tick,volts` CSV: a scripted
//! user on the sensor model (with noise, hum, drift and spikes as asked),
//! or a simulated person with known breathing (a breather) in ordinary
//! use or following the calibration protocol, with the truth beside it;
//! or a simulated IMU user's head motion as the IMU CSV
//! (`tick,ax,ay,az,gx,gy,gz`), with its truth.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Context;
use serde::Serialize;

use crate::config::Config;
use crate::control::Tick;
use crate::control::mode::Mode;
use crate::fit::protocol::Protocol;
use crate::sim::breather::{Breather, Session, practice_session, protocol_session};
use crate::sim::head_gesture::GestureName;
use crate::sim::imu_session::{
    self, Drive, ImuSession, TrueGesture, ordinary_session, use_session,
};
use crate::sim::imu_user::ImuUser;
use crate::sim::script::{
    demo_script, outputs_session, parse_sequences, random_session, sequences_script,
};
use crate::sim::sensor_model::{Crossings, SignalGenerator, SignalParams, write_csv};
use crate::tools::imu_csv::write_imu_csv;
use crate::tools::output_file::{create, write_whole};

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
    /// A simulated person wearing a head IMU: the output is the IMU CSV.
    ImuUser {
        /// Who (at the sample rate to write).
        user: ImuUser,
        /// What they do.
        session: ImuSessionKind,
        /// The gestures they make, in order.
        gestures: Vec<GestureName>,
        /// Where to write the truth as JSON, if asked.
        truth: Option<PathBuf>,
    },
}

/// What a simulated IMU user does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ImuSessionKind {
    /// The recording protocol: rest, 5 examples of each gesture, 60 s of
    /// ordinary movement.
    Protocol,
    /// Practice: each gesture this many times, shuffled, with rests and
    /// now and then ordinary movement between them.
    Practice {
        /// Examples of each gesture.
        per_gesture: u32,
    },
    /// Ordinary use, this many minutes: gestures now and then among
    /// long stretches of ordinary movement.
    Use {
        /// The session's length, min.
        minutes: u32,
    },
    /// Ordinary movement alone, this many minutes.
    Ordinary {
        /// The session's length, min.
        minutes: u32,
    },
    /// Driving the arm: each gesture, then the head pitched and held.
    Drive {
        /// The pitch, degrees (positive: chin down).
        tilt_deg: i32,
        /// How long it is held, ms.
        hold_ms: u32,
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
        Who::ImuUser {
            user,
            session,
            gestures,
            truth,
        } => return generate_imu(user, *session, gestures, truth.as_deref(), seed, out, say),
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

/// An IMU user's session as the IMU CSV, and its truth; each file
/// written whole or not at all.
fn generate_imu(
    user: &ImuUser,
    kind: ImuSessionKind,
    gestures: &[GestureName],
    truth: Option<&Path>,
    seed: u64,
    out: &Path,
    say: &dyn Fn(&str),
) -> anyhow::Result<()> {
    let session = match kind {
        ImuSessionKind::Protocol => imu_session::protocol_session(user, gestures, seed),
        ImuSessionKind::Practice { per_gesture } => {
            imu_session::practice_session(user, gestures, per_gesture, seed)
        }
        ImuSessionKind::Use { minutes } => use_session(user, gestures, minutes, seed),
        ImuSessionKind::Ordinary { minutes } => ordinary_session(user, minutes, seed),
        ImuSessionKind::Drive { tilt_deg, hold_ms } => {
            let drives: Vec<Drive> = gestures
                .iter()
                .map(|&gesture| Drive {
                    gesture,
                    pitch_deg: f64::from(tilt_deg),
                    hold_ms,
                })
                .collect();
            imu_session::drive_session(user, &drives, seed).0
        }
    };
    write_whole(out, |writer| {
        Ok(write_imu_csv(writer, session.channels, &session.samples)?)
    })?;
    let seconds = session.samples.last().map_or(0, |(tick, _)| *tick) as f64 / 1000.0;
    say(&format!(
        "wrote {} samples ({seconds:.1} s at {} Hz) to {}",
        session.samples.len(),
        user.rate_hz,
        out.display()
    ));
    if let Some(path) = truth {
        write_whole(path, |writer| {
            let truth = imu_truth(user, kind, gestures, seed, &session);
            serde_json::to_writer_pretty(&mut *writer, &truth)?;
            Ok(writeln!(writer)?)
        })?;
        say(&format!(
            "wrote the truth of {} gestures and {} stretch(es) of ordinary movement to {}",
            session.truth.len(),
            session.ordinary.len(),
            path.display()
        ));
    }
    Ok(())
}

/// `--truth`'s JSON for an IMU user: who, what was asked, and where each
/// gesture and stretch of ordinary movement truly lies.
#[derive(Serialize)]
pub struct ImuTruth<'a> {
    /// The user's true parameters.
    pub user: &'a ImuUser,
    /// The session asked for.
    pub session: ImuSessionKind,
    /// The gestures asked for, in order.
    pub asked: &'a [GestureName],
    /// The seed.
    pub seed: u64,
    /// The channels in the CSV (`ax,ay,az,gx,gy,gz`).
    pub channels: String,
    /// Samples in the CSV.
    pub samples: usize,
    /// The last sample's tick, ms.
    pub last_tick: Tick,
    /// Every gesture made: `name`, `example` (from 1), `start` and `end`
    /// ticks (its first move's start and its last move's end).
    pub gestures: &'a [TrueGesture],
    /// The stretches of ordinary movement, `[start, end)` ticks.
    pub ordinary: Vec<Stretch>,
    /// The gyro's constant bias this session, rad/s, x y z.
    pub gyro_bias: [f64; 3],
}

/// A stretch of ordinary movement, ticks.
#[derive(Serialize)]
pub struct Stretch {
    /// First tick.
    pub start: Tick,
    /// The tick after the last.
    pub end: Tick,
}

/// The truth of `session`.
pub fn imu_truth<'a>(
    user: &'a ImuUser,
    session: ImuSessionKind,
    asked: &'a [GestureName],
    seed: u64,
    made: &'a ImuSession,
) -> ImuTruth<'a> {
    ImuTruth {
        user,
        session,
        asked,
        seed,
        channels: made.channels.to_string(),
        samples: made.samples.len(),
        last_tick: made.samples.last().map_or(0, |(tick, _)| *tick),
        gestures: &made.truth,
        ordinary: made
            .ordinary
            .iter()
            .map(|&(start, end)| Stretch { start, end })
            .collect(),
        gyro_bias: made.gyro_bias,
    }
}
