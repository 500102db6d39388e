//! Replays from and to files: the input opened (a CSV of samples, or a
//! recording with the configuration chosen for it), the events' and the
//! trace's files created before any work, the replay timed; an error
//! names the file it is about.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;
use std::time::Instant;

use crate::config::Config;
use crate::control::core_config::CoreConfig;
use crate::sensor::csv::CsvSignal;
use crate::tools::csv_replay;
use crate::tools::imu_csv::read_imu_csv;
use crate::tools::imu_replay;
use crate::tools::output_file::create;
use crate::tools::recording::GESTURES;
use crate::tools::recording::read::Recording;
use crate::tools::recording::recording_replay::{self, ReplayVerdict};
use crate::tools::replay::{ReplayError, ReplaySummary};

/// Where a replay writes.
#[derive(Debug, Clone, Copy)]
pub struct ReplayTo<'a> {
    /// The events' file (`None`: the standard output given).
    pub events: Option<&'a Path>,
    /// The per-tick trace's file, if asked for.
    pub trace: Option<&'a Path>,
}

/// A CSV's replay.
#[derive(Debug, Clone, Copy)]
pub struct CsvReplayed {
    /// What it did.
    pub summary: ReplaySummary,
    /// How long it took, s.
    pub seconds: f64,
}

/// A recording's replay.
#[derive(Debug)]
pub struct RecordingReplayed {
    /// The recording replayed.
    pub recording: Recording,
    /// What it did, against what was recorded.
    pub verdict: ReplayVerdict,
    /// How long it took, s.
    pub seconds: f64,
}

/// Replays the CSV at `path` through `config` ([`csv_replay::replay`]),
/// writing where `to` says (the events to `stdout` if to no file).
pub fn replay_csv(
    config: &CoreConfig,
    path: &Path,
    to: ReplayTo,
    stdout: impl Write,
) -> anyhow::Result<CsvReplayed> {
    let mut input = CsvSignal::open(path)?;
    let mut opened = Opened::open(to, stdout)?;
    let started = Instant::now();
    let (out, trace) = opened.writers();
    let result = csv_replay::replay(config, &mut input, out, trace);
    timed(path, result, started)
}

/// Replays the IMU recording at `path` through `config` (its gestures
/// loaded; [`imu_replay::replay`]), writing where `to` says.
pub fn replay_imu_csv(
    config: &CoreConfig,
    path: &Path,
    to: ReplayTo,
    stdout: impl Write,
) -> anyhow::Result<CsvReplayed> {
    let recording = read_imu_csv(path).map_err(|e| anyhow::anyhow!("{e}"))?;
    crate::gestures::setup::check_channels(config, &path.display().to_string(), recording.channels)
        .map_err(anyhow::Error::msg)?;
    let mut opened = Opened::open(to, stdout)?;
    let started = Instant::now();
    let (out, trace) = opened.writers();
    let result = imu_replay::replay(config, &recording, out, trace);
    timed(path, result, started)
}

/// A CSV's replay that began at `started`: what it did and how long it
/// took, or its error naming the file.
fn timed(
    path: &Path,
    result: Result<ReplaySummary, ReplayError>,
    started: Instant,
) -> anyhow::Result<CsvReplayed> {
    let seconds = started.elapsed().as_secs_f64();
    match result {
        Ok(summary) => Ok(CsvReplayed { summary, seconds }),
        Err(ReplayError::Write(e)) => Err(cannot_write(path, e)),
        Err(e) => Err(anyhow::Error::new(e).context(path.display().to_string())),
    }
}

/// Replays the recording in `dir` through the configuration `config`
/// chooses for it (given the recorded one), compared with what was
/// recorded if `compare` ([`recording_replay::replay`]), writing where
/// `to` says (the events to `stdout` if to no file).
pub fn replay_recording(
    dir: &Path,
    config: impl FnOnce(&Config) -> anyhow::Result<Config>,
    compare: bool,
    to: ReplayTo,
    stdout: impl Write,
) -> anyhow::Result<RecordingReplayed> {
    let recording = Recording::open(dir)?;
    let config = with_recorded_gestures(&recording, config(&recording.config)?)?;
    let mut opened = Opened::open(to, stdout)?;
    let started = Instant::now();
    let (out, trace) = opened.writers();
    let result = recording_replay::replay(&recording, &config, compare, out, trace);
    let seconds = started.elapsed().as_secs_f64();
    let verdict = match result {
        Ok(verdict) => verdict,
        Err(ReplayError::Write(e)) => return Err(cannot_write(dir, e)),
        Err(e) => return Err(e.into()),
    };
    Ok(RecordingReplayed {
        recording,
        verdict,
        seconds,
    })
}

/// `config` with the person's gestures loaded, if it names a set: the
/// recording's copy of the set the run used when `config` names the same
/// set as the recorded configuration, else the set `config` names; the
/// breath sensor kept when the run read one beside the IMU.
fn with_recorded_gestures(recording: &Recording, config: Config) -> anyhow::Result<Config> {
    let Some(path) = config.core().gesture_set_file() else {
        return Ok(config);
    };
    let copy = recording.path(GESTURES);
    let file = if recording.config.core().gesture_set_file() == Some(path) && copy.exists() {
        copy
    } else {
        path.to_path_buf()
    };
    let setup = crate::gestures::setup::load(config.core(), &file).map_err(anyhow::Error::msg)?;
    Ok(if recording.meta.breath_and_imu {
        config.for_breath_and_imu(setup)
    } else {
        config.for_imu(setup)
    })
}

/// The replay of `input` could not write its output: the `io::Error`
/// stays in the chain (a closed stdout: exit status 141).
fn cannot_write(input: &Path, e: std::io::Error) -> anyhow::Error {
    anyhow::Error::new(e).context(format!("{}: cannot write the output", input.display()))
}

/// Where a replay writes, open: the events' writer (a file, or stdout
/// buffered) and the trace's file, created before any work.
struct Opened<'a> {
    events: Box<dyn Write + 'a>,
    trace: Option<BufWriter<File>>,
}

impl<'a> Opened<'a> {
    fn open(to: ReplayTo, stdout: impl Write + 'a) -> anyhow::Result<Opened<'a>> {
        let events: Box<dyn Write + 'a> = match to.events {
            Some(path) => Box::new(create(path)?),
            None => Box::new(BufWriter::new(stdout)),
        };
        let trace = to.trace.map(create).transpose()?;
        Ok(Opened { events, trace })
    }

    /// The events' writer and the trace's, if asked for.
    fn writers(&mut self) -> (&mut dyn Write, Option<&mut dyn Write>) {
        let trace = self.trace.as_mut().map(|t| t as &mut dyn Write);
        (&mut self.events, trace)
    }
}
