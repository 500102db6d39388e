//! The detection/command mode machine of the paper's Fig. 1.
//!
//! Detection mode: no motion; a match enters command mode for the matched
//! mode. Command mode: puff = positive direction, sip = negative, motion only
//! while the breath is held (hold-to-run); no breath for
//! `inactivity_timeout_ms` returns to detection mode, and so does a sensor
//! fault (motion never resumes by itself after a fault).

use serde::Serialize;

use crate::control::Tick;
use crate::control::action::Breath;
use crate::control::mode::{Direction, Held, Mode, ModeState};

/// Command mode settings (`[command]` in the config file).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CommandConfig {
    /// No breath for this long (from the match or the end of the last breath)
    /// returns to detection mode.
    pub inactivity_timeout_ms: u32,
    /// Beyond the paper: in command mode a breath moves the arm only once
    /// it has been held this long; shorter breaths go to the sequence
    /// matcher, and a completed sequence switches mode at once (no wait for
    /// the inactivity timeout, no motion). 0 = off (the paper: every breath
    /// in command mode moves the arm).
    pub motion_onset_ms: u32,
}

impl Default for CommandConfig {
    fn default() -> Self {
        CommandConfig {
            inactivity_timeout_ms: 2000,
            motion_onset_ms: 0,
        }
    }
}

/// Why the machine went back to detection mode. Serialized by its name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DetectionReason {
    /// No breath for `inactivity_timeout_ms`.
    Inactivity,
    /// The sensor signal faulted.
    Fault,
    /// A stop was requested (SIGINT, end of run).
    Stop,
}

/// The command for the motion layer on one tick. `Copy`, RT-safe.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ModeOutput {
    /// Current mode.
    pub state: ModeState,
    /// Puff, sip or nothing; always [`Direction::Still`] in detection mode.
    pub direction: Direction,
    /// Volts past the threshold while a breath is held, else 0.
    pub strength_volts: f64,
    /// When the head's tilt moves: how far past its dead zone, 0–1 of
    /// full scale (the speed is always proportional to it).
    pub speed_fraction: Option<f64>,
}

/// The mode machine. `step` is RT-safe.
#[derive(Debug, Clone)]
pub struct ModeMachine {
    config: CommandConfig,
    state: ModeState,
    last_activity: Tick,
    /// A breath was already held when the mode was entered (a sip right
    /// after a puff, say): it must be released before anything moves.
    await_release: bool,
    /// Stopping: back to detection mode for good.
    stopping: bool,
    /// The breath held in command mode and the tick it was first seen.
    held_since: Option<(Breath, Tick)>,
    /// The current (or last) breath in command mode moved the arm.
    moved: bool,
}

impl ModeMachine {
    /// Starts in detection mode, no motion.
    pub fn new(config: &CommandConfig) -> Self {
        ModeMachine {
            config: *config,
            state: ModeState::Detection,
            last_activity: 0,
            await_release: false,
            stopping: false,
            held_since: None,
            moved: false,
        }
    }

    /// With `motion_onset_ms`: the burst that just ended in command mode was
    /// too short to move the arm, so it belongs to a selection. Read before
    /// [`ModeMachine::step`] on the burst's tick. RT-safe.
    pub fn selects_in_command_mode(&self) -> bool {
        self.config.motion_onset_ms > 0
            && matches!(self.state, ModeState::Command(_))
            && !self.moved
    }

    /// With `motion_onset_ms`: the burst that just ended in command mode
    /// moved the arm (a selection in progress is void). RT-safe.
    pub fn moved_in_command_mode(&self) -> bool {
        self.config.motion_onset_ms > 0 && matches!(self.state, ModeState::Command(_)) && self.moved
    }

    /// From the next tick on: detection mode, no mode is entered again.
    /// RT-safe.
    pub fn stop(&mut self) {
        self.stopping = true;
    }

    /// A stop was asked for ([`ModeMachine::stop`]).
    pub fn stopping(&self) -> bool {
        self.stopping
    }

    /// The current mode.
    pub fn state(&self) -> ModeState {
        self.state
    }

    /// In command mode: the tick it returns to selection if nothing more
    /// is breathed. RT-safe.
    pub fn returns_at(&self) -> Option<Tick> {
        matches!(self.state, ModeState::Command(_)).then(|| {
            self.last_activity
                .saturating_add(self.config.inactivity_timeout_ms.into())
        })
    }

