//! A gesture's name as the core carries it: inline and `Copy`, so a
//! recognised gesture can be a token of a sequence and an event without
//! touching the heap. The names come from the person's gesture set.

use std::fmt;

use serde::{Serialize, Serializer};

/// Longest gesture name, bytes.
pub const MAX_GESTURE_NAME: usize = 15;

/// A gesture's name: lower-case letters, digits and `_`, starting with a
/// letter, at most [`MAX_GESTURE_NAME`] bytes (`nod`, `tilt_left`).
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct GestureName {
    name: [u8; MAX_GESTURE_NAME],
    len: u8,
}

impl GestureName {
    /// The name `name`, if it is a valid one.
    pub fn new(name: &str) -> Option<GestureName> {
        let valid = name.len() <= MAX_GESTURE_NAME
            && name.bytes().next().is_some_and(|b| b.is_ascii_lowercase())
            && name
                .bytes()
                .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_');
        if !valid {
            return None;
        }
        let mut out = GestureName {
            name: [0; MAX_GESTURE_NAME],
            len: 0,
        };
        for (slot, byte) in out.name.iter_mut().zip(name.bytes()) {
            *slot = byte;
            out.len += 1;
        }
        Some(out)
    }

    /// The name.
    pub fn as_str(&self) -> &str {
        // Only ASCII is ever stored (`new` checks).
        std::str::from_utf8(self.name.get(..usize::from(self.len)).unwrap_or(&[])).unwrap_or("")
    }
}

impl fmt::Display for GestureName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl fmt::Debug for GestureName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}", self.as_str())
    }
}

impl Serialize for GestureName {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_short_lower_case_words() {
        assert_eq!(GestureName::new("tilt_left").unwrap().as_str(), "tilt_left");
        assert_eq!(GestureName::new("nod2").unwrap().to_string(), "nod2");
        for bad in ["", "Nod", "2nod", "_nod", "tilt left", "sixteen_letters_"] {
            assert_eq!(GestureName::new(bad), None, "{bad}");
        }
        assert!(GestureName::new("fifteen_letter_").is_some());
    }
}
