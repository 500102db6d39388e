//! What the display shows, built on the telemetry side from each tick's
//! record (the core's [`CoreView`] and the sample) and the events. Pure:
//! the same records and events give the same frames, so it is tested with
//! simulated ticks. The page, the terminal view and the tests all draw
//! the same [`Frame`]; [`Setup`] is what does not change during a run.

use crate::control::Tick;
use crate::control::action::Breath;
use crate::control::core_config::CoreConfig;
use crate::control::event::{Event, TimedEvent};
use crate::control::mode::{Direction, Mode, ModeState};
use crate::control::modes::DetectionReason;
use crate::control::motion::MotionEvent;
use crate::control::sample::Sample;
use crate::control::selection::Interface;
use crate::control::sequence::Sequence;
use crate::control::target::Target;
use crate::control::view::CoreView;
use crate::fit::outcome::Outcome;
use crate::fit::prompter::{Say, View};
use crate::rt::telemetry::TickRecord;

use crate::control::head::{pitch_and_roll, smooth_tilt};
use crate::control::imu::ImuInput;
use crate::display::frame::{
    Calibration, Command, Cue, Frame, GestureRecording, Head, HeadSetup, Highlight,
    LibrarySequence, ModeEntry, Notice, Pressure, Setup, Symbol, Waiting, symbols,
};
use crate::display::words::{
    fired_words, limit_words, motion_shown, movers, sequence_verb, target_id, target_label,
};
use crate::gestures::guided::{self, Say as GuideSay};
use crate::gestures::protocol::EXAMPLES;

/// The screen's state: fed records and events, gives frames and cues.
#[derive(Debug, Clone)]
pub struct Screen {
    setup: Setup,
    library: Vec<Sequence>,
    view: CoreView,
    tick: Tick,
    volts: Option<f64>,
    highlight_since: Tick,
    highlight_dwell: u32,
    selected: Option<Mode>,
    sensor_fault: Option<String>,
    arm_fault: Option<String>,
    limit: Option<(String, Direction, ModeState)>,
    saved: &'static str,
    news: Option<(String, Tick)>,
    stopping: bool,
    calibration: Option<Calibration>,
    /// A live gesture recording: what it shows, and the head read
    /// straight from the IMU (there is no core).
    recording: Option<Recording>,
}

/// A live gesture recording's state on the screen.
#[derive(Debug, Clone)]
struct Recording {
    view: GestureRecording,
    names: Vec<String>,
    /// The ordinary minute ends at this tick.
    ordinary_until: Option<Tick>,
    /// The acceleration, smoothed as the core smooths it.
    smoothed: Option<[f64; 3]>,
    /// The rest it is measured from (set when the rest is asked for and
    /// again at the first prompt).
    reference: Option<[f64; 3]>,
    /// Take the next smoothed value as the rest.
    anchor: bool,
}

/// How long a piece of news (`point saved`, `nothing saved yet`) stays up, ms.
const NEWS_MS: u64 = 4000;

