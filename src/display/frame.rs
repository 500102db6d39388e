//! What the page and the terminal view draw: the [`Setup`] of a run (what
//! does not change), each moment's [`Frame`], a calibration's view and
//! the sounds ([`Cue`]). Plain serialized values; the
//! [`Screen`](crate::display::screen::Screen) builds them.

use serde::Serialize;

use crate::control::Tick;
use crate::control::action::Breath;
use crate::control::gesture::name::GestureName;
use crate::control::sequence::Sequence;
use crate::control::token::Token;
use crate::fit::outcome::Outcome;
use crate::fit::prompter::{Phase, Say, View};

/// One breath or gesture of a sequence, as the page draws it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Symbol {
    /// `sip`, `puff` or `gesture`.
    pub breath: &'static str,
    /// A long one.
    pub long: bool,
    /// The gesture's name (`nod`), for a gesture.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gesture: Option<GestureName>,
}

impl Symbol {
    fn of(token: Token) -> Symbol {
        match token {
            Token::Breath(action) => Symbol {
                breath: action.breath().word(),
                long: action.is_long(),
                gesture: None,
            },
            Token::Gesture(name) => Symbol {
                breath: "gesture",
                long: false,
                gesture: Some(name),
            },
        }
    }

    /// How a person reads it: `sip`, `long puff`, `nod`.
    pub fn words(&self) -> String {
        match (self.gesture, self.long) {
            (Some(name), _) => name.to_string(),
            (None, true) => format!("long {}", self.breath),
            (None, false) => self.breath.to_string(),
        }
    }
}

pub(super) fn symbols(sequence: &Sequence) -> Vec<Symbol> {
    sequence.as_slice().iter().map(|&t| Symbol::of(t)).collect()
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
    /// The puff's hysteresis band, volts.
    pub hysteresis_volts: f64,
    /// The sip's hysteresis band, volts.
    pub sip_hysteresis_volts: f64,
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
    /// A breath sensor feeds the core: the pressure bar is shown.
    pub breath: bool,
    /// A head-worn IMU feeds the core: its trace is shown.
    pub head: Option<HeadSetup>,
    /// How a sequence is made, in words: `breathe`, `make` (gestures
    /// alone) or `breathe or move`.
    pub sequence_verb: &'static str,
    /// What moves in a command mode, in words: `puff and sip move`,
    /// `tilting your head moves` or `puff, sip or a head tilt move`.
    pub movers: &'static str,
}

/// How the head moves the arm in a command mode (`[gestures]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct HeadSetup {
    /// `pitch`, `roll` or `off`: the tilt that moves.
    pub tilt: &'static str,
    /// Tilts within this angle of the rest move nothing, degrees.
    pub dead_zone_deg: f64,
    /// At this angle the arm moves at full speed, degrees.
    pub full_scale_deg: f64,
}

/// The head now, for its trace.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Head {
    /// Chin down (+) or up (−) from the rest, degrees (0.1°).
    pub pitch_deg: f64,
    /// Left ear down (+) or right ear down (−), degrees (0.1°).
    pub roll_deg: f64,
    /// A movement is under way.
    pub moving: bool,
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
    /// A breath is held, or the head tilted past its dead zone: the
    /// countdown waits.
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
    /// The head (a person with gestures; none before the IMU's first
    /// sample or in its fault).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub head: Option<Head>,
    /// Faults, limits and other news, most important first.
    pub notices: Vec<Notice>,
    /// The saved point: `none`, `set` or `reached`.
    pub saved_point: &'static str,
    /// The arm: `connected` or `fault`.
    pub arm: &'static str,
    /// A live calibration's prompts (`sipnpuff fit` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub calibration: Option<Calibration>,
    /// A live gesture recording's prompts (`sipnpuff gestures record`
    /// only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub recording: Option<GestureRecording>,
}

/// What a live gesture recording (`gestures record --sensor`) shows: the
/// prompt, large; the example's count and the gesture's place; a line of
/// news; the ordinary minute's time left; at the end, what was made. Words
/// from the session's guide ([`crate::gestures::guided`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GestureRecording {
    /// `rest` (holding still at the start), `prompt`, `between` (resting
    /// before the next prompt), `ordinary`, `finished`, `stopped`, or
    /// `summary` (the set is written, or nothing was).
    pub phase: &'static str,
    /// The large words: "nod — now", "rest".
    pub headline: String,
    /// "2 of 5" (empty without a prompt).
    pub count: String,
    /// "gesture 1 of 2: nod" (empty before the first prompt).
    pub gesture: String,
    /// The latest news: "seen (0.8 s)", "no movement seen yet".
    pub message: String,
    /// How the news is drawn: `info`, `again` or `fault`.
    pub message_level: &'static str,
    /// Examples seen so far.
    pub seen: usize,
    /// Examples the session asks for.
    pub total: usize,
    /// The ordinary minute's time left, ms.
    pub ordinary_ms_left: Option<u64>,
    /// At the end: the set written and its check, or why nothing was.
    pub summary: Option<String>,
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
    pub(super) fn starting() -> Calibration {
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
    pub(super) fn of(view: &View) -> Calibration {
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
