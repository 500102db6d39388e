//! The telemetry thread's side of a recording: [`Recorder`] hands each
//! item to the writer thread's bounded queue without ever waiting (full:
//! dropped, counted, and marked in the stream), and at the end waits for
//! the writer to finish, but never longer than the writer makes progress.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, SyncSender, TrySendError};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use crate::config::Config;
use crate::control::event::TimedEvent;
use crate::control::motion::stream::ArmCommand;
use crate::control::tick::TickInput;
use crate::rt::recorder::{Lost, RecordingReport, RecordingSummary, SessionRecorder};
use crate::rt::report::RunReport;
use crate::tools::recording::writer::{Finish, Item, RecordOptions, Writer, one, problems};
use crate::tools::recording::{CONFIG, GESTURES, META};

/// Why a recording could not start.
#[derive(Debug)]
pub enum RecordError {
    /// The directory already holds a recording: never overwritten.
    Exists(PathBuf),
    /// The directory or `config.toml` could not be written.
    Io {
        /// What was being done.
        what: String,
        /// The system's error.
        error: std::io::Error,
    },
    /// The configuration does not print back to itself exactly (a bug):
    /// it could not be replayed faithfully.
    Config(String),
}

impl std::fmt::Display for RecordError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RecordError::Exists(dir) => write!(
                f,
                "{}: already holds a recording ({META}); choose another directory",
                dir.display()
            ),
            RecordError::Io { what, error } => write!(f, "{what}: {error}"),
            RecordError::Config(why) => write!(f, "cannot record the configuration: {why}"),
        }
    }
}

impl std::error::Error for RecordError {}

/// The telemetry side of a recording: never blocks.
pub struct Recorder {
    dir: PathBuf,
    options: RecordOptions,
    tx: SyncSender<Item>,
    pending: Lost,
    ring_lost: Lost,
    queue_dropped: Lost,
    /// Handed to the writer.
    sent: Lost,
    /// The writer's loop count: it goes up unless the writer is stuck in
    /// a call (a stalled disk).
    progress: Arc<AtomicU64>,
    thread: Option<JoinHandle<()>>,
}

impl Recorder {
    /// Creates `dir` (if needed), writes the configuration in effect to
    /// `config.toml` after checking it reads back to the identical
    /// `Config`, and starts the writer thread. Not RT-safe: before the run.
    pub fn create(
        dir: &Path,
        config: &Config,
        options: RecordOptions,
    ) -> Result<Recorder, RecordError> {
        let io = |what: String| move |error| RecordError::Io { what, error };
        make_dir(dir)?;
        let text = config_text(config)?;
        let path = dir.join(CONFIG);
        std::fs::write(&path, text).map_err(io(format!("cannot write {}", path.display())))?;
        if let (Some(_), Some(set)) = (config.core().gestures(), config.core().gesture_set_file()) {
            let copy = dir.join(GESTURES);
            std::fs::copy(set, &copy).map_err(io(format!(
                "cannot copy the gesture set {} to {}",
                set.display(),
                copy.display()
            )))?;
        }
        let (tx, rx) = mpsc::sync_channel(options.queue.max(1));
        let progress = Arc::new(AtomicU64::new(0));
        let both = config.core().has_breath_sensor() && config.core().gestures().is_some();
        let writer = Writer::new(dir, options, progress.clone(), both);
        let thread = thread::Builder::new()
            .name("recorder".into())
            .spawn(move || writer.run(&rx))
            .map_err(io("cannot start the recorder's writer thread".into()))?;
        Ok(Recorder {
            dir: dir.to_path_buf(),
            options,
            tx,
            pending: Lost::default(),
            ring_lost: Lost::default(),
            queue_dropped: Lost::default(),
            sent: Lost::default(),
            progress,
            thread: Some(thread),
        })
    }

