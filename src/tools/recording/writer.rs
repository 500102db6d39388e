//! The writer thread of a recording: it takes items from the bounded
//! queue the telemetry thread fills (see [`recorder`](super::recorder)),
//! encodes them and writes the files, committing every 200 ms. A slow or
//! stalled disk costs recorded items, never a tick or an event on stdout;
//! the bytes are capped (`--record-max-mb`), after which recording stops
//! and the run goes on.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

use crate::control::Tick;
use crate::control::event::TimedEvent;
use crate::control::motion::stream::ArmCommand;
use crate::control::tick::TickInput;
use crate::rt::recorder::{Lost, RecordingReport, RecordingSummary};
use crate::rt::report::RunReport;
use crate::tools::recording::format::commands::CommandEncoder;
use crate::tools::recording::format::samples::SampleEncoder;
use crate::tools::recording::format::{END_BYTES, Stream, StreamFile};
use crate::tools::recording::meta::Meta;
use crate::tools::recording::{COMMANDS, EVENTS, META, REPORT, SAMPLES};

/// Room kept under the cap for what must be written at the end: the runs
/// the encoder holds and the end markers.
const RESERVE_BYTES: u64 = 64;
/// The smallest cap: the headers and the end.
pub const MIN_BYTES: u64 = 1000;
/// The writer commits what it encoded this often (or sooner when a
/// buffer grows past [`CHUNK_BYTES`]): a killed run loses at most this
/// much.
const COMMIT_EVERY: Duration = Duration::from_millis(200);
const CHUNK_BYTES: usize = 64 * 1024;

/// How to record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RecordOptions {
    /// Cap on the bytes of samples, commands and events.
    pub max_bytes: u64,
    /// Items the queue to the writer holds: 32 768 is about 30 s of ticks,
    /// commands and events, room for a disk that pauses.
    pub queue: usize,
    /// At the end, how long the writer may make no progress before the
    /// recording is given up as stalled.
    pub stall_timeout: Duration,
}

impl Default for RecordOptions {
    fn default() -> Self {
        RecordOptions {
            max_bytes: 200_000_000,
            queue: 32_768,
            stall_timeout: Duration::from_secs(5),
        }
    }
}

/// What goes through the queue.
pub(super) enum Item {
    Start { sensor: String, arm: String },
    Input(TickInput),
    Command(ArmCommand),
    Event(TimedEvent),
    Lost(Lost),
    Finish(Box<Finish>),
}

/// The end of the run, and what the telemetry side counted.
pub(super) struct Finish {
    pub(super) report: RunReport,
    /// Lost items not yet marked in the streams.
    pub(super) pending: Lost,
    /// Lost in the control thread's rings.
    pub(super) ring_lost: Lost,
    /// Dropped because the queue was full.
    pub(super) queue_dropped: Lost,
    pub(super) reply: mpsc::Sender<RecordingReport>,
}

/// One item of the kind of `item`, as a count.
pub(super) fn one(item: &Item) -> Lost {
    match item {
        Item::Input(_) => Lost {
            ticks: 1,
            ..Lost::default()
        },
        Item::Command(_) => Lost {
            arm_commands: 1,
            ..Lost::default()
        },
        Item::Event(_) => Lost {
            events: 1,
            ..Lost::default()
        },
        Item::Start { .. } | Item::Lost(_) | Item::Finish(_) => Lost::default(),
    }
}
/// Why a recording is incomplete, in words.
pub(super) fn problems(
    ring: Lost,
    queue: Lost,
    capped: Option<(Tick, Lost)>,
    max: u64,
) -> Vec<String> {
    let counts = |l: Lost| {
        format!(
            "{} ticks, {} arm commands, {} events",
            l.ticks, l.arm_commands, l.events
        )
    };
    let mut out = Vec::new();
    if !ring.is_empty() {
        out.push(format!(
            "the control thread's rings were full (the telemetry thread fell behind): {} lost",
            counts(ring)
        ));
    }
    if !queue.is_empty() {
        out.push(format!(
            "the recorder's queue was full (the disk did not keep up): {} dropped",
            counts(queue)
        ));
    }
    if let Some((tick, lost)) = capped {
        out.push(format!(
            "the size cap of {} MB was reached at tick {tick}: {} not written",
            max as f64 / 1e6,
            counts(lost)
        ));
    }
    out
}

