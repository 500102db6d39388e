//! What the display shows, built on the telemetry side from each tick's
//! record (the core's [`CoreView`] and the sample) and the events. Pure:
//! the same records and events give the same frames, so it is tested with
//! simulated ticks. The page, the terminal view and the tests all draw
//! the same [`Frame`]; [`Setup`] is what does not change during a run.

use serde::Serialize;

use crate::control::Tick;
use crate::control::action::{Action, ActionSeq, Breath};
use crate::control::core_config::CoreConfig;
use crate::control::event::{Event, TimedEvent};
use crate::control::mode::{Direction, Mode, ModeState};
use crate::control::modes::DetectionReason;
use crate::control::motion::MotionEvent;
use crate::control::motion::workspace::Boundary;
use crate::control::sample::Sample;
use crate::control::selection::Interface;
use crate::control::target::Target;
use crate::control::view::CoreView;
use crate::fit::outcome::Outcome;
use crate::fit::prompter::{Phase, Say, View};
use crate::rt::telemetry::TickRecord;

/// One breath of a sequence, as the page draws it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Symbol {
    /// `sip` or `puff`.
    pub breath: &'static str,
    /// A long one.
    pub long: bool,
}

impl Symbol {
    fn of(action: Action) -> Symbol {
        Symbol {
            breath: action.breath().word(),
            long: action.is_long(),
        }
    }
}

fn symbols(sequence: &ActionSeq) -> Vec<Symbol> {
    sequence.as_slice().iter().map(|&a| Symbol::of(a)).collect()
}

/// A mode as listed on the screen.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModeEntry {
    /// Its config name (`translate_x`), or what it fires
    /// (`key:ctrl+alt+t`, `click:left`, `event:lights_toggle`, `drag`).
    pub mode: String,
    /// What a person reads (`Forward / back`, `Ctrl+Alt+T`).
    pub label: String,
    /// What puff and sip do, or what it does.
    pub description: String,
    /// Its sequences (ASP), in library order; indices into
    /// [`Frame::candidates`] are `(mode index, sequence index)` flattened
    /// as [`Setup::sequences`].
    pub sequences: Vec<Vec<Symbol>>,
}

/// What does not change during a run: sent once to each page.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Setup {
    /// `run` (the modes, `sipnpuff run`) or `fit` (a live calibration's
    /// prompts, `sipnpuff fit`).
    pub view: &'static str,
    /// `asp` (sequences) or `bsp` (scanning).
    pub interface: &'static str,
    /// The modes in the order the screen lists them: the library's order
    /// of first appearance (ASP) or the scan order (BSP).
    pub modes: Vec<ModeEntry>,
    /// Every library sequence with its mode, in library order (the
    /// indices of [`Frame::candidates`]).
    pub sequences: Vec<LibrarySequence>,
    /// The neutral, puff and sip thresholds and the hysteresis, volts, as
    /// configured (the frame carries the tracked neutral).
    pub puff_offset_volts: f64,
    /// Sip threshold minus neutral (negative).
    pub sip_offset_volts: f64,
    /// The hysteresis band, volts.
    pub hysteresis_volts: f64,
    /// A breath this long or longer is long, ms.
    pub long_ms: u32,
    /// How long the matcher waits for the next breath, ms.
    pub sequence_timeout_ms: u32,
    /// How long command mode waits before returning to selection, ms.
    pub inactivity_ms: u32,
    /// Scan dwell, ms (BSP).
    pub dwell_ms: u32,
    /// First dwell of a scan, ms (BSP).
    pub first_dwell_ms: u32,
    /// The arm, in words (`simulated JACO`, `ROS 1 at /j2n6s300_driver`).
    pub arm: String,
}

/// A sequence of the library.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LibrarySequence {
    /// What it selects or fires ([`ModeEntry::mode`]).
    pub mode: String,
    /// Its breaths.
    pub symbols: Vec<Symbol>,
}

/// The matcher waiting for the next breath.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Waiting {
    /// Time left before it decides, ms (frozen while a breath is held).
    pub ms_left: u64,
    /// The whole wait, ms.
    pub total_ms: u32,
    /// What it selects then ([`ModeEntry::mode`]; the sequence is
    /// complete but a longer one starts with it); `None`: the sequence is
    /// dropped.
    pub selects: Option<String>,
}

