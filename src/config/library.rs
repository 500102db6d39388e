//! A `[[sequence]]` entry as a file has it: `actions` and exactly one of
//! `mode` (an arm or pointer mode, or `drag`), `key` (a chord such as
//! `ctrl+alt+t`), `click` (`left`, `right`, `double`) or `event` (a home
//! event's name). Each value is checked where it is read, so its error
//! names its key (`sequence #3.key`); the entry as a whole says when it
//! has none or several.

use std::marker::PhantomData;

use serde::de::{Deserializer, Error, Visitor};
use serde::ser::SerializeMap;
use serde::{Deserialize, Serialize, Serializer};

use crate::control::mode::Mode;
use crate::control::selection::SequenceEntry;
use crate::control::sequence::Sequence;
use crate::control::target::{Chord, Click, DRAG, HomeEvent, Target};

/// The keys of an entry that say what it does; an entry has one.
pub(super) const TARGET_KEYS: [&str; 4] = ["mode", "key", "click", "event"];

/// One library entry, read and written in the file's form.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct LibraryEntry(pub(crate) SequenceEntry);

impl Serialize for LibraryEntry {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let entry = &self.0;
        let mut map = serializer.serialize_map(Some(2))?;
        map.serialize_entry("actions", &entry.actions)?;
        match entry.target {
            Target::Mode(mode) => map.serialize_entry("mode", mode.name())?,
            Target::Drag => map.serialize_entry("mode", DRAG)?,
            Target::Key(chord) => map.serialize_entry("key", &chord.to_string())?,
            Target::Click(click) => map.serialize_entry("click", click.name())?,
            Target::Home(event) => map.serialize_entry("event", event.as_str())?,
        }
        map.end()
    }
}

/// The entry as written, each value already checked.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Written {
    actions: Sequence,
    mode: Option<ModeChoice>,
    key: Option<ChordText>,
    click: Option<ClickName>,
    event: Option<EventName>,
}

impl<'de> Deserialize<'de> for LibraryEntry {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let w = Written::deserialize(deserializer)?;
        let targets: Vec<Target> = [
            w.mode.map(|m| m.0),
            w.key.map(|k| Target::Key(k.0)),
            w.click.map(|c| Target::Click(c.0)),
            w.event.map(|e| Target::Home(e.0)),
        ]
        .into_iter()
        .flatten()
        .collect();
        match targets.as_slice() {
            [target] => Ok(LibraryEntry(SequenceEntry {
                actions: w.actions,
                target: *target,
            })),
            [] => Err(D::Error::custom(format!(
                "says nothing to do: give one of {}",
                keys_list()
            ))),
            _ => Err(D::Error::custom(format!(
                "gives {} things to do: give exactly one of {}",
                targets.len(),
                keys_list()
            ))),
        }
    }
}

/// `mode`, `key`, `click` or `event`.
fn keys_list() -> String {
    let quoted: Vec<String> = TARGET_KEYS.iter().map(|k| format!("`{k}`")).collect();
    quoted.join(", ")
}

/// A `mode` value: an arm or pointer mode, or `drag`.
struct ModeChoice(Target);

impl<'de> Deserialize<'de> for ModeChoice {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let name = String::deserialize(deserializer)?;
        if name == DRAG {
            return Ok(ModeChoice(Target::Drag));
        }
        Mode::from_name(&name)
            .map(|mode| ModeChoice(Target::Mode(mode)))
            .ok_or_else(|| {
                let names: Vec<&str> = Mode::EVERY.iter().map(|m| m.name()).chain([DRAG]).collect();
                D::Error::custom(format!(
                    "{name:?} is not a mode (known: {})",
                    names.join(", ")
                ))
            })
    }
}

/// A `key` value: a chord the virtual keyboard can type.
struct ChordText(Chord);

impl<'de> Deserialize<'de> for ChordText {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let text = String::deserialize(deserializer)?;
        Chord::parse(&text)
            .map(ChordText)
            .map_err(|e| D::Error::custom(format!("{text:?} cannot be typed: {e}")))
    }
}

/// A `click` value.
struct ClickName(Click);

impl<'de> Deserialize<'de> for ClickName {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_str(ClickVisitor(PhantomData))
    }
}

struct ClickVisitor(PhantomData<ClickName>);

impl Visitor<'_> for ClickVisitor {
    type Value = ClickName;

    fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("a string")
    }

    fn visit_str<E: Error>(self, name: &str) -> Result<ClickName, E> {
        Click::from_name(name).map(ClickName).ok_or_else(|| {
            E::custom(format!(
                "{name:?} is not a click (known: left, right, double)"
            ))
        })
    }
}

/// An `event` value: a home event's name.
struct EventName(HomeEvent);

impl<'de> Deserialize<'de> for EventName {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let name = String::deserialize(deserializer)?;
        HomeEvent::new(&name).map(EventName).ok_or_else(|| {
            D::Error::custom(format!(
                "{name:?} is not an event name: lower-case letters, digits and `_`, at most {} characters (e.g. \"lights_toggle\")",
                crate::control::target::MAX_EVENT_NAME
            ))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Result<SequenceEntry, String> {
        toml::from_str::<LibraryEntry>(text)
            .map(|e| e.0)
            .map_err(|e| e.message().to_string())
    }

    #[test]
    fn each_kind_of_entry_reads_and_writes_back() {
        for text in [
            "actions = [-1, -1]\nmode = \"translate_x\"\n",
            "actions = [1]\nmode = \"drag\"\n",
            "actions = [1, 2]\nmode = \"pointer_y\"\n",
            "actions = [-2]\nkey = \"ctrl+alt+t\"\n",
            "actions = [2]\nclick = \"double\"\n",
            "actions = [2, 2]\nevent = \"lights_toggle\"\n",
        ] {
            let entry = read(text).unwrap();
            assert_eq!(toml::to_string(&LibraryEntry(entry)).unwrap(), text);
        }
    }

    #[test]
    fn an_entry_does_exactly_one_thing() {
        assert_eq!(
            read("actions = [1]\nmode = \"fingers\"\nclick = \"left\""),
            Err("gives 2 things to do: give exactly one of `mode`, `key`, `click`, `event`".into())
        );
        assert_eq!(
            read("actions = [1]"),
            Err("says nothing to do: give one of `mode`, `key`, `click`, `event`".into())
        );
        assert!(
            read("actions = [1]\nkey = \"ctrl+hyper\"")
                .unwrap_err()
                .contains("`hyper` is not a key")
        );
        assert!(
            read("actions = [1]\nevent = \"Lights On\"")
                .unwrap_err()
                .contains("is not an event name")
        );
    }
}
