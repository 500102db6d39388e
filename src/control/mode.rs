//! The vocabulary of modes: the paper's nine arm modes, which one the
//! interface is in, which way the user asks to move, and the breath held
//! right now.

use serde::Serialize;

use crate::control::action::Breath;

/// One of the paper's nine arm modes. Serialized by its config name.
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
}

impl Mode {
    /// All modes, in the paper's order.
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
        }
    }

    /// The mode with this config name.
    pub fn from_name(name: &str) -> Option<Mode> {
        Mode::ALL.into_iter().find(|m| m.name() == name)
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
        for mode in Mode::ALL {
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