impl Screen {
    /// The screen for a run of `config` with `arm` (in words).
    pub fn new(config: &CoreConfig, arm: &str) -> Screen {
        let detector = config.detector();
        let scanning = config.scanning();
        let interface = config.interface();
        let order: Vec<Target> = match interface {
            Interface::Asp => {
                let mut order = Vec::new();
                for entry in config.sequences() {
                    if !order.contains(&entry.target) {
                        order.push(entry.target);
                    }
                }
                order
            }
            Interface::Bsp => scanning.modes().iter().map(|&m| Target::Mode(m)).collect(),
        };
        let sequences_of = |target: Target| -> Vec<Vec<Symbol>> {
            if interface == Interface::Bsp {
                return Vec::new();
            }
            config
                .sequences()
                .iter()
                .filter(|e| e.target == target)
                .map(|e| symbols(&e.actions))
                .collect()
        };
        let setup = Setup {
            view: "run",
            interface: match interface {
                Interface::Asp => "asp",
                Interface::Bsp => "bsp",
            },
            modes: order
                .iter()
                .map(|&target| ModeEntry {
                    mode: target_id(&target),
                    label: target_label(&target),
                    description: target.description(),
                    sequences: sequences_of(target),
                })
                .collect(),
            sequences: if interface == Interface::Asp {
                config
                    .sequences()
                    .iter()
                    .map(|e| LibrarySequence {
                        mode: target_id(&e.target),
                        symbols: symbols(&e.actions),
                    })
                    .collect()
            } else {
                Vec::new()
            },
            puff_offset_volts: detector.puff_offset_volts(),
            sip_offset_volts: detector.sip_offset_volts(),
            hysteresis_volts: detector.hysteresis_of(Breath::Puff),
            sip_hysteresis_volts: detector.hysteresis_of(Breath::Sip),
            long_ms: detector.long_burst_ms,
            sequence_timeout_ms: config.matcher().sequence_timeout_ms,
            inactivity_ms: config.command().inactivity_timeout_ms,
            dwell_ms: scanning.dwell_ms,
            first_dwell_ms: scanning.first_dwell_ms,
            arm: arm.to_string(),
            breath: config.has_breath_sensor(),
            sequence_verb: sequence_verb(config),
            movers: movers(config),
            head: config.gestures().map(|_| {
                let head = config.head();
                HeadSetup {
                    tilt: head.tilt.name(),
                    dead_zone_deg: head.dead_zone_deg,
                    full_scale_deg: head.full_scale_deg,
                }
            }),
        };
        Screen {
            library: if interface == Interface::Asp {
                config.sequences().iter().map(|e| e.actions).collect()
            } else {
                Vec::new()
            },
            setup,
            view: CoreView {
                neutral_volts: detector.neutral_volts,
                ..CoreView::default()
            },
            tick: 0,
            volts: None,
            highlight_since: 0,
            highlight_dwell: 0,
            selected: None,
            sensor_fault: None,
            arm_fault: None,
            limit: None,
            saved: "none",
            news: None,
            stopping: false,
            calibration: None,
            recording: None,
        }
    }

    /// The screen of a live gesture recording (`sipnpuff gestures record`)
    /// of `names`: its prompts and the head, instead of the modes.
    pub fn recording_gestures(mut self, names: &[String]) -> Screen {
        self.setup.view = "gestures";
        self.setup.breath = false;
        self.recording = Some(Recording {
            view: GestureRecording {
                phase: "rest",
                headline: "hold your head still".into(),
                count: String::new(),
                gesture: String::new(),
                message: String::new(),
                message_level: "info",
                seen: 0,
                total: names.len() * EXAMPLES,
                ordinary_ms_left: None,
                summary: None,
            },
            names: names.to_vec(),
            ordinary_until: None,
            smoothed: None,
            reference: None,
            anchor: true,
        });
        self
    }

    /// A live gesture recording's IMU input on `tick`.
    pub fn observe_imu(&mut self, tick: Tick, input: ImuInput) {
        self.tick = tick;
        let Some(r) = self.recording.as_mut() else {
            return;
        };
        if let ImuInput::Sample(sample) = input
            && sample.is_finite()
        {
            smooth_tilt(&mut r.smoothed, sample.acceleration());
            if r.anchor {
                r.reference = r.smoothed;
                r.anchor = false;
            }
        }
    }