    /// Hands `item` to the writer, or drops and counts it if the queue is
    /// full (a mark of what was lost goes ahead of the next item that
    /// fits). Never blocks.
    fn send(&mut self, item: Item) {
        if !self.pending.is_empty() {
            match self.tx.try_send(Item::Lost(self.pending)) {
                Ok(()) => self.pending = Lost::default(),
                Err(_) => return self.dropped(&item),
            }
        }
        let one = one(&item);
        match self.tx.try_send(item) {
            Ok(()) => self.sent = self.sent.plus(one),
            Err(TrySendError::Full(item) | TrySendError::Disconnected(item)) => {
                self.dropped(&item);
            }
        }
    }

    fn dropped(&mut self, item: &Item) {
        let lost = one(item);
        self.queue_dropped = self.queue_dropped.plus(lost);
        self.pending = self.pending.plus(lost);
    }

    /// Ends the recording after the run: the writer ends every stream,
    /// writes `report.json` (this report, with the recording's summary)
    /// and the final `meta.json`. Returns the summary, also set in
    /// `report.recording`. If the writer makes no progress for
    /// `stall_timeout` (a stalled disk), it is left behind and the summary
    /// says the recording failed; this never waits longer.
    pub fn finish(mut self, report: &mut RunReport) -> RecordingReport {
        let (reply, answer) = mpsc::channel();
        let mut item = Item::Finish(Box::new(Finish {
            report: report.clone(),
            pending: self.pending,
            ring_lost: self.ring_lost,
            queue_dropped: self.queue_dropped,
            reply,
        }));
        let progress = self.progress.clone();
        let mut watch = Watch::new(&progress, self.options.stall_timeout);
        let summary = loop {
            match self.tx.try_send(item) {
                Ok(()) => break self.answer(&answer, &mut watch),
                Err(TrySendError::Full(back)) if !watch.stalled() => {
                    item = back;
                    thread::sleep(Duration::from_millis(10));
                }
                Err(TrySendError::Full(_)) => break self.failed(Stop::Stalled),
                Err(TrySendError::Disconnected(_)) => break self.failed(Stop::Died),
            }
        };
        report.recording = Some(summary.clone());
        summary
    }

    /// The writer's summary once it has ended the recording.
    fn answer(
        &mut self,
        answer: &Receiver<RecordingReport>,
        watch: &mut Watch<'_>,
    ) -> RecordingReport {
        loop {
            match answer.recv_timeout(Duration::from_millis(20)) {
                Ok(summary) => {
                    if let Some(thread) = self.thread.take() {
                        let _ = thread.join();
                    }
                    return summary;
                }
                Err(RecvTimeoutError::Timeout) if !watch.stalled() => {}
                Err(RecvTimeoutError::Timeout) => return self.failed(Stop::Stalled),
                Err(RecvTimeoutError::Disconnected) => return self.failed(Stop::Died),
            }
        }
    }

    /// The summary of a recording whose writer never finished: nothing
    /// in it can be counted on (its files have no end markers).
    fn failed(&self, stop: Stop) -> RecordingReport {
        let error = match stop {
            Stop::Stalled => format!(
                "the recorder's writer made no progress for {:.1} s (a stalled disk?): {} is unfinished",
                self.options.stall_timeout.as_secs_f64(),
                self.dir.display()
            ),
            Stop::Died => format!(
                "the recorder's writer stopped unexpectedly: {} is unfinished",
                self.dir.display()
            ),
        };
        let mut problems = problems(
            self.ring_lost,
            self.queue_dropped,
            None,
            self.options.max_bytes,
        );
        problems.push(error.clone());
        RecordingReport {
            dir: self.dir.display().to_string(),
            summary: RecordingSummary {
                max_bytes: self.options.max_bytes,
                lost: self.ring_lost.plus(self.queue_dropped).plus(self.sent),
                problems,
                ..RecordingSummary::default()
            },
            error: Some(error),
        }
    }
}

impl SessionRecorder for Recorder {
    fn start(&mut self, sensor: &str, arm: &str) {
        self.send(Item::Start {
            sensor: sensor.into(),
            arm: arm.into(),
        });
    }

