//! The vocabulary of modes: the paper's nine arm modes and the pointer's
//! three, which one the interface is in, which way the user asks to move,
//! and the breath held right now.

use serde::Serialize;

use crate::control::action::Breath;

/// A mode: one of the paper's nine arm modes, or one of the computer's
/// pointer modes. In each, a held puff moves one way and a held sip the
/// other. Serialized by its config name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// Forward (puff) / backward (sip).
    TranslateX,
    /// Left (puff) / right (sip).
    TranslateY,
    /// Up (puff) / down (sip).
    TranslateZ,
    /// Rotation about the tool's x axis.
    RotateX,
    /// Rotation about the tool's y axis.
    RotateY,
    /// Rotation about the tool's z axis.
    RotateZ,
    /// Open (puff) / close (sip) the fingers.
    Fingers,
    /// Store the current pose.
    SavePoint,
    /// Move to the stored pose.
    GotoPoint,
    /// The pointer right (puff) / left (sip).
    PointerX,
    /// The pointer up (puff) / down (sip).
    PointerY,
    /// Scroll up (puff) / down (sip).
    Scroll,
}

impl Mode {
    /// The pointer's modes.
    pub const POINTER: [Mode; 3] = [Mode::PointerX, Mode::PointerY, Mode::Scroll];

    /// Every mode, the arm's then the pointer's: the names a library
    /// entry's `mode` may take.
    pub const EVERY: [Mode; 12] = [
        Mode::TranslateX,
        Mode::TranslateY,
        Mode::TranslateZ,
        Mode::RotateX,
        Mode::RotateY,
        Mode::RotateZ,
        Mode::Fingers,
        Mode::SavePoint,
        Mode::GotoPoint,
        Mode::PointerX,
        Mode::PointerY,
        Mode::Scroll,
    ];

    /// The paper's nine arm modes, in its order.
    pub const ALL: [Mode; 9] = [
        Mode::TranslateX,
        Mode::TranslateY,
        Mode::TranslateZ,
        Mode::RotateX,
        Mode::RotateY,
        Mode::RotateZ,
        Mode::Fingers,
        Mode::SavePoint,
        Mode::GotoPoint,
    ];

    /// The name used in config files and events.
    pub const fn name(self) -> &'static str {
        match self {
            Mode::TranslateX => "translate_x",
            Mode::TranslateY => "translate_y",
            Mode::TranslateZ => "translate_z",
            Mode::RotateX => "rotate_x",
            Mode::RotateY => "rotate_y",
            Mode::RotateZ => "rotate_z",
            Mode::Fingers => "fingers",
            Mode::SavePoint => "save_point",
            Mode::GotoPoint => "goto_point",
            Mode::PointerX => "pointer_x",
            Mode::PointerY => "pointer_y",
            Mode::Scroll => "scroll",
        }
    }

    /// What puff and sip do in this mode, for people.
    pub const fn description(self) -> &'static str {
        match self {
            Mode::TranslateX => "forward (puff) / backward (sip)",
            Mode::TranslateY => "left (puff) / right (sip)",
            Mode::TranslateZ => "up (puff) / down (sip)",
            Mode::RotateX => "rotate about the tool's x axis",
            Mode::RotateY => "rotate about the tool's y axis",
            Mode::RotateZ => "rotate about the tool's z axis",
            Mode::Fingers => "open (puff) / close (sip) the fingers",
            Mode::SavePoint => "puff stores the current pose",
            Mode::GotoPoint => "hold a puff to move to the stored pose",
            Mode::PointerX => "the pointer right (puff) / left (sip)",
            Mode::PointerY => "the pointer up (puff) / down (sip)",
            Mode::Scroll => "scroll up (puff) / down (sip)",
        }
    }

    /// How the display labels it: the pointer's modes by their arrows.
    pub const fn label(self) -> &'static str {
        match self {
            Mode::PointerX => "Pointer ←→",
            Mode::PointerY => "Pointer ↑↓",
            Mode::Scroll => "Scroll ↑↓",
            _ => self.name(),
        }
    }

    /// A pointer mode (it moves the computer's pointer, not the arm).
    pub const fn is_pointer(self) -> bool {
        matches!(self, Mode::PointerX | Mode::PointerY | Mode::Scroll)
    }

    /// The mode with this config name.
    pub fn from_name(name: &str) -> Option<Mode> {
        Mode::EVERY.into_iter().find(|m| m.name() == name)
    }
}

/// Which mode the interface is in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ModeState {
    /// Waiting for a sequence; nothing moves.
    #[default]
    Detection,
    /// Puff and sip move the arm in this mode.
    Command(Mode),
}

impl ModeState {
    /// `detection` or the mode's name.
    pub const fn name(self) -> &'static str {
        match self {
            ModeState::Detection => "detection",
            ModeState::Command(mode) => mode.name(),
        }
    }
}

/// Which way the user asks the arm to move in command mode: a puff is the
/// mode's positive direction, a sip its negative one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Direction {
    /// Nothing asked: no breath held, or detection mode.
    #[default]
    Still,
    /// Puff: forward, left, up, open the fingers, positive rotation.
    Positive,
    /// Sip: backward, right, down, close the fingers, negative rotation.
    Negative,
}

impl Direction {
    /// +1, −1 or 0.
    pub const fn sign(self) -> f64 {
        match self {
            Direction::Still => 0.0,
            Direction::Positive => 1.0,
            Direction::Negative => -1.0,
        }
    }

    /// The direction a breath asks for.
    pub const fn of(breath: Breath) -> Direction {
        match breath {
            Breath::Puff => Direction::Positive,
            Breath::Sip => Direction::Negative,
        }
    }
}

/// What the user is doing right now.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Held {
    /// The breath held, if any.
    pub breath: Option<Breath>,
    /// How far past its threshold the signal is, in volts (0 when nothing is
    /// held).
    pub strength_volts: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for mode in Mode::EVERY {
            assert_eq!(Mode::from_name(mode.name()), Some(mode));
            assert_eq!(
                serde_json::to_value(mode).unwrap(),
                serde_json::json!(mode.name())
            );
        }
        assert_eq!(Mode::from_name("translate"), None);
    }

    #[test]
    fn puff_is_positive_and_sip_negative() {
        assert_eq!(Direction::of(Breath::Puff).sign(), 1.0);
        assert_eq!(Direction::of(Breath::Sip).sign(), -1.0);
        assert_eq!(Direction::Still.sign(), 0.0);
    }
}