/// What the writer has committed to the files (or holds to commit).
#[derive(Debug, Clone, Copy, Default)]
struct Counts {
    ticks: u64,
    arm_commands: u64,
    events: u64,
    first_tick: Option<Tick>,
    last_tick: Option<Tick>,
    stop_tick: Option<Tick>,
}

/// The writer thread's state.
pub(super) struct Writer {
    dir: PathBuf,
    options: RecordOptions,
    progress: Arc<AtomicU64>,
    meta: Meta,
    samples: Option<StreamFile<File>>,
    commands: Option<StreamFile<File>>,
    events: Option<File>,
    sample_enc: SampleEncoder,
    command_enc: CommandEncoder,
    sample_ops: Vec<u8>,
    command_ops: Vec<u8>,
    event_lines: Vec<u8>,
    /// Everything given to the encoders.
    given: Counts,
    /// Everything written.
    written: Counts,
    event_bytes: u64,
    /// Bytes of the binary streams once ended.
    ended_bytes: u64,
    /// Recording stopped at the cap: the tick, and what was not written.
    capped: Option<(Tick, Lost)>,
    /// Recording stopped on a write error.
    error: Option<String>,
    error_lost: Lost,
    last_commit: Instant,
}

impl Writer {
    pub(super) fn new(
        dir: &Path,
        options: RecordOptions,
        progress: Arc<AtomicU64>,
        breath_and_imu: bool,
    ) -> Writer {
        Writer {
            dir: dir.to_path_buf(),
            options,
            progress,
            meta: Meta {
                breath_and_imu,
                ..Meta::starting("", "", options.max_bytes)
            },
            samples: None,
            commands: None,
            events: None,
            sample_enc: SampleEncoder::default(),
            command_enc: CommandEncoder::default(),
            sample_ops: Vec::with_capacity(CHUNK_BYTES),
            command_ops: Vec::new(),
            event_lines: Vec::new(),
            given: Counts::default(),
            written: Counts::default(),
            event_bytes: 0,
            ended_bytes: 0,
            capped: None,
            error: None,
            error_lost: Lost::default(),
            last_commit: Instant::now(),
        }
    }

    /// Recording, as opposed to stopped at the cap or by an error.
    fn recording(&self) -> bool {
        self.capped.is_none() && self.error.is_none()
    }

    fn fail(&mut self, file: &str, e: &std::io::Error) {
        if self.error.is_none() {
            self.error = Some(format!(
                "cannot write {}: {e}",
                self.dir.join(file).display()
            ));
        }
    }

    fn open(&mut self) {
        let open = |name: &str| File::create(self.dir.join(name));
        match open(SAMPLES).and_then(|f| StreamFile::start(f, Stream::Samples)) {
            Ok(f) => self.samples = Some(f),
            Err(e) => return self.fail(SAMPLES, &e),
        }
        match open(COMMANDS).and_then(|f| StreamFile::start(f, Stream::Commands)) {
            Ok(f) => self.commands = Some(f),
            Err(e) => return self.fail(COMMANDS, &e),
        }
        match open(EVENTS) {
            Ok(f) => self.events = Some(f),
            Err(e) => self.fail(EVENTS, &e),
        }
    }

    pub(super) fn run(mut self, rx: &Receiver<Item>) {
        self.open();
        loop {
            let item = rx.recv_timeout(COMMIT_EVERY);
            // Alive: `finish` gives up only on a writer stuck in a call.
            self.progress.fetch_add(1, Ordering::Relaxed);
            match item {
                Ok(Item::Finish(finish)) => return self.finish(*finish),
                Ok(item) => self.take(item),
                Err(RecvTimeoutError::Timeout) => {}
                // The run ended without `finish` (it failed): leave the
                // files ended and, if a tick was recorded, the metadata
                // saying so (with none, the directory is no recording and
                // may be used again).
                Err(RecvTimeoutError::Disconnected) => {
                    self.end_streams(Lost::default());
                    if self.given.ticks > 0 {
                        self.meta.summary.problems = vec!["the run did not finish".into()];
                        self.write_meta();
                    }
                    return;
                }
            }
            let big = self.sample_ops.len() + self.command_ops.len() + self.event_lines.len();
            if big >= CHUNK_BYTES || self.last_commit.elapsed() >= COMMIT_EVERY {
                self.commit(RESERVE_BYTES);
            }
        }
    }