    fn input(&mut self, input: &TickInput) {
        self.send(Item::Input(*input));
    }

    fn command(&mut self, command: &ArmCommand) {
        self.send(Item::Command(*command));
    }

    fn event(&mut self, event: &TimedEvent) {
        self.send(Item::Event(*event));
    }

    fn lost(&mut self, lost: Lost) {
        self.ring_lost = self.ring_lost.plus(lost);
        self.pending = self.pending.plus(lost);
    }
}

/// Checks, before a run, that `dir` can hold a new recording: it can be
/// created, is writable, and holds no recording already (never
/// overwritten). What the check created is removed again: a run refused
/// later (a sensor that is not there) leaves no empty folder behind.
pub fn check_dir(dir: &Path) -> Result<(), RecordError> {
    let mut created = Vec::new();
    let mut missing = Some(dir);
    while let Some(d) = missing.filter(|d| !d.as_os_str().is_empty() && !d.exists()) {
        created.push(d.to_path_buf());
        missing = d.parent();
    }
    let checked = make_dir(dir);
    for d in created {
        // Empty but for nothing the check left: removal fails otherwise.
        let _ = std::fs::remove_dir(d);
    }
    checked
}

/// Creates `dir` if missing and checks it is writable and holds no
/// recording.
fn make_dir(dir: &Path) -> Result<(), RecordError> {
    let io = |what: String| move |error| RecordError::Io { what, error };
    std::fs::create_dir_all(dir).map_err(io(format!("cannot create {}", dir.display())))?;
    if dir.join(META).exists() {
        return Err(RecordError::Exists(dir.to_path_buf()));
    }
    let probe = dir.join(format!(".sipnpuff-write-test-{}", std::process::id()));
    std::fs::write(&probe, b"").map_err(io(format!("cannot write into {}", dir.display())))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// How a writer failed to finish.
#[derive(Debug, Clone, Copy)]
enum Stop {
    /// No progress for the stall timeout.
    Stalled,
    /// Its thread ended without answering (it panicked).
    Died,
}

/// The configuration as TOML, checked to read back to the identical
/// `Config` (equal, and equal in every bit: `Debug` shows `-0.0`).
fn config_text(config: &Config) -> Result<String, RecordError> {
    let text = config
        .to_toml()
        .map_err(|e| RecordError::Config(e.to_string()))?;
    // A person's gestures are loaded from their set, which the file names.
    let loaded = |back: Config| match config.core().gestures() {
        Some(setup) if config.core().has_breath_sensor() => back.for_breath_and_imu(setup.clone()),
        Some(setup) => back.for_imu(setup.clone()),
        None => back,
    };
    match Config::from_toml_str(&text).map(loaded) {
        Ok(back) if back == *config && format!("{back:?}") == format!("{config:?}") => Ok(text),
        Ok(_) => Err(RecordError::Config(
            "it does not read back to the same configuration".into(),
        )),
        Err(e) => Err(RecordError::Config(format!("it does not read back: {e}"))),
    }
}

/// Whether a thread has made no progress for a while.
struct Watch<'a> {
    progress: &'a AtomicU64,
    seen: u64,
    since: Instant,
    timeout: Duration,
}

impl<'a> Watch<'a> {
    fn new(progress: &'a AtomicU64, timeout: Duration) -> Self {
        Watch {
            progress,
            seen: progress.load(Ordering::Relaxed),
            since: Instant::now(),
            timeout,
        }
    }

