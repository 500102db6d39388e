//! The display's feed, on the telemetry thread: every record and event
//! goes through the [`Screen`]; a frame is published after a drain that
//! brought an event, or every [`FRAME_PERIOD_MS`] otherwise, into a
//! latest-value slot (a page that reads slowly skips frames, it never
//! queues them) and each sound into a bounded broadcast (a page that falls
//! behind loses the oldest, counted). Nothing here blocks the telemetry
//! thread, and nothing reaches the control thread.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Instant, SystemTime, UNIX_EPOCH};

use serde::Serialize;
use tokio::sync::{broadcast, watch};

use crate::control::Tick;
use crate::control::core_config::CoreConfig;
use crate::control::event::TimedEvent;
use crate::control::imu::ImuInput;
use crate::display::frame::{Cue, Frame};
use crate::display::screen::Screen;
use crate::fit::outcome::Outcome;
use crate::fit::prompter::{Say, View};
use crate::gestures::guided::Say as GuideSay;
use crate::rt::report::{DisplayCounts, DisplaySummary};
use crate::rt::telemetry::{TelemetryObserver, TickRecord};

/// Frames go out at least this often while anything changes, ms (25 a
/// second: smooth enough for the pressure bar and the countdowns); a
/// drain that brought an event publishes at once.
pub const FRAME_PERIOD_MS: u64 = 40;

/// Sounds a page may fall behind by before the oldest are dropped.
pub const CUE_QUEUE: usize = 32;

/// One published frame, serialized once for every page.
#[derive(Debug)]
pub struct Published {
    /// 1, 2, … in publication order (a page that skipped frames sees gaps).
    pub seq: u64,
    /// The frame.
    pub frame: Frame,
    /// The frame on the wire as JSON (with the last event's tick and wake
    /// time, and when it was sent): what a page receives.
    pub json: String,
    /// The session's last frame: nothing follows it (`fit`'s summary).
    pub last: bool,
}

/// A frame on the wire.
#[derive(Serialize)]
struct Wire<'a> {
    seq: u64,
    /// The last event the frame shows: its tick, and when the control
    /// thread woke for that tick (Unix ms, the clock a browser's
    /// `Date.now()` reads), to measure event-to-screen latency.
    event_tick: Option<Tick>,
    event_unix_ms: Option<f64>,
    /// When the frame was published, Unix ms.
    sent_unix_ms: f64,
    #[serde(flatten)]
    frame: &'a Frame,
}

/// A sound on the wire.
#[derive(Debug, Clone, Serialize)]
pub struct CueMessage {
    /// Which.
    pub cue: Cue,
    /// The tick of the event that called for it.
    pub tick: Tick,
}

/// Counters shared by the feed and the pages' streams.
#[derive(Debug, Default)]
pub struct FeedStats {
    /// What the report says of the display, counted live.
    pub counts: DisplayCounts<AtomicU64>,
    /// Pages open now.
    pub pages_open: AtomicU64,
    /// Times a session's last frame was sent to a page.
    pub last_frames_sent: AtomicU64,
}

/// What the pages and the terminal view read: the setup, the latest
/// frame, the sounds.
#[derive(Debug)]
pub struct Feed {
    /// [`crate::display::frame::Setup`] as JSON: sent first to each page.
    pub setup_json: String,
    /// The setup.
    pub setup: crate::display::frame::Setup,
    frames: watch::Sender<Arc<Published>>,
    cues: broadcast::Sender<CueMessage>,
    /// Counters.
    pub stats: FeedStats,
}

impl Feed {
    /// A receiver of the latest frame (it holds the current one).
    pub fn frames(&self) -> watch::Receiver<Arc<Published>> {
        self.frames.subscribe()
    }

    /// A receiver of the sounds from now on.
    pub fn cues(&self) -> broadcast::Receiver<CueMessage> {
        self.cues.subscribe()
    }

    /// The latest frame.
    pub fn latest(&self) -> Arc<Published> {
        self.frames.borrow().clone()
    }