    fn take(&mut self, item: Item) {
        if !self.recording() {
            let lost = one(&item);
            match &mut self.capped {
                Some((_, not_written)) => *not_written = not_written.plus(lost),
                None => self.error_lost = self.error_lost.plus(lost),
            }
            return;
        }
        match item {
            Item::Start { sensor, arm } => {
                self.meta.sensor = sensor;
                self.meta.arm = arm;
            }
            Item::Input(input) => {
                // From the first tick the directory is a recording (one
                // whose run is killed says so: "status": "recording").
                if self.given.ticks == 0 {
                    self.write_meta();
                }
                self.sample_enc.input(&mut self.sample_ops, &input);
                let g = &mut self.given;
                g.ticks += 1;
                g.first_tick.get_or_insert(input.tick);
                g.last_tick = Some(input.tick);
                if input.stop {
                    g.stop_tick = Some(input.tick);
                }
            }
            Item::Command(command) => {
                self.command_enc.command(&mut self.command_ops, &command);
                self.given.arm_commands += 1;
            }
            Item::Event(event) => match serde_json::to_writer(&mut self.event_lines, &event) {
                Ok(()) => {
                    self.event_lines.push(b'\n');
                    self.given.events += 1;
                }
                Err(e) => self.fail(EVENTS, &e.into()),
            },
            Item::Lost(lost) => {
                self.sample_enc.lost(&mut self.sample_ops, lost.ticks);
                self.command_enc
                    .lost(&mut self.command_ops, lost.arm_commands);
            }
            Item::Finish(_) => {}
        }
    }

    fn bytes(&self) -> u64 {
        let stream = |f: &Option<StreamFile<File>>| f.as_ref().map_or(0, StreamFile::bytes);
        stream(&self.samples) + stream(&self.commands) + self.ended_bytes + self.event_bytes
    }

    /// What was given to the encoders and is not written.
    fn unwritten(&self) -> Lost {
        Lost {
            ticks: self.given.ticks - self.written.ticks,
            arm_commands: self.given.arm_commands - self.written.arm_commands,
            events: self.given.events - self.written.events,
        }
    }

    /// Writes what the encoders produced if it fits under the cap with
    /// `reserve` bytes to spare; if not, recording stops here (counted).
    fn commit(&mut self, reserve: u64) {
        self.last_commit = Instant::now();
        if !self.recording() {
            return;
        }
        let pending = self.sample_ops.len() + self.command_ops.len() + self.event_lines.len();
        if self.bytes() + pending as u64 + reserve > self.options.max_bytes {
            self.capped = Some((self.written.last_tick.unwrap_or(0), self.unwritten()));
            return;
        }
        let results = [
            (SAMPLES, write_stream(&mut self.samples, &self.sample_ops)),
            (
                COMMANDS,
                write_stream(&mut self.commands, &self.command_ops),
            ),
            (EVENTS, write_file(&mut self.events, &self.event_lines)),
        ];
        for (file, result) in results {
            if let Err(e) = result {
                self.fail(file, &e);
            }
        }
        if self.error.is_some() {
            self.error_lost = self.unwritten();
            return;
        }
        self.event_bytes += self.event_lines.len() as u64;
        self.sample_ops.clear();
        self.command_ops.clear();
        self.event_lines.clear();
        // The ticks of a run the encoder still holds are written with it
        // (a run is of consecutive ticks).
        let held = self.sample_enc.held();
        self.written = Counts {
            ticks: self.given.ticks - held,
            last_tick: self.given.last_tick.map(|t| t.saturating_sub(held)),
            ..self.given
        };
    }