    /// What a live gesture recording's guide said on `tick`, `seen`
    /// examples in; `max_ms` is the front end's longest gesture. Returns
    /// the sound for it.
    pub fn guide_gestures(
        &mut self,
        tick: Tick,
        said: &GuideSay,
        seen: usize,
        max_ms: u32,
    ) -> Option<Cue> {
        self.tick = tick;
        let r = self.recording.as_mut()?;
        let (headline, message, level) = guided::page_words(said, &r.names, max_ms);
        let v = &mut r.view;
        v.headline = headline;
        v.message = message;
        v.message_level = level;
        v.seen = seen;
        let (phase, cue) = match *said {
            GuideSay::HoldStill { again } => {
                r.anchor = true;
                ("rest", again.then_some(Cue::Again))
            }
            GuideSay::Make {
                gesture,
                example,
                again,
            } => {
                if v.gesture.is_empty() {
                    r.anchor = true;
                }
                v.count = format!("{example} of {EXAMPLES}");
                v.gesture = format!(
                    "gesture {} of {}: {}",
                    gesture + 1,
                    r.names.len(),
                    r.names
                        .get(gesture)
                        .map_or("?", String::as_str)
                        .replace('_', " ")
                );
                ("prompt", Some(if again { Cue::Again } else { Cue::Prompt }))
            }
            GuideSay::Seen { .. } => ("between", None),
            GuideSay::OutOfTurn | GuideSay::TooLong { .. } => ("between", Some(Cue::Again)),
            GuideSay::Ordinary { ms } => {
                r.ordinary_until = Some(tick + ms);
                v.count = String::new();
                v.gesture = String::new();
                ("ordinary", Some(Cue::Prompt))
            }
            GuideSay::Done => {
                r.ordinary_until = None;
                ("finished", Some(Cue::Done))
            }
            GuideSay::Stopped(_) => {
                r.ordinary_until = None;
                ("stopped", Some(Cue::Fault))
            }
        };
        v.phase = phase;
        cue
    }

    /// A live gesture recording is over: what was written, or why not.
    pub fn conclude_gestures(&mut self, summary: String, written: bool) {
        if let Some(r) = self.recording.as_mut() {
            r.view.phase = "summary";
            r.view.headline = if written {
                "Gesture set written".into()
            } else {
                "No gesture set written".into()
            };
            r.view.summary = Some(summary);
            r.ordinary_until = None;
        }
    }

    /// The screen of a live calibration (`sipnpuff fit`): the prompts
    /// instead of the modes.
    pub fn fitting(mut self) -> Screen {
        self.setup.view = "fit";
        self.calibration = Some(Calibration::starting());
        self
    }

    /// Takes the session guide's view after it said `said`; returns the
    /// sound for what it said.
    pub fn calibrate(&mut self, view: &View, said: Option<&Say>) -> Option<Cue> {
        self.calibration = Some(Calibration::of(view));
        match said? {
            Say::Prompt(_) => Some(Cue::Prompt),
            Say::Repeat(_)
            | Say::WrongKind { .. }
            | Say::Early { .. }
            | Say::Rest { again: true } => Some(Cue::Again),
            Say::Finished => Some(Cue::Done),
            Say::Stopped(_) => Some(Cue::Fault),
            Say::Counted { .. } | Say::Rest { again: false } => None,
        }
    }

    /// The session is over: its summary.
    pub fn conclude(&mut self, outcome: &Outcome) {
        let c = self.calibration.get_or_insert_with(Calibration::starting);
        c.phase = "summary";
        c.headline = if outcome.profile.is_some() {
            "fitted — the profile is written".into()
        } else {
            "no profile written".into()
        };
        c.held = None;
        c.outcome = Some(outcome.clone());
    }

    /// What does not change.
    pub fn setup(&self) -> &Setup {
        &self.setup
    }