    /// Waits until every open page has been sent the session's last frame
    /// (or `limit` passes: a page that stopped reading is not waited
    /// for); whether they all were.
    pub fn wait_last_sent(&self, limit: std::time::Duration) -> bool {
        let started = Instant::now();
        loop {
            let s = &self.stats;
            if s.last_frames_sent.load(Ordering::Relaxed) >= s.pages_open.load(Ordering::Relaxed) {
                return true;
            }
            if started.elapsed() >= limit {
                return false;
            }
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
    }

    /// What the report says of the display.
    pub fn summary(&self, address: Option<String>) -> DisplaySummary {
        let c = &self.stats.counts;
        let load = |n: &AtomicU64| n.load(Ordering::Relaxed);
        DisplaySummary {
            address,
            counts: DisplayCounts {
                pages_opened: load(&c.pages_opened),
                frames_published: load(&c.frames_published),
                frames_sent: load(&c.frames_sent),
                frames_skipped: load(&c.frames_skipped),
                cues_dropped: load(&c.cues_dropped),
            },
        }
    }
}

/// The telemetry thread's side: a [`TelemetryObserver`] that keeps the
/// [`Feed`] current.
pub struct DisplayHub {
    screen: Screen,
    feed: Arc<Feed>,
    /// Unix time minus `CLOCK_MONOTONIC`, ns.
    unix_minus_monotonic_ns: i128,
    /// `woke_ns` of recent ticks, by tick modulo the ring's length: an
    /// event's tick is looked up here when it arrives (events and records
    /// come through different rings).
    woke: Box<[(Tick, u64)]>,
    /// The last event's tick and, once its record is in, its wake time.
    last_event: Option<(Tick, Option<u64>)>,
    event_pending: bool,
    changed: bool,
    last_publish: Option<Instant>,
    seq: u64,
    /// Events waiting for their tick's record: the screen takes each
    /// after the record of its tick, as the core made them (events and
    /// records come through different rings, events drained first).
    waiting: Vec<TimedEvent>,
    /// The last record's tick.
    last_tick: Option<Tick>,
    /// The session's last frame is published.
    last: bool,
}

/// How many recent ticks' wake times are kept (2 s).
const WOKE_TICKS: usize = 2048;

impl DisplayHub {
    /// The hub for a run of `config` on `arm` (in words).
    pub fn new(config: &CoreConfig, arm: &str) -> DisplayHub {
        DisplayHub::showing(Screen::new(config, arm))
    }

    /// The hub for a live calibration (`sipnpuff fit`) on `config` and
    /// `arm`: the page shows the prompts.
    pub fn for_fit(config: &CoreConfig, arm: &str) -> DisplayHub {
        DisplayHub::showing(Screen::new(config, arm).fitting())
    }

    /// The hub for a live gesture recording (`sipnpuff gestures record`)
    /// of `names`: the page shows the prompts and the head.
    pub fn for_gestures(config: &CoreConfig, names: &[String]) -> DisplayHub {
        DisplayHub::showing(Screen::new(config, "none").recording_gestures(names))
    }

    fn showing(screen: Screen) -> DisplayHub {
        let setup = screen.setup().clone();
        let setup_json = serde_json::to_string(&setup).unwrap_or_else(|_| "{}".into());
        let first = publication(1, screen.frame(), None, false);
        let (frames, _) = watch::channel(Arc::new(first));
        let (cues, _) = broadcast::channel(CUE_QUEUE);
        let feed = Arc::new(Feed {
            setup_json,
            setup,
            frames,
            cues,
            stats: FeedStats::default(),
        });
        feed.stats
            .counts
            .frames_published
            .store(1, Ordering::Relaxed);
        DisplayHub {
            screen,
            feed,
            unix_minus_monotonic_ns: unix_minus_monotonic_ns(),
            woke: vec![(Tick::MAX, 0); WOKE_TICKS].into_boxed_slice(),
            last_event: None,
            event_pending: false,
            changed: false,
            last_publish: None,
            seq: 1,
            waiting: Vec::with_capacity(64),
            last_tick: None,
            last: false,
        }
    }

    /// The feed the pages and the terminal view read.
    pub fn feed(&self) -> Arc<Feed> {
        self.feed.clone()
    }

    /// Publishes the frame now (the run's last, or a test's), with every
    /// event taken in.
    pub fn publish(&mut self) {
        self.take_events(Tick::MAX);
        self.publish_frame();
    }

    /// Takes a live calibration's state from its guide, after it said
    /// `said` on `tick`: published at the next drain, its sound at once.
    pub fn calibrate(&mut self, tick: Tick, view: &View, said: Option<&Say>) {
        if let Some(cue) = self.screen.calibrate(view, said) {
            let _ = self.feed.cues.send(CueMessage { cue, tick });
        }
        self.event_pending = true;
    }

    /// A live gesture recording's IMU input on `tick`: a frame goes out
    /// every [`FRAME_PERIOD_MS`].
    pub fn observe_imu(&mut self, tick: Tick, input: ImuInput) {
        self.screen.observe_imu(tick, input);
        let due = self
            .last_publish
            .is_none_or(|at| at.elapsed().as_millis() as u64 >= FRAME_PERIOD_MS);
        if due {
            self.publish_frame();
        }
    }