    /// One tick: `matched` is the mode the matcher selected on this tick.
    /// Returns the command and, if it happened, why the machine went back
    /// to detection mode. RT-safe.
    pub fn step(
        &mut self,
        now: Tick,
        held: Held,
        matched: Option<Mode>,
        faulted: bool,
    ) -> (ModeOutput, Option<DetectionReason>) {
        let mut output = ModeOutput::default();
        let mut left = None;
        match self.state {
            ModeState::Detection => {
                if let Some(mode) = matched.filter(|_| !self.stopping) {
                    self.state = ModeState::Command(mode);
                    self.last_activity = now;
                    self.await_release = held.breath.is_some();
                }
            }
            ModeState::Command(_) => {
                if self.stopping {
                    left = Some(DetectionReason::Stop);
                } else if faulted {
                    left = Some(DetectionReason::Fault);
                } else if let Some(mode) = matched {
                    // A selection completed in command mode (motion onset):
                    // the new mode at once.
                    self.state = ModeState::Command(mode);
                    self.last_activity = now;
                    self.await_release = held.breath.is_some();
                    self.held_since = None;
                } else if let Some(breath) = held.breath {
                    self.last_activity = now;
                    let since = match self.held_since {
                        Some((b, since)) if b == breath => since,
                        _ => {
                            self.held_since = Some((breath, now));
                            self.moved = false;
                            now
                        }
                    };
                    let held_ms = now.saturating_sub(since) + 1;
                    if !self.await_release && held_ms >= u64::from(self.config.motion_onset_ms) {
                        output.direction = Direction::of(breath);
                        output.strength_volts = held.strength_volts;
                        self.moved = true;
                    }
                } else {
                    self.held_since = None;
                    self.await_release = false;
                    if now.saturating_sub(self.last_activity)
                        >= u64::from(self.config.inactivity_timeout_ms)
                    {
                        left = Some(DetectionReason::Inactivity);
                    }
                }
                if left.is_some() {
                    self.state = ModeState::Detection;
                }
            }
        }
        output.state = self.state;
        (output, left)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn machine(inactivity_timeout_ms: u32) -> ModeMachine {
        ModeMachine::new(&CommandConfig {
            inactivity_timeout_ms,
            motion_onset_ms: 0,
        })
    }

    const REST: Held = Held {
        breath: None,
        strength_volts: 0.0,
    };

    fn puff(strength: f64) -> Held {
        Held {
            breath: Some(Breath::Puff),
            strength_volts: strength,
        }
    }

    #[test]
    fn starts_in_detection_and_does_not_move() {
        let mut m = machine(2000);
        let (out, left) = m.step(0, puff(1.0), None, false);
        assert_eq!(out, ModeOutput::default());
        assert_eq!(left, None);
    }

    #[test]
    fn hold_to_run_and_inactivity() {
        let mut m = machine(2000);
        let (out, _) = m.step(100, REST, Some(Mode::TranslateZ), false);
        assert_eq!(out.state, ModeState::Command(Mode::TranslateZ));
        assert_eq!(out.direction, Direction::Still);

        let (out, _) = m.step(500, puff(0.8), None, false);
        assert_eq!(
            (out.direction, out.strength_volts),
            (Direction::Positive, 0.8)
        );
        let sip = Held {
            breath: Some(Breath::Sip),
            strength_volts: 0.3,
        };
        assert_eq!(
            m.step(700, sip, None, false).0.direction,
            Direction::Negative
        );
        // Released at 701: still in command mode until 701 + 2000.
        assert_eq!(m.step(701, REST, None, false).0.direction, Direction::Still);
        assert_eq!(m.step(2699, REST, None, false).1, None);
        let (out, left) = m.step(2700, REST, None, false);
        assert_eq!(left, Some(DetectionReason::Inactivity));
        assert_eq!(out, ModeOutput::default());
    }

    #[test]
    fn inactivity_counts_from_the_match() {
        let mut m = machine(2000);
        m.step(100, REST, Some(Mode::Fingers), false);
        assert_eq!(m.step(2099, REST, None, false).1, None);
        assert_eq!(
            m.step(2100, REST, None, false).1,
            Some(DetectionReason::Inactivity)
        );
    }

    #[test]
    fn a_fault_returns_to_detection() {
        let mut m = machine(2000);
        m.step(100, REST, Some(Mode::RotateX), false);
        m.step(200, puff(1.0), None, false);
        let (out, left) = m.step(201, REST, None, true);
        assert_eq!(left, Some(DetectionReason::Fault));
        assert_eq!(out, ModeOutput::default());
    }

    #[test]
    fn a_stop_leaves_command_mode_for_good() {
        let mut m = machine(2000);
        m.step(100, REST, Some(Mode::TranslateX), false);
        assert_eq!(
            m.step(101, puff(1.0), None, false).0.direction,
            Direction::Positive
        );
        m.stop();
        let (out, left) = m.step(102, puff(1.0), None, false);
        assert_eq!(
            (out, left),
            (ModeOutput::default(), Some(DetectionReason::Stop))
        );
        let (out, _) = m.step(103, REST, Some(Mode::Fingers), false);
        assert_eq!(out.state, ModeState::Detection);
    }

    #[test]
    fn a_breath_held_at_the_match_must_be_released_first() {
        let mut m = machine(2000);
        let (out, _) = m.step(100, puff(1.0), Some(Mode::TranslateX), false);
        assert_eq!(out.direction, Direction::Still);
        assert_eq!(
            m.step(150, puff(1.0), None, false).0.direction,
            Direction::Still
        );
        assert_eq!(m.step(151, REST, None, false).0.direction, Direction::Still);
        assert_eq!(
            m.step(152, puff(1.0), None, false).0.direction,
            Direction::Positive
        );
        // The held breath counted as activity.
        assert_eq!(m.step(2150, REST, None, false).1, None);
    }
}
