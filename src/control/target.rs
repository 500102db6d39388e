//! What a library entry does when its sequence matches: enter a mode (the
//! arm's nine, or a pointer mode), hold the pointer's button for a drag,
//! or fire an action at once — a key chord, a click, a home event.
//! Everything here is `Copy` and inline, so the core carries it without
//! touching the heap.

use std::fmt;

use serde::{Serialize, Serializer};

use crate::control::keys;
use crate::control::mode::Mode;

/// Most keys in one chord (`ctrl+alt+shift+t` is four).
pub const MAX_CHORD_KEYS: usize = 4;
/// Longest home event name, bytes.
pub const MAX_EVENT_NAME: usize = 32;

/// What a sequence selects or fires.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Target {
    /// A mode: puff and sip move one way and the other while held.
    Mode(Mode),
    /// The pointer's left button goes down and stays down while the
    /// pointer moves; the next selection of anything but a pointer mode
    /// (or `drag` again) lets it go.
    Drag,
    /// A key chord, pressed and released at once.
    Key(Chord),
    /// A pointer click.
    Click(Click),
    /// A named home event, sent to home automation.
    Home(HomeEvent),
}

impl Target {
    /// The mode entered, if this selects one.
    pub const fn mode(self) -> Option<Mode> {
        match self {
            Target::Mode(mode) => Some(mode),
            _ => None,
        }
    }

    /// How the display and `config` show it: "translate_x", "Ctrl+Alt+T",
    /// "Click: left", "Home: lights_toggle", "Drag".
    pub fn label(&self) -> String {
        match self {
            Target::Mode(mode) => mode.name().to_owned(),
            Target::Drag => "Drag".to_owned(),
            Target::Key(chord) => chord.label(),
            Target::Click(click) => format!("Click: {}", click.name()),
            Target::Home(event) => format!("Home: {}", event.as_str()),
        }
    }

    /// What it does, for people: "forward (puff) / backward (sip)",
    /// "types Ctrl+Alt+T", "sends the home event lights_toggle".
    pub fn description(&self) -> String {
        match self {
            Target::Mode(mode) => mode.description().to_owned(),
            Target::Drag => {
                "holds the left button while the pointer moves (drag; again to let go)".to_owned()
            }
            Target::Key(chord) => format!("types {}", chord.label()),
            Target::Click(Click::Double) => "double-clicks".to_owned(),
            Target::Click(click) => format!("clicks the {} button", click.name()),
            Target::Home(event) => format!("sends the home event {}", event.as_str()),
        }
    }
}

/// A target is written as the key of its library entry and its value:
/// `"mode":"translate_x"`, `"key":"ctrl+alt+t"`, `"click":"left"`,
/// `"home_event":"lights_toggle"` (`event` names the log's event kind),
/// `"mode":"drag"`.
impl Serialize for Target {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut map = serializer.serialize_map(Some(1))?;
        match self {
            Target::Mode(mode) => map.serialize_entry("mode", mode.name())?,
            Target::Drag => map.serialize_entry("mode", DRAG)?,
            Target::Key(chord) => map.serialize_entry("key", &chord.to_string())?,
            Target::Click(click) => map.serialize_entry("click", click.name())?,
            Target::Home(event) => map.serialize_entry("home_event", event.as_str())?,
        }
        map.end()
    }
}

/// The config name of the drag mode.
pub const DRAG: &str = "drag";

/// A pointer click.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Click {
    /// The left button.
    Left,
    /// The right button.
    Right,
    /// Two left clicks.
    Double,
}

impl Click {
    /// All clicks.
    pub const ALL: [Click; 3] = [Click::Left, Click::Right, Click::Double];

    /// `left`, `right` or `double`.
    pub const fn name(self) -> &'static str {
        match self {
            Click::Left => "left",
            Click::Right => "right",
            Click::Double => "double",
        }
    }

    /// The click with this config name.
    pub fn from_name(name: &str) -> Option<Click> {
        Click::ALL.into_iter().find(|c| c.name() == name)
    }
}

/// Up to [`MAX_CHORD_KEYS`] keys (Linux key codes), pressed in order and
/// released in reverse order. Inline and `Copy`.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct Chord {
    codes: [u16; MAX_CHORD_KEYS],
    len: u8,
}

/// Why a chord cannot be typed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ChordError {
    /// A name that is no key of [`keys::KEYS`].
    UnknownKey(String),
    /// More keys than [`MAX_CHORD_KEYS`].
    TooManyKeys(usize),
    /// The same key twice.
    Repeated(String),
    /// Only modifiers, or nothing.
    NoKey,
}

impl fmt::Display for ChordError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ChordError::UnknownKey(name) => write!(
                f,
                "`{name}` is not a key the virtual keyboard can type (keys: a–z, 0–9, f1–f12, enter, space, tab, esc, arrows, media keys…; modifiers ctrl, shift, alt, super, altgr)"
            ),
            ChordError::TooManyKeys(n) => {
                write!(f, "{n} keys: a chord holds at most {MAX_CHORD_KEYS}")
            }
            ChordError::Repeated(name) => write!(f, "`{name}` appears twice"),
            ChordError::NoKey => f.write_str("a chord needs one key that is not a modifier"),
        }
    }
}