    /// What a live gesture recording's guide said on `tick` (`seen`
    /// examples in; `max_ms` the longest gesture): published at once,
    /// with its sound.
    pub fn guide_gestures(&mut self, tick: Tick, said: &GuideSay, seen: usize, max_ms: u32) {
        if let Some(cue) = self.screen.guide_gestures(tick, said, seen, max_ms) {
            let _ = self.feed.cues.send(CueMessage { cue, tick });
        }
        self.publish_frame();
    }

    /// Publishes a live gesture recording's end (`summary`; `written`:
    /// the set was) as the session's last frame; then
    /// [`Feed::wait_last_sent`] tells when the pages have it.
    pub fn conclude_gestures(&mut self, summary: String, written: bool) {
        self.screen.conclude_gestures(summary, written);
        self.last = true;
        self.publish_frame();
    }

    /// Publishes a live calibration's summary as the session's last
    /// frame; then [`Feed::wait_last_sent`] tells when the pages have it.
    pub fn conclude(&mut self, outcome: &Outcome) {
        self.take_events(Tick::MAX);
        self.screen.conclude(outcome);
        self.last = true;
        self.publish_frame();
    }

    fn publish_frame(&mut self) {
        self.seq += 1;
        let offset = self.unix_minus_monotonic_ns;
        let event = self.last_event.map(|(tick, woke_ns)| {
            let unix_ms = woke_ns.map(|ns| (i128::from(ns) + offset) as f64 / 1e6);
            (tick, unix_ms)
        });
        let published = publication(self.seq, self.screen.frame(), event, self.last);
        self.feed.frames.send_replace(Arc::new(published));
        self.feed
            .stats
            .counts
            .frames_published
            .fetch_add(1, Ordering::Relaxed);
        self.last_publish = Some(Instant::now());
        self.event_pending = false;
        self.changed = false;
    }

    /// Gives the screen the waiting events of ticks up to `tick`.
    fn take_events(&mut self, tick: Tick) {
        let mut kept = 0;
        for i in 0..self.waiting.len() {
            let event = self.waiting[i];
            if event.tick <= tick {
                self.take_event(&event);
            } else {
                self.waiting[kept] = event;
                kept += 1;
            }
        }
        self.waiting.truncate(kept);
    }

    fn take_event(&mut self, event: &TimedEvent) {
        // An event's record comes through its own ring: its wake time is
        // looked up when known.
        self.last_event = Some((event.tick, self.woke_at(event.tick)));
        self.event_pending = true;
        if let Some(cue) = self.screen.event(event) {
            // No page listening is not an error.
            let _ = self.feed.cues.send(CueMessage {
                cue,
                tick: event.tick,
            });
        }
    }

    fn woke_at(&self, tick: Tick) -> Option<u64> {
        let (at, woke) = self.woke[(tick % WOKE_TICKS as u64) as usize];
        (at == tick).then_some(woke)
    }
}

fn publication(
    seq: u64,
    frame: Frame,
    event: Option<(Tick, Option<f64>)>,
    last: bool,
) -> Published {
    let wire = Wire {
        seq,
        event_tick: event.map(|e| e.0),
        event_unix_ms: event.and_then(|e| e.1),
        sent_unix_ms: unix_ms(),
        frame: &frame,
    };
    let json = serde_json::to_string(&wire).unwrap_or_else(|_| "{}".into());
    Published {
        seq,
        frame,
        json,
        last,
    }
}

impl TelemetryObserver for DisplayHub {
    fn record(&mut self, record: &TickRecord) {
        if record.reference {
            return;
        }
        self.woke[(record.tick % WOKE_TICKS as u64) as usize] = (record.tick, record.woke_ns);
        self.screen.observe(record);
        self.last_tick = Some(record.tick);
        self.changed = true;
        if !self.waiting.is_empty() {
            self.take_events(record.tick);
        }
    }

    fn event(&mut self, event: &TimedEvent) {
        self.waiting.push(*event);
    }

    fn drained(&mut self) {
        if let Some((tick, None)) = self.last_event {
            self.last_event = Some((tick, self.woke_at(tick)));
        }
        // Events whose records were dropped (a full ring) wait no longer
        // than the next record after them.
        if let Some(tick) = self.last_tick {
            self.take_events(tick);
        }
        let due = self
            .last_publish
            .is_none_or(|at| at.elapsed().as_millis() as u64 >= FRAME_PERIOD_MS);
        if self.event_pending || self.changed && due {
            self.publish_frame();
        }
    }
}

/// Now, Unix ms.
fn unix_ms() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64() * 1000.0)
}

/// Unix time minus `CLOCK_MONOTONIC` (the control loop's clock), ns.
fn unix_minus_monotonic_ns() -> i128 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: a valid clock id and a pointer to a timespec we own.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    let monotonic = i128::from(ts.tv_sec) * 1_000_000_000 + i128::from(ts.tv_nsec);
    let unix = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as i128);
    unix - monotonic
}
