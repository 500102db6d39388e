//! Settings chosen by name (a mode, an interface, a format) or written as
//! the paper's action codes, read through serde with messages that list
//! the choices: `"fly" is not a mode (known: translate_x, …)`.

use std::marker::PhantomData;

use serde::de::{Deserialize, Deserializer, Error, Visitor};

use crate::arm::settings::Ros2Message;
use crate::control::action::{Action, MAX_SEQUENCE_LEN};
use crate::control::gesture::name::{GestureName, MAX_GESTURE_NAME};
use crate::control::head::TiltAxis;
use crate::control::mode::Mode;
use crate::control::selection::Interface;
use crate::control::sequence::Sequence;
use crate::control::token::Token;
use crate::sensor::settings::{EvdevInput, SerialFormat};

/// A setting whose value is one of a few names.
trait Named: Copy + 'static {
    /// Every choice, in the order a message lists them.
    const ALL: &'static [Self];
    /// What one choice is, for a message ("a mode").
    const WHAT: &'static str;
    /// The name in the file.
    fn config_name(self) -> &'static str;
}

/// Implements [`Named`] and `Deserialize` for a type with `ALL` and `name`.
macro_rules! named {
    ($type:ty, $what:literal) => {
        impl Named for $type {
            const ALL: &'static [Self] = &<$type>::ALL;
            const WHAT: &'static str = $what;
            fn config_name(self) -> &'static str {
                self.name()
            }
        }

        impl<'de> Deserialize<'de> for $type {
            fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
                deserializer.deserialize_str(ByName(PhantomData))
            }
        }
    };
}

named!(Mode, "a mode");
named!(Interface, "an interface");
named!(EvdevInput, "an input");
named!(SerialFormat, "a format");
named!(Ros2Message, "a message");
named!(TiltAxis, "a tilt axis");

/// Reads a [`Named`] value from its name.
struct ByName<T>(PhantomData<T>);

impl<T: Named> Visitor<'_> for ByName<T> {
    type Value = T;

    fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("a string")
    }

    fn visit_str<E: Error>(self, name: &str) -> Result<T, E> {
        T::ALL
            .iter()
            .copied()
            .find(|choice| choice.config_name() == name)
            .ok_or_else(|| E::custom(not_a_choice::<T>(name)))
    }
}

/// The message for a name that is none of `T`'s.
fn not_a_choice<T: Named>(name: &str) -> String {
    let names: Vec<&str> = T::ALL.iter().map(|choice| choice.config_name()).collect();
    match names.as_slice() {
        [one, other] => format!("{name:?} is not `{one}` or `{other}`"),
        _ => format!("{name:?} is not {} (known: {})", T::WHAT, names.join(", ")),
    }
}

/// A sequence is written as its list of tokens: paper codes for breaths,
/// gesture names for gestures, e.g. `[1, 2, -1]` or `["nod", -1]`.
impl<'de> Deserialize<'de> for Sequence {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let written = Vec::<WrittenToken>::deserialize(deserializer)?;
        tokens(&written).map_err(D::Error::custom)
    }
}

/// One token as a file has it.
#[derive(serde::Deserialize)]
#[serde(untagged)]
enum WrittenToken {
    Code(i64),
    Name(String),
}

/// The tokens written: at least one, at most [`MAX_SEQUENCE_LEN`], each a
/// paper code or a gesture's name.
fn tokens(written: &[WrittenToken]) -> Result<Sequence, String> {
    if written.is_empty() {
        return Err("must hold at least one action".into());
    }
    if written.len() > MAX_SEQUENCE_LEN {
        return Err(format!(
            "{} actions, at most {MAX_SEQUENCE_LEN} allowed",
            written.len()
        ));
    }
    let read = |w: &WrittenToken| match w {
        WrittenToken::Code(code) => Action::from_code(*code).map(Token::Breath),
        WrittenToken::Name(name) => GestureName::new(name).map(Token::Gesture),
    };
    let bad_codes: Vec<String> = written
        .iter()
        .filter(|w| matches!(w, WrittenToken::Code(_)) && read(w).is_none())
        .filter_map(|w| match w {
            WrittenToken::Code(code) => Some(code.to_string()),
            WrittenToken::Name(_) => None,
        })
        .collect();
    let bad_names: Vec<String> = written
        .iter()
        .filter_map(|w| match w {
            WrittenToken::Name(name) if GestureName::new(name).is_none() => {
                Some(format!("{name:?}"))
            }
            _ => None,
        })
        .collect();
    let mut problems = Vec::new();
    if !bad_codes.is_empty() {
        problems.push(format!(
            "{} not an action (1 = short sip, 2 = long sip, -1 = short puff, -2 = long puff)",
            bad_codes.join(", ")
        ));
    }
    if !bad_names.is_empty() {
        problems.push(format!(
            "{} not a gesture name (lower-case letters, digits and _, starting with a letter, at most {MAX_GESTURE_NAME})",
            bad_names.join(", ")
        ));
    }
    if !problems.is_empty() {
        return Err(problems.join("; "));
    }
    Sequence::from_tokens(written.iter().filter_map(read)).ok_or_else(|| "too many actions".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read<T: for<'de> Deserialize<'de>>(text: &str) -> Result<T, String> {
        toml::Value::from(text)
            .try_into()
            .map_err(|e: toml::de::Error| e.message().to_string())
    }

    #[test]
    fn a_name_reads_as_its_choice_and_others_list_the_choices() {
        assert_eq!(read::<Mode>("save_point"), Ok(Mode::SavePoint));
        assert_eq!(
            read::<Ros2Message>("pose_velocity"),
            Ok(Ros2Message::PoseVelocity)
        );
        assert_eq!(
            read::<Interface>("scan"),
            Err("\"scan\" is not `asp` or `bsp`".into())
        );
        assert_eq!(
            read::<SerialFormat>("modbus"),
            Err(
                "\"modbus\" is not a format (known: volts, counts, flipmouse, lipsync, imu)".into()
            )
        );
        let wrong = toml::Value::Integer(3)
            .try_into::<EvdevInput>()
            .unwrap_err();
        assert_eq!(
            wrong.message(),
            "invalid type: integer `3`, expected a string"
        );
    }

    #[test]
    fn actions_are_paper_codes_and_every_bad_one_is_named() {
        let codes = |text: &str| -> Result<Vec<i8>, String> {
            let value: toml::Value = toml::from_str::<toml::Table>(&format!("a = {text}"))
                .unwrap()
                .remove("a")
                .unwrap();
            value
                .try_into::<Sequence>()
                .map(|seq| {
                    seq.actions()
                        .unwrap()
                        .as_slice()
                        .iter()
                        .map(|a| a.code())
                        .collect()
                })
                .map_err(|e| e.message().to_string())
        };
        assert_eq!(codes("[1, 2, -1, -2]"), Ok(vec![1, 2, -1, -2]));
        assert_eq!(codes("[]"), Err("must hold at least one action".into()));
        assert!(
            codes("[1, 3, 7]")
                .unwrap_err()
                .starts_with("3, 7 not an action")
        );
        let long = vec!["1"; MAX_SEQUENCE_LEN + 1].join(", ");
        assert_eq!(
            codes(&format!("[{long}]")),
            Err(format!("17 actions, at most {MAX_SEQUENCE_LEN} allowed"))
        );
    }
}