impl Chord {
    /// Parses `ctrl+alt+t`: key names joined by `+`, modifiers first or
    /// not (they are pressed first either way), one non-modifier at least.
    pub fn parse(text: &str) -> Result<Chord, ChordError> {
        let names: Vec<&str> = text.split('+').map(str::trim).collect();
        if names.len() > MAX_CHORD_KEYS {
            return Err(ChordError::TooManyKeys(names.len()));
        }
        let mut found = Vec::with_capacity(names.len());
        for name in &names {
            let key =
                keys::by_name(name).ok_or_else(|| ChordError::UnknownKey(name.to_string()))?;
            if found.iter().any(|k: &keys::Key| k.code == key.code) {
                return Err(ChordError::Repeated(name.to_string()));
            }
            found.push(key);
        }
        if found.iter().all(|k| k.modifier) {
            return Err(ChordError::NoKey);
        }
        // Modifiers first, each group in the order written.
        found.sort_by_key(|k| !k.modifier);
        let mut chord = Chord {
            codes: [0; MAX_CHORD_KEYS],
            len: 0,
        };
        for (slot, key) in chord.codes.iter_mut().zip(&found) {
            *slot = key.code;
            chord.len += 1;
        }
        Ok(chord)
    }

    /// The key codes in the order they are pressed.
    pub fn codes(&self) -> &[u16] {
        self.codes.get(..usize::from(self.len)).unwrap_or(&[])
    }

    /// "Ctrl+Alt+T".
    pub fn label(&self) -> String {
        self.codes()
            .iter()
            .map(|&code| keys::by_code(code).map_or("?", |k| k.label))
            .collect::<Vec<_>>()
            .join("+")
    }
}

/// Written as its config form, `ctrl+alt+t`.
impl fmt::Display for Chord {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, &code) in self.codes().iter().enumerate() {
            if i > 0 {
                f.write_str("+")?;
            }
            f.write_str(keys::by_code(code).map_or("?", |k| k.name))?;
        }
        Ok(())
    }
}

impl fmt::Debug for Chord {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Chord({self})")
    }
}

/// A home event's name: lower-case letters, digits and `_`, at most
/// [`MAX_EVENT_NAME`] bytes. Inline and `Copy`.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct HomeEvent {
    name: [u8; MAX_EVENT_NAME],
    len: u8,
}

impl HomeEvent {
    /// The event named `name`, if it is a valid name.
    pub fn new(name: &str) -> Option<HomeEvent> {
        let valid = !name.is_empty()
            && name.len() <= MAX_EVENT_NAME
            && name
                .bytes()
                .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_');
        if !valid {
            return None;
        }
        let mut event = HomeEvent {
            name: [0; MAX_EVENT_NAME],
            len: 0,
        };
        for (slot, byte) in event.name.iter_mut().zip(name.bytes()) {
            *slot = byte;
            event.len += 1;
        }
        Some(event)
    }

    /// The name.
    pub fn as_str(&self) -> &str {
        // Only ASCII is ever stored (`new` checks).
        std::str::from_utf8(self.name.get(..usize::from(self.len)).unwrap_or(&[])).unwrap_or("")
    }
}

impl fmt::Debug for HomeEvent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "HomeEvent({})", self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chords_press_modifiers_first() {
        let chord = Chord::parse("t+ctrl+alt").unwrap();
        assert_eq!(chord.codes(), &[29, 56, 20]);
        assert_eq!(chord.to_string(), "ctrl+alt+t");
        assert_eq!(chord.label(), "Ctrl+Alt+T");
        assert_eq!(Chord::parse("space").unwrap().codes(), &[57]);
    }

    #[test]
    fn chords_that_cannot_be_typed() {
        assert_eq!(
            Chord::parse("ctrl+hyper"),
            Err(ChordError::UnknownKey("hyper".into()))
        );
        assert_eq!(Chord::parse("ctrl+shift"), Err(ChordError::NoKey));
        assert_eq!(
            Chord::parse("ctrl+t+ctrl"),
            Err(ChordError::Repeated("ctrl".into()))
        );
        assert_eq!(
            Chord::parse("ctrl+alt+shift+super+t"),
            Err(ChordError::TooManyKeys(5))
        );
        assert_eq!(Chord::parse(""), Err(ChordError::UnknownKey("".into())));
    }

    #[test]
    fn home_event_names() {
        assert_eq!(
            HomeEvent::new("lights_toggle").unwrap().as_str(),
            "lights_toggle"
        );
        assert!(HomeEvent::new("Lights").is_none());
        assert!(HomeEvent::new("a b").is_none());
        assert!(HomeEvent::new("").is_none());
        assert!(HomeEvent::new(&"x".repeat(33)).is_none());
    }

    #[test]
    fn targets_serialize_as_their_library_key() {
        let json = |t: Target| serde_json::to_string(&t).unwrap();
        assert_eq!(json(Target::Mode(Mode::Fingers)), r#"{"mode":"fingers"}"#);
        assert_eq!(json(Target::Drag), r#"{"mode":"drag"}"#);
        assert_eq!(
            json(Target::Key(Chord::parse("ctrl+alt+t").unwrap())),
            r#"{"key":"ctrl+alt+t"}"#
        );
        assert_eq!(json(Target::Click(Click::Double)), r#"{"click":"double"}"#);
        assert_eq!(
            json(Target::Home(HomeEvent::new("lights_toggle").unwrap())),
            r#"{"home_event":"lights_toggle"}"#
        );
    }
}