    /// Takes in one tick's record (a reference tick of `bench latency`
    /// is not the core's and is ignored).
    pub fn observe(&mut self, record: &TickRecord) {
        if record.reference {
            return;
        }
        let view = record.view;
        if view.highlighted != self.view.highlighted {
            self.highlight_since = record.tick;
            // A scan (re)starts on its first mode with the longer dwell.
            self.highlight_dwell = if self.view.highlighted.is_none() {
                self.setup.first_dwell_ms
            } else {
                self.setup.dwell_ms
            };
        }
        if view.state != self.view.state
            || view.direction != self.view.direction && view.direction != Direction::Still
        {
            self.limit = None;
        }
        if !view.sequence.is_empty() || view.held.is_some() && view.state == ModeState::Detection {
            // A new selection has begun: the last one is no longer lit.
            if !matches!(view.state, ModeState::Command(_)) {
                self.selected = None;
            }
        }
        if !view.sensor_faulted {
            self.sensor_fault = None;
        }
        self.view = view;
        self.tick = record.tick;
        self.volts = match record.input.sample {
            Sample::Volts(v) if v.is_finite() => Some(v),
            _ => None,
        };
        if self
            .news
            .as_ref()
            .is_some_and(|(_, at)| record.tick.saturating_sub(*at) >= NEWS_MS)
        {
            self.news = None;
        }
    }

    /// Takes in one event; returns the sound it calls for.
    pub fn event(&mut self, event: &TimedEvent) -> Option<Cue> {
        let tick = event.tick;
        match &event.event {
            Event::Match { target, .. } => {
                match target.mode() {
                    Some(mode) => self.selected = Some(mode),
                    None => self.news = Some((fired_words(target), tick)),
                }
                Some(Cue::Match)
            }
            Event::Detection { reason } => match reason {
                DetectionReason::Inactivity => Some(Cue::Selection),
                DetectionReason::Stop => {
                    self.stopping = true;
                    None
                }
                DetectionReason::Fault => None,
            },
            Event::Fault { reason } => {
                // Said with what it means for the arm (nothing moves).
                let reason = reason.to_string();
                self.sensor_fault = Some(if reason.ends_with("arm stopped") {
                    reason
                } else {
                    format!("{reason} — arm stopped")
                });
                Some(Cue::Fault)
            }
            Event::Recovered | Event::Rezeroed { .. } => {
                self.sensor_fault = None;
                None
            }
            Event::ArmFault { reason } => {
                self.arm_fault = Some(format!("arm: {reason} — arm stopped"));
                Some(Cue::Fault)
            }
            Event::Motion(motion) => self.motion_event(motion, tick),
            Event::GestureRejected { nearest, .. } => {
                // Never guessed: said, so the person knows to do it again.
                let words = match nearest {
                    Some(name) => format!("movement not read as a gesture (nearest: {name})"),
                    None => "movement not read as a gesture".into(),
                };
                self.news = Some((words, tick));
                None
            }
            Event::Burst(_)
            | Event::Gesture { .. }
            | Event::Reset { .. }
            | Event::Highlight { .. } => None,
        }
    }

    fn motion_event(&mut self, event: &MotionEvent, tick: Tick) -> Option<Cue> {
        match event {
            MotionEvent::WorkspaceLimit { boundary } => {
                self.limit = Some((
                    limit_words(*boundary).to_string(),
                    self.view.direction,
                    self.view.state,
                ));
                Some(Cue::Limit)
            }
            MotionEvent::Saved { .. } => {
                self.saved = "set";
                self.news = Some(("point saved".into(), tick));
                None
            }
            MotionEvent::GotoReached | MotionEvent::AlreadyAtSavedPoint => {
                self.saved = "reached";
                self.news = Some(("saved point reached".into(), tick));
                None
            }
            MotionEvent::GotoStarted { .. } => {
                self.saved = "set";
                None
            }
            MotionEvent::NoSavedPoint => {
                self.news = Some(("no point saved yet: save one first".into(), tick));
                None
            }
            MotionEvent::TrajectoryError => {
                self.news = Some(("motion error: braking".into(), tick));
                Some(Cue::Fault)
            }
            MotionEvent::PoseCorrected { .. } => None,
        }
    }