/// The scan's highlight (BSP).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Highlight {
    /// The mode highlighted.
    pub mode: &'static str,
    /// Time it stays highlighted, ms.
    pub ms_left: u64,
    /// Its whole dwell, ms.
    pub dwell_ms: u32,
}

/// Command mode.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Command {
    /// The mode.
    pub mode: &'static str,
    /// The motion, in words (`forward`, `close fingers`, `stopped`).
    pub moving: &'static str,
    /// Which arrow to draw: `forward`, `back`, `left`, `right`, `up`,
    /// `down`, `turn_positive`, `turn_negative`, `open`, `close`, `save`,
    /// `goto` or `none`.
    pub arrow: &'static str,
    /// Time before the return to selection, ms.
    pub returns_in_ms: u64,
    /// A breath is held: the countdown waits.
    pub countdown_paused: bool,
}

/// The pressure bar.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Pressure {
    /// The sample, volts (`None`: no sample this tick).
    pub volts: Option<f64>,
    /// The tracked neutral, volts.
    pub neutral_volts: f64,
    /// The breath held: `sip` or `puff`.
    pub held: Option<&'static str>,
    /// For how long, ms (against [`Setup::long_ms`]).
    pub held_ms: u64,
}

/// A line of plain words for the user.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Notice {
    /// `fault`, `limit` or `info`: how it is drawn.
    pub level: &'static str,
    /// The words.
    pub text: String,
}

/// Everything the screen shows at one moment.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Frame {
    /// The tick it shows.
    pub tick: Tick,
    /// `selecting`, `command` or `stopped` (faulted arm or the run
    /// stopping: nothing will be selected again).
    pub state: &'static str,
    /// ASP: the sequence entered so far.
    pub sequence: Vec<Symbol>,
    /// ASP: the library sequences (indices into [`Setup::sequences`]) the
    /// current sequence can still become (all of them when it is empty).
    pub candidates: Vec<usize>,
    /// ASP: the matcher's wait for the next breath.
    pub waiting: Option<Waiting>,
    /// BSP: the scan's highlight.
    pub highlight: Option<Highlight>,
    /// The mode selected last (lit until the next selection starts).
    pub selected: Option<&'static str>,
    /// Command mode.
    pub command: Option<Command>,
    /// The pressure bar.
    pub pressure: Pressure,
    /// Faults, limits and other news, most important first.
    pub notices: Vec<Notice>,
    /// The saved point: `none`, `set` or `reached`.
    pub saved_point: &'static str,
    /// The arm: `connected` or `fault`.
    pub arm: &'static str,
    /// A live calibration's prompts (`sipnpuff fit` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub calibration: Option<Calibration>,
}

/// What a live calibration (`sipnpuff fit`) shows: the prompt, large;
/// the count; a line of news; the rest level; at the end, the summary.
/// Words from the session's guide ([`crate::fit::prompter`]), as the
/// terminal prints them.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Calibration {
    /// `rest` (the rest at the start), `pause` (resting before the next
    /// prompt), `prompt`, `finished`, `stopped`, or `summary` (the fit is
    /// done, or nothing was written).
    pub phase: &'static str,
    /// The large words: "short puff — now", "rest, please".
    pub headline: String,
    /// "3 of 8" (empty without a prompt).
    pub count: String,
    /// "block 1 of 4: 8 short puffs" (empty without a prompt).
    pub block: String,
    /// The latest news: "that was a sip — again, a puff please", "got it".
    pub message: String,
    /// How the news is drawn: `info`, `again` (not counted, or the prompt
    /// repeated) or `fault` (the session stopped).
    pub message_level: &'static str,
    /// Breaths counted so far.
    pub counted: u32,
    /// Breaths the session asks for.
    pub total: u32,
    /// The rest level measured, volts (the pressure bar's centre).
    pub rest_volts: Option<f64>,
    /// The band around it a breath must leave, volts.
    pub band_volts: Option<f64>,
    /// The breath held now: `sip` or `puff`.
    pub held: Option<&'static str>,
    /// The summary, once the session is over.
    pub outcome: Option<Outcome>,
}

