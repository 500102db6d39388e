//! What each command writes to the device, pure and tested exactly: the
//! events and pauses of a chord, a click, a drag's button, a pointer move
//! or a release of everything, given the keys and buttons held.

use std::time::Duration;

use evdev::{EventType, KeyCode, RelativeAxisCode, SynchronizationCode};

use crate::control::output_command::OutputCommand;
use crate::control::target::Click;

/// How long a chord's keys stay down: longer than one 60 Hz frame
/// (16.7 ms), so an application that samples the keyboard once a frame
/// still sees the whole chord, and short enough to feel instant.
pub const KEY_HOLD: Duration = Duration::from_millis(20);

/// How long a click holds its button: longer than libinput's 25 ms button
/// debounce window, inside which a press and its release can be taken for
/// a bouncing switch and dropped.
pub const BUTTON_HOLD: Duration = Duration::from_millis(30);

/// Between the two clicks of a double click (first up to second down):
/// clear of the 25 ms debounce window, far inside any desktop's
/// double-click time (400–500 ms by default).
pub const DOUBLE_CLICK_GAP: Duration = Duration::from_millis(60);

/// `EV_SYN`, `EV_KEY`, `EV_REL` and `SYN_REPORT`.
pub(super) const EV_SYN: u16 = EventType::SYNCHRONIZATION.0;
pub(super) const EV_KEY: u16 = EventType::KEY.0;
pub(super) const EV_REL: u16 = EventType::RELATIVE.0;
pub(super) const SYN_REPORT: u16 = SynchronizationCode::SYN_REPORT.0;

/// The pointer's buttons: left (clicks and the drag), right, middle.
pub(super) const BTN_LEFT: u16 = KeyCode::BTN_LEFT.0;
pub(super) const BTN_RIGHT: u16 = KeyCode::BTN_RIGHT.0;
pub(super) const BTN_MIDDLE: u16 = KeyCode::BTN_MIDDLE.0;
pub(super) const BUTTONS: [u16; 3] = [BTN_LEFT, BTN_RIGHT, BTN_MIDDLE];

/// The pointer's axes.
pub(super) const REL_X: u16 = RelativeAxisCode::REL_X.0;
pub(super) const REL_Y: u16 = RelativeAxisCode::REL_Y.0;
pub(super) const REL_WHEEL: u16 = RelativeAxisCode::REL_WHEEL.0;
pub(super) const AXES: [u16; 3] = [REL_X, REL_Y, REL_WHEEL];

/// One input event: type, code, value (`struct input_event` without its
/// time, which the kernel sets when the event is written).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UinputEvent {
    /// `EV_*`.
    pub kind: u16,
    /// Key, button or axis code.
    pub code: u16,
    /// Key: 1 down, 0 up; axis: the motion.
    pub value: i32,
}

impl UinputEvent {
    /// A key or button going down (`true`) or up.
    pub const fn key(code: u16, down: bool) -> UinputEvent {
        UinputEvent {
            kind: EV_KEY,
            code,
            value: down as i32,
        }
    }

    /// Relative motion on an axis.
    pub const fn rel(code: u16, value: i32) -> UinputEvent {
        UinputEvent {
            kind: EV_REL,
            code,
            value,
        }
    }

    /// `SYN_REPORT`: the events since the last one happened together.
    pub const SYN: UinputEvent = UinputEvent {
        kind: EV_SYN,
        code: SYN_REPORT,
        value: 0,
    };
}

/// One step of what a command writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WriteStep {
    /// Write this event (a frame of them ends with [`UinputEvent::SYN`]).
    Write(UinputEvent),
    /// Wait this long before the next.
    Pause(Duration),
}

/// The keys and buttons written down and not yet up, in the order they
/// went down.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct HeldKeys {
    codes: Vec<u16>,
}

