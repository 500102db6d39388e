//! The words the display uses for what the core does: a library entry's
//! id and label, a mode's name, the news of a fired action, the motion
//! and its arrow, a workspace limit, and how the person's sensors make a
//! sequence and move.

use crate::control::core_config::CoreConfig;
use crate::control::head::TiltAxis;
use crate::control::mode::{Direction, Mode};
use crate::control::motion::workspace::Boundary;
use crate::control::target::Target;

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
pub(super) fn home_label(name: &str) -> String {
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
pub(super) fn fired_words(target: &Target) -> String {
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
pub(super) fn motion_shown(mode: Mode, direction: Direction) -> (&'static str, &'static str) {
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
pub(super) fn limit_words(boundary: Boundary) -> &'static str {
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

/// How a sequence is made with `config`'s sensors: `breathe`, `make`
/// (gestures alone) or `breathe or move`.
pub fn sequence_verb(config: &CoreConfig) -> &'static str {
    match (config.has_breath_sensor(), config.gestures().is_some()) {
        (true, true) => "breathe or move",
        (false, true) => "make",
        _ => "breathe",
    }
}

/// What moves in a command mode with `config`'s sensors: a breath, the
/// head's tilt (unless `[gestures] tilt = "off"`), or either.
pub fn movers(config: &CoreConfig) -> &'static str {
    let head = config.gestures().is_some() && config.head().tilt != TiltAxis::Off;
    match (config.has_breath_sensor(), head) {
        (true, true) => "puff, sip or a head tilt move",
        (false, true) => "tilting your head moves",
        (false, false) if config.gestures().is_some() => "the head's tilt is off: nothing moves",
        _ => "puff and sip move",
    }
}