impl Calibration {
    /// Before the session's first tick.
    fn starting() -> Calibration {
        Calibration {
            phase: "rest",
            headline: "rest, please".into(),
            count: String::new(),
            block: String::new(),
            message: String::new(),
            message_level: "info",
            counted: 0,
            total: 0,
            rest_volts: None,
            band_volts: None,
            held: None,
            outcome: None,
        }
    }

    /// The guide's view.
    fn of(view: &View) -> Calibration {
        let message_level = match view.message {
            Some(
                Say::WrongKind { .. }
                | Say::Early { .. }
                | Say::Repeat(_)
                | Say::Rest { again: true },
            ) => "again",
            Some(Say::Stopped(_)) => "fault",
            _ => "info",
        };
        Calibration {
            phase: match view.phase {
                Phase::Rest => "rest",
                Phase::Pause => "pause",
                Phase::Prompted => "prompt",
                Phase::Finished => "finished",
                Phase::Stopped => "stopped",
            },
            headline: view.headline(),
            count: view.prompt.map(|p| p.count_words()).unwrap_or_default(),
            block: view.prompt.map(|p| p.block_words()).unwrap_or_default(),
            message: view.message.map(|s| s.message()).unwrap_or_default(),
            message_level,
            counted: view.counted,
            total: view.total,
            rest_volts: view.band.map(|b| b.level),
            band_volts: view.band.map(|b| b.outside),
            held: view.held.map(Breath::word),
            outcome: None,
        }
    }
}

/// A sound the page plays.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Cue {
    /// A mode was selected.
    Match,
    /// Back to selection (inactivity).
    Selection,
    /// A sensor or arm fault.
    Fault,
    /// Motion stopped at a limit.
    Limit,
    /// A calibration's prompt: breathe now.
    Prompt,
    /// A calibration's breath not counted (wrong kind, too early) or its
    /// prompt repeated.
    Again,
    /// A calibration's last breath is in.
    Done,
}

/// The screen's state: fed records and events, gives frames and cues.
#[derive(Debug, Clone)]
pub struct Screen {
    setup: Setup,
    library: Vec<ActionSeq>,
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
            hysteresis_volts: detector.hysteresis_volts,
            long_ms: detector.long_burst_ms,
            sequence_timeout_ms: config.matcher().sequence_timeout_ms,
            inactivity_ms: config.command().inactivity_timeout_ms,
            dwell_ms: scanning.dwell_ms,
            first_dwell_ms: scanning.first_dwell_ms,
            arm: arm.to_string(),
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
            Event::Burst(_) | Event::Reset { .. } | Event::Highlight { .. } => None,
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
                    countdown_paused: view.held.is_some(),
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
            notices,
            saved_point: self.saved,
            arm: if view.arm_faulted {
                "fault"
            } else {
                "connected"
            },
            calibration: self.calibration.clone(),
        }
    }
}

/// `sequence` starts with `prefix`.
fn starts_with(sequence: &ActionSeq, prefix: &ActionSeq) -> bool {
    sequence.as_slice().starts_with(prefix.as_slice())
}

/// How the page names what a library entry does: a mode by its config
/// name, anything else by its kind and value (`key:ctrl+alt+t`,
/// `click:left`, `event:lights_toggle`, `drag`).
pub fn target_id(target: &Target) -> String {
    match target {
        Target::Mode(mode) => mode.name().to_owned(),
        Target::Drag => "drag".to_owned(),
        Target::Key(chord) => format!("key:{chord}"),
        Target::Click(click) => format!("click:{}", click.name()),
        Target::Home(event) => format!("event:{}", event.as_str()),
    }
}

/// What a library entry does, for people: "Forward / back",
/// "Ctrl+Alt+T", "Lights: toggle", "Pointer ←→".
pub fn target_label(target: &Target) -> String {
    match target {
        Target::Mode(mode) => label(mode.to_owned()).to_owned(),
        Target::Home(event) => home_label(event.as_str()),
        _ => target.label(),
    }
}