    /// The screen now.
    pub fn frame(&self) -> Frame {
        let view = &self.view;
        let now = self.tick;
        let held_ms = view
            .held
            .map_or(0, |(_, start)| now.saturating_sub(start) + 1);
        let stopped = view.arm_faulted || self.stopping;
        let sequence = view.sequence;
        let candidates = (0..self.library.len())
            .filter(|&i| {
                self.library
                    .get(i)
                    .is_some_and(|s| starts_with(s, &sequence))
            })
            .collect();
        let waiting = view.decides_at.map(|at| Waiting {
            ms_left: if view.held.is_some() {
                u64::from(self.setup.sequence_timeout_ms)
            } else {
                at.saturating_sub(now)
            },
            total_ms: self.setup.sequence_timeout_ms,
            selects: view.pending.as_ref().map(target_id),
        });
        // The scan runs in detection mode only.
        let scanning = view.state == ModeState::Detection && !stopped;
        let highlight = view.highlighted.filter(|_| scanning).map(|mode| Highlight {
            mode: mode.name(),
            ms_left: (self.highlight_since + u64::from(self.highlight_dwell)).saturating_sub(now),
            dwell_ms: self.highlight_dwell,
        });
        let command = match view.state {
            ModeState::Command(mode) => {
                let (moving, arrow) = motion_shown(mode, view.direction);
                Some(Command {
                    mode: mode.name(),
                    moving,
                    arrow,
                    returns_in_ms: view.returns_at.map_or(0, |at| at.saturating_sub(now)),
                    countdown_paused: view.held.is_some() || view.head.is_some_and(|h| h.tilted),
                })
            }
            ModeState::Detection => None,
        };
        let mut notices = Vec::new();
        if let Some(text) = &self.arm_fault {
            notices.push(Notice {
                level: "fault",
                text: text.clone(),
            });
        }
        if let Some(text) = &self.sensor_fault {
            notices.push(Notice {
                level: "fault",
                text: text.clone(),
            });
        }
        if let Some((text, _, _)) = &self.limit {
            notices.push(Notice {
                level: "limit",
                text: text.clone(),
            });
        }
        if self.stopping && !view.arm_faulted {
            notices.push(Notice {
                level: "info",
                text: "stopping — the arm brakes to rest".into(),
            });
        }
        if let Some((text, _)) = &self.news {
            notices.push(Notice {
                level: "info",
                text: text.clone(),
            });
        }
        Frame {
            tick: now,
            state: if stopped {
                "stopped"
            } else if command.is_some() {
                "command"
            } else {
                "selecting"
            },
            sequence: symbols(&sequence),
            candidates,
            waiting,
            highlight,
            selected: self.selected.map(Mode::name),
            command,
            pressure: Pressure {
                volts: self.volts,
                neutral_volts: view.neutral_volts,
                held: view.held.map(|(b, _)| b.word()),
                held_ms,
            },
            head: self.head(),
            notices,
            saved_point: self.saved,
            arm: if view.arm_faulted {
                "fault"
            } else {
                "connected"
            },
            calibration: self.calibration.clone(),
            recording: self.recording.as_ref().map(|r| GestureRecording {
                ordinary_ms_left: r.ordinary_until.map(|until| until.saturating_sub(now)),
                ..r.view.clone()
            }),
        }
    }

    /// The head for its trace: from the core, or in a live gesture
    /// recording straight from the IMU.
    fn head(&self) -> Option<Head> {
        let tenth = |deg: f64| (deg * 10.0).round() / 10.0;
        let (pitch, roll, moving) = match &self.recording {
            Some(r) => {
                let (pitch, roll) = pitch_and_roll(r.reference?, r.smoothed?)?;
                (pitch, roll, false)
            }
            None => {
                let h = self.view.head?;
                (h.pitch_deg, h.roll_deg, h.moving)
            }
        };
        Some(Head {
            pitch_deg: tenth(pitch),
            roll_deg: tenth(roll),
            moving,
        })
    }
}

/// `sequence` starts with `prefix`.
fn starts_with(sequence: &Sequence, prefix: &Sequence) -> bool {
    sequence.as_slice().starts_with(prefix.as_slice())
}