    fn stalled(&mut self) -> bool {
        let now = self.progress.load(Ordering::Relaxed);
        if now != self.seen {
            self.seen = now;
            self.since = Instant::now();
        }
        self.since.elapsed() >= self.timeout
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::arm::sim::SimArm;
    use crate::control::sample::Sample;
    use crate::rt::threads::{LoopSettings, RunOptions, run};
    use crate::sim::synthetic_sensor::SyntheticSensor;
    use crate::tools::recording::format::samples::{SampleDecoder, SampleItem};
    use crate::tools::recording::meta::Meta;
    use crate::tools::recording::{COMMANDS, SAMPLES};
    use std::fs::File;

    fn scratch(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("sipnpuff-writer-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }

    /// A real report of a very short run, to finish recordings with.
    fn report() -> RunReport {
        let config = Config::default();
        let settings = LoopSettings::plain(0.01);
        let sensor = SyntheticSensor::built_in_user(&config);
        let arm = Box::new(SimArm::new(config.core()));
        run(config.core(), RunOptions::new(sensor, arm, settings)).unwrap()
    }

    #[test]
    fn the_configuration_reads_back_identically_and_is_never_overwritten() {
        let config = Config::from_toml_str(
            "[detector]\nneutral_volts = 2.5000000000000004\nhysteresis_volts = 0.30000000000000004\n[arm]\nhome_rotation_vector_rad = [-0.0, 0.0, 0.1]\n",
        )
        .unwrap();
        let text = config_text(&config).unwrap();
        assert!(
            text.contains("neutral_volts = 2.5000000000000004"),
            "{text}"
        );
        assert!(text.contains("[-0.0, 0.0, 0.1]"), "{text}");
        let dir = scratch("exists");
        let recorder = Recorder::create(&dir, &config, RecordOptions::default()).unwrap();
        let mut report = report();
        assert!(recorder.finish(&mut report).summary.complete);
        assert_eq!(
            std::fs::read_to_string(dir.join(CONFIG)).unwrap(),
            text,
            "config.toml"
        );
        let again = Recorder::create(&dir, &config, RecordOptions::default());
        assert!(matches!(again, Err(RecordError::Exists(_))));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Noisy samples past a 2 kB cap, in three batches: what is written
    /// ends cleanly and decodes to exactly the ticks counted as written;
    /// written and not written add up to what was given.
    #[test]
    fn the_cap_stops_recording_cleanly_and_counts_the_rest() {
        let dir = scratch("cap");
        let options = RecordOptions {
            max_bytes: 2000,
            ..RecordOptions::default()
        };
        let mut recorder = Recorder::create(&dir, &Config::default(), options).unwrap();
        recorder.start("test", "test");
        for batch in 0..3u64 {
            for t in batch * 100..(batch + 1) * 100 {
                recorder.input(&TickInput {
                    tick: t,
                    sample: Sample::Volts(2.5 + t as f64 * 1e-3),
                    stop: false,
                    ..TickInput::default()
                });
            }
            // The writer commits between batches (every 200 ms).
            thread::sleep(Duration::from_millis(300));
        }
        let mut report = report();
        let recording = recorder.finish(&mut report);
        assert!(recording.error.is_none(), "{recording:?}");
        let summary = recording.summary;
        assert!(!summary.complete);
        assert_eq!(summary.ticks + summary.lost.ticks, 300, "{summary:?}");
        assert!(summary.bytes <= 2000, "{summary:?}");
        assert!(
            summary.problems[0].contains("size cap of 0.002 MB"),
            "{summary:?}"
        );
        let file = File::open(dir.join(SAMPLES)).unwrap();
        assert_eq!(
            file.metadata().unwrap().len() + std::fs::metadata(dir.join(COMMANDS)).unwrap().len(),
            summary.bytes
        );
        let mut decoder = SampleDecoder::new(std::io::BufReader::new(file)).unwrap();
        let mut ticks = 0;
        while let Some(item) = decoder.next_item().unwrap() {
            assert_eq!(
                item,
                SampleItem::Input(TickInput::volts(ticks, 2.5 + ticks as f64 * 1e-3))
            );
            ticks += 1;
        }
        assert_eq!(ticks, summary.ticks);
        let meta: Meta =
            serde_json::from_str(&std::fs::read_to_string(dir.join(META)).unwrap()).unwrap();
        assert_eq!(
            (meta.summary.ticks, meta.summary.lost, meta.summary.complete),
            (summary.ticks, summary.lost, false)
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