/// A home event's name for people: `lights_toggle` → "Lights: toggle"
/// (the last word is the action), `movie_time` → "Movie time".
fn home_label(name: &str) -> String {
    let words: Vec<&str> = name.split('_').filter(|w| !w.is_empty()).collect();
    let capital = |w: &str| {
        let mut c = w.chars();
        c.next()
            .map(|f| f.to_uppercase().collect::<String>() + c.as_str())
            .unwrap_or_default()
    };
    const ACTIONS: [&str; 7] = ["toggle", "on", "off", "open", "close", "up", "down"];
    match words.split_last() {
        Some((last, rest)) if !rest.is_empty() && ACTIONS.contains(last) => {
            format!("{}: {last}", capital(&rest.join(" ")))
        }
        _ => capital(&words.join(" ")),
    }
}

/// The news when a match fires an action.
fn fired_words(target: &Target) -> String {
    match target {
        Target::Drag => "drag: the button is held, or let go".to_owned(),
        Target::Key(chord) => format!("typed {}", chord.label()),
        Target::Click(click) => format!("{} click", click.name()),
        Target::Home(event) => format!("sent {}", home_label(event.as_str())),
        Target::Mode(mode) => mode.name().to_owned(),
    }
}

/// A mode's name for people.
pub fn label(mode: Mode) -> &'static str {
    match mode {
        Mode::TranslateX => "Forward / back",
        Mode::TranslateY => "Left / right",
        Mode::TranslateZ => "Up / down",
        Mode::RotateX => "Turn about x",
        Mode::RotateY => "Turn about y",
        Mode::RotateZ => "Turn about z",
        Mode::Fingers => "Fingers",
        Mode::SavePoint => "Save point",
        Mode::GotoPoint => "Go to point",
        Mode::PointerX | Mode::PointerY | Mode::Scroll => mode.label(),
    }
}

/// The motion in words, and the arrow drawn for it.
fn motion_shown(mode: Mode, direction: Direction) -> (&'static str, &'static str) {
    use Direction::{Negative, Positive, Still};
    match (mode, direction) {
        (_, Still) => ("stopped", "none"),
        (Mode::TranslateX, Positive) => ("forward", "forward"),
        (Mode::TranslateX, Negative) => ("back", "back"),
        (Mode::TranslateY, Positive) => ("left", "left"),
        (Mode::TranslateY, Negative) => ("right", "right"),
        (Mode::TranslateZ, Positive) => ("up", "up"),
        (Mode::TranslateZ, Negative) => ("down", "down"),
        (Mode::RotateX, Positive) => ("turning about x (+)", "turn_positive"),
        (Mode::RotateX, Negative) => ("turning about x (−)", "turn_negative"),
        (Mode::RotateY, Positive) => ("turning about y (+)", "turn_positive"),
        (Mode::RotateY, Negative) => ("turning about y (−)", "turn_negative"),
        (Mode::RotateZ, Positive) => ("turning about z (+)", "turn_positive"),
        (Mode::RotateZ, Negative) => ("turning about z (−)", "turn_negative"),
        (Mode::Fingers, Positive) => ("open fingers", "open"),
        (Mode::Fingers, Negative) => ("close fingers", "close"),
        (Mode::SavePoint, _) => ("saving the point", "save"),
        (Mode::GotoPoint, Positive) => ("going to the saved point", "goto"),
        (Mode::GotoPoint, Negative) => ("stopped", "none"),
        (Mode::PointerX, Positive) => ("pointer right", "right"),
        (Mode::PointerX, Negative) => ("pointer left", "left"),
        (Mode::PointerY, Positive) => ("pointer up", "up"),
        (Mode::PointerY, Negative) => ("pointer down", "down"),
        (Mode::Scroll, Positive) => ("scrolling up", "up"),
        (Mode::Scroll, Negative) => ("scrolling down", "down"),
    }
}

/// A workspace limit in plain words.
fn limit_words(boundary: Boundary) -> &'static str {
    match boundary {
        Boundary::Reach => "reach limit: the arm is as far out as it goes",
        Boundary::Base => "too close to the arm's base",
        Boundary::Table => "table reached",
        Boundary::FingersOpen => "fingers fully open",
        Boundary::FingersClosed => "fingers fully closed",
        Boundary::Tilt => "tilt limit reached",
        Boundary::Twist => "twist limit reached",
    }
}