    /// Ends both streams (the runs held, the end markers: the reserve
    /// under the cap keeps room for them) and flushes every file to the
    /// disk.
    fn end_streams(&mut self, pending: Lost) {
        if self.recording() {
            self.sample_enc.lost(&mut self.sample_ops, pending.ticks);
            self.command_enc
                .lost(&mut self.command_ops, pending.arm_commands);
            self.sample_enc.flush(&mut self.sample_ops);
            self.commit(2 * END_BYTES);
        }
        for (name, stream) in [
            (SAMPLES, self.samples.take()),
            (COMMANDS, self.commands.take()),
        ] {
            if let Some(stream) = stream {
                self.ended_bytes += stream.bytes() + END_BYTES;
                if let Err(e) = stream.end().and_then(|f| f.sync_all()) {
                    self.fail(name, &e);
                }
            }
        }
        if let Some(events) = self.events.take()
            && let Err(e) = events.sync_all()
        {
            self.fail(EVENTS, &e);
        }
    }

    /// Ends the recording: the streams, `report.json` (with the
    /// recording's summary in it), the final `meta.json`; replies with the
    /// summary (which also says if writing those failed).
    fn finish(mut self, finish: Finish) {
        let Finish {
            mut report,
            pending,
            ring_lost,
            queue_dropped,
            reply,
        } = finish;
        self.end_streams(pending);
        let recording = self.summary(ring_lost, queue_dropped);
        self.meta.status = "finished".into();
        self.meta.summary.clone_from(&recording.summary);
        report.recording = Some(recording);
        match serde_json::to_string_pretty(&report) {
            Ok(text) => {
                if let Err(e) = std::fs::write(self.dir.join(REPORT), text + "\n") {
                    self.fail(REPORT, &e);
                }
            }
            Err(e) => self.fail(REPORT, &e.into()),
        }
        self.write_meta();
        let _ = reply.send(self.summary(ring_lost, queue_dropped));
    }

    fn summary(&self, ring_lost: Lost, queue_dropped: Lost) -> RecordingReport {
        let cap_lost = self.capped.map_or(Lost::default(), |(_, lost)| lost);
        let mut problems = problems(
            ring_lost,
            queue_dropped,
            self.capped,
            self.options.max_bytes,
        );
        if let Some(error) = &self.error {
            problems.push(format!(
                "{error}: {} ticks, {} arm commands, {} events not written",
                self.error_lost.ticks, self.error_lost.arm_commands, self.error_lost.events
            ));
        }

        RecordingReport {
            dir: self.dir.display().to_string(),
            summary: RecordingSummary {
                complete: problems.is_empty(),
                ticks: self.written.ticks,
                arm_commands: self.written.arm_commands,
                events: self.written.events,
                stop_tick: self.written.stop_tick,
                bytes: self.bytes(),
                max_bytes: self.options.max_bytes,
                lost: ring_lost
                    .plus(queue_dropped)
                    .plus(cap_lost)
                    .plus(self.error_lost),
                problems,
            },
            error: self.error.clone(),
        }
    }

    fn write_meta(&mut self) {
        let w = self.written;
        let bytes = self.bytes();
        let meta = &mut self.meta;
        (meta.first_tick, meta.last_tick) = (w.first_tick, w.last_tick);
        let s = &mut meta.summary;
        (s.ticks, s.arm_commands, s.events, s.stop_tick) =
            (w.ticks, w.arm_commands, w.events, w.stop_tick);
        s.bytes = bytes;
        let written = serde_json::to_string_pretty(&self.meta)
            .map_err(std::io::Error::from)
            .and_then(|text| std::fs::write(self.dir.join(META), text + "\n"));
        if let Err(e) = written {
            self.fail(META, &e);
        }
    }
}

fn write_stream(file: &mut Option<StreamFile<File>>, ops: &[u8]) -> std::io::Result<()> {
    match file {
        Some(f) if !ops.is_empty() => f.write(ops),
        _ => Ok(()),
    }
}

fn write_file(file: &mut Option<File>, bytes: &[u8]) -> std::io::Result<()> {
    match file {
        Some(f) if !bytes.is_empty() => f.write_all(bytes),
        _ => Ok(()),
    }
}