impl HeldKeys {
    /// Nothing held, with room for a chord and a drag.
    pub fn new() -> HeldKeys {
        HeldKeys {
            codes: Vec::with_capacity(8),
        }
    }

    /// `code` is down (again: no change).
    pub fn press(&mut self, code: u16) {
        if !self.contains(code) {
            self.codes.push(code);
        }
    }

    /// `code` is up.
    pub fn release(&mut self, code: u16) {
        self.codes.retain(|&c| c != code);
    }

    /// Whether `code` is down.
    pub fn contains(&self, code: u16) -> bool {
        self.codes.contains(&code)
    }

    /// Nothing is down.
    pub fn is_empty(&self) -> bool {
        self.codes.is_empty()
    }

    /// What is down, in the order it went down.
    pub fn codes(&self) -> &[u16] {
        &self.codes
    }
}

/// What `command` writes, given what is held, into `out` (cleared first;
/// its capacity is reused):
///
/// * `Key`: each key down with `SYN` after it (modifiers first, as
///   [`Chord::codes`](crate::control::target::Chord::codes) orders them),
///   [`KEY_HOLD`], each key up in reverse order with `SYN` after it;
/// * `Click`: the button down, `SYN`, [`BUTTON_HOLD`], up, `SYN`; a double
///   click is two left clicks [`DOUBLE_CLICK_GAP`] apart;
/// * `Button`: the left button down or up, `SYN`, unless it already is;
/// * `Pointer`: the non-zero of `REL_X`, `REL_Y`, `REL_WHEEL`, one `SYN`;
/// * `ReleaseAll`: everything held up, last pressed first, one `SYN`;
/// * `Home`: nothing (the home is not the computer).
pub fn plan(command: &OutputCommand, held: &HeldKeys, out: &mut Vec<WriteStep>) {
    out.clear();
    let write = |out: &mut Vec<WriteStep>, event: UinputEvent| out.push(WriteStep::Write(event));
    match *command {
        OutputCommand::Key(chord) => {
            for &code in chord.codes() {
                write(out, UinputEvent::key(code, true));
                write(out, UinputEvent::SYN);
            }
            out.push(WriteStep::Pause(KEY_HOLD));
            for &code in chord.codes().iter().rev() {
                write(out, UinputEvent::key(code, false));
                write(out, UinputEvent::SYN);
            }
        }
        OutputCommand::Click(click) => {
            let (button, times) = match click {
                Click::Left => (BTN_LEFT, 1),
                Click::Right => (BTN_RIGHT, 1),
                Click::Double => (BTN_LEFT, 2),
            };
            for i in 0..times {
                if i > 0 {
                    out.push(WriteStep::Pause(DOUBLE_CLICK_GAP));
                }
                write(out, UinputEvent::key(button, true));
                write(out, UinputEvent::SYN);
                out.push(WriteStep::Pause(BUTTON_HOLD));
                write(out, UinputEvent::key(button, false));
                write(out, UinputEvent::SYN);
            }
        }
        OutputCommand::Button { down } => {
            if held.contains(BTN_LEFT) != down {
                write(out, UinputEvent::key(BTN_LEFT, down));
                write(out, UinputEvent::SYN);
            }
        }
        OutputCommand::Pointer(motion) => {
            let axes = [
                (REL_X, motion.dx),
                (REL_Y, motion.dy),
                (REL_WHEEL, motion.wheel),
            ];
            for (code, value) in axes {
                if value != 0 {
                    write(out, UinputEvent::rel(code, value));
                }
            }
            if !motion.is_zero() {
                write(out, UinputEvent::SYN);
            }
        }
        OutputCommand::ReleaseAll => {
            for &code in held.codes().iter().rev() {
                write(out, UinputEvent::key(code, false));
            }
            if !held.is_empty() {
                write(out, UinputEvent::SYN);
            }
        }
        OutputCommand::Home { .. } => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::output_command::PointerMove;
    use crate::control::target::Chord;

    const KEY_LEFTCTRL: u16 = 29;
    const KEY_LEFTALT: u16 = 56;
    const KEY_T: u16 = 20;

    fn down(code: u16) -> WriteStep {
        WriteStep::Write(UinputEvent::key(code, true))
    }
    fn up(code: u16) -> WriteStep {
        WriteStep::Write(UinputEvent::key(code, false))
    }
    const SYN: WriteStep = WriteStep::Write(UinputEvent::SYN);

    fn planned(command: OutputCommand, held: &HeldKeys) -> Vec<WriteStep> {
        let mut out = Vec::new();
        plan(&command, held, &mut out);
        out
    }

    fn key(text: &str) -> OutputCommand {
        OutputCommand::Key(Chord::parse(text).unwrap())
    }

    #[test]
    fn a_chord_presses_in_order_and_releases_in_reverse() {
        assert_eq!(
            planned(key("ctrl+alt+t"), &HeldKeys::new()),
            [
                down(KEY_LEFTCTRL),
                SYN,
                down(KEY_LEFTALT),
                SYN,
                down(KEY_T),
                SYN,
                WriteStep::Pause(KEY_HOLD),
                up(KEY_T),
                SYN,
                up(KEY_LEFTALT),
                SYN,
                up(KEY_LEFTCTRL),
                SYN,
            ]
        );
        assert_eq!(
            planned(key("space"), &HeldKeys::new()),
            [down(57), SYN, WriteStep::Pause(KEY_HOLD), up(57), SYN]
        );
    }

    #[test]
    fn clicks() {
        let click = |button| {
            vec![
                down(button),
                SYN,
                WriteStep::Pause(BUTTON_HOLD),
                up(button),
                SYN,
            ]
        };
        let held = HeldKeys::new();
        assert_eq!(
            planned(OutputCommand::Click(Click::Left), &held),
            click(272)
        );
        assert_eq!(
            planned(OutputCommand::Click(Click::Right), &held),
            click(273)
        );
        let mut double = click(272);
        double.push(WriteStep::Pause(DOUBLE_CLICK_GAP));
        double.extend(click(272));
        assert_eq!(planned(OutputCommand::Click(Click::Double), &held), double);
    }

    #[test]
    fn pointer_moves_write_the_non_zero_axes_then_one_syn() {
        let held = HeldKeys::new();
        let moved =
            |dx, dy, wheel| planned(OutputCommand::Pointer(PointerMove { dx, dy, wheel }), &held);
        let rel = |code, value| WriteStep::Write(UinputEvent::rel(code, value));
        assert_eq!(moved(3, -2, 1), [rel(0, 3), rel(1, -2), rel(8, 1), SYN]);
        assert_eq!(moved(0, 5, 0), [rel(1, 5), SYN]);
        assert_eq!(moved(-7, 0, 0), [rel(0, -7), SYN]);
        assert_eq!(moved(0, 0, 0), []);
    }

    #[test]
    fn the_button_goes_down_and_up_once() {
        let mut held = HeldKeys::new();
        let press = OutputCommand::Button { down: true };
        let release = OutputCommand::Button { down: false };
        assert_eq!(planned(press, &held), [down(272), SYN]);
        assert_eq!(planned(release, &held), []);
        held.press(272);
        assert_eq!(planned(press, &held), []);
        assert_eq!(planned(release, &held), [up(272), SYN]);
    }

    #[test]
    fn release_all_lets_go_of_the_last_pressed_first() {
        let mut held = HeldKeys::new();
        assert_eq!(planned(OutputCommand::ReleaseAll, &held), []);
        held.press(KEY_LEFTCTRL);
        held.press(272);
        held.press(KEY_T);
        held.press(KEY_LEFTCTRL);
        assert_eq!(
            planned(OutputCommand::ReleaseAll, &held),
            [up(KEY_T), up(272), up(KEY_LEFTCTRL), SYN]
        );
    }
}
