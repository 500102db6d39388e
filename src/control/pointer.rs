//! The computer's pointer: in a pointer mode a held puff moves it one way
//! and a held sip the other, its speed ramping jerk-limited from rest
//! (Ruckig, as the arm's), so a short breath nudges it a count and a long
//! one crosses the screen; it stops when the breath ends (a pointer has
//! no mass to brake, and a coast would overshoot the target the user let
//! go at). And the drag, the left button held while the pointer moves. The motion is integrated and handed out in whole
//! counts every 10 ticks (100 Hz), the fractions carried over, so the
//! moves sum to the travel commanded.

use serde::{Deserialize, Serialize};

use crate::control::Tick;
use crate::control::mode::{Direction, Mode, ModeState};
use crate::control::modes::ModeOutput;
use crate::control::motion::channel::{CYCLE_S, Channel};
use crate::control::output_command::{OutputCommand, OutputCommands, PointerMove};
use crate::control::target::Target;

/// Ticks between pointer moves: 100 Hz.
pub const MOVE_EVERY_TICKS: Tick = 10;

/// The pointer's speeds (`[output.uinput]` in the config file).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PointerConfig {
    /// Top pointer speed, counts/s.
    pub pointer_speed: f64,
    /// Pointer acceleration, counts/s².
    pub pointer_acceleration: f64,
    /// Pointer jerk, counts/s³: how gently it starts.
    pub pointer_jerk: f64,
    /// Top scroll speed, wheel detents/s.
    pub scroll_speed: f64,
    /// Scroll acceleration, detents/s².
    pub scroll_acceleration: f64,
    /// Scroll jerk, detents/s³.
    pub scroll_jerk: f64,
}

impl Default for PointerConfig {
    /// A creep that gathers speed: a 150 ms breath moves the pointer
    /// about one count, a 0.5 s breath about 30, a 1 s breath about 250,
    /// and from 1.4 s on it runs at 800 counts/s.
    fn default() -> Self {
        PointerConfig {
            pointer_speed: 800.0,
            pointer_acceleration: 1600.0,
            pointer_jerk: 1600.0,
            scroll_speed: 8.0,
            scroll_acceleration: 32.0,
            scroll_jerk: 256.0,
        }
    }
}

/// Degrees of freedom of the pointer's channel.
const X: usize = 0;
const Y: usize = 1;
const WHEEL: usize = 2;

/// The pointer's motion and the drag button. RT-safe after
/// [`Pointer::new`].
pub struct Pointer {
    config: PointerConfig,
    channel: Channel<3>,
    /// Travel since the start, counts (x right, y down, wheel up).
    travel: [f64; 3],
    /// Whole counts handed out so far.
    sent: [i64; 3],
    /// The left button is held for a drag.
    dragging: bool,
}

impl std::fmt::Debug for Pointer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Pointer")
            .field("travel", &self.travel)
            .field("sent", &self.sent)
            .field("dragging", &self.dragging)
            .finish()
    }
}

impl Pointer {
    /// At rest, no button held. Not RT-safe (call at start-up).
    pub fn new(config: &PointerConfig) -> Pointer {
        let c = config;
        Pointer {
            config: *c,
            channel: Channel::new(
                [c.pointer_speed, c.pointer_speed, c.scroll_speed],
                [
                    c.pointer_acceleration,
                    c.pointer_acceleration,
                    c.scroll_acceleration,
                ],
                [c.pointer_jerk, c.pointer_jerk, c.scroll_jerk],
            ),
            travel: [0.0; 3],
            sent: [0; 3],
            dragging: false,
        }
    }

    /// The left button is held for a drag.
    pub fn dragging(&self) -> bool {
        self.dragging
    }

    /// A match: a drag begins or ends; any other selection but a pointer
    /// mode ends a drag first. RT-safe.
    pub fn on_match(&mut self, target: Target, out: &mut OutputCommands) {
        let keeps_drag = matches!(target, Target::Mode(mode) if mode.is_pointer());
        match target {
            Target::Drag => {
                self.dragging = !self.dragging;
                push(
                    out,
                    OutputCommand::Button {
                        down: self.dragging,
                    },
                );
            }
            _ if self.dragging && !keeps_drag => {
                self.dragging = false;
                push(out, OutputCommand::Button { down: false });
            }
            _ => {}
        }
    }

    /// A fault or a stop: the drag ends (the outputs let go of
    /// everything). RT-safe.
    pub fn release(&mut self, out: &mut OutputCommands) {
        self.dragging = false;
        push(out, OutputCommand::ReleaseAll);
    }

    /// One tick: the speed follows the breath held in a pointer mode (0
    /// otherwise, ramping down); every [`MOVE_EVERY_TICKS`] the travel's
    /// new whole counts go out. RT-safe.
    pub fn step(&mut self, now: Tick, command: &ModeOutput, out: &mut OutputCommands) {
        let sign = command.direction.sign();
        let c = &self.config;
        let mut target = [0.0; 3];
        if let ModeState::Command(mode) = command.state
            && command.direction != Direction::Still
        {
            match mode {
                Mode::PointerX => target[X] = sign * c.pointer_speed,
                // Puff is up: negative y on a screen.
                Mode::PointerY => target[Y] = -sign * c.pointer_speed,
                Mode::Scroll => target[WHEEL] = sign * c.scroll_speed,
                _ => {}
            }
        }
        // Released, or turned the other way: that axis stops at once.
        for (dof, &asked) in target.iter().enumerate() {
            let moving = self.channel.velocity(dof);
            if moving != 0.0 && asked * moving <= 0.0 {
                self.channel.restart_from_rest(dof);
            }
        }
        let asked_nothing = target == [0.0; 3];
        if !(asked_nothing && self.channel.resting()) {
            self.channel.ask_velocities(target);
            self.channel.update(asked_nothing);
            for (dof, travel) in self.travel.iter_mut().enumerate() {
                *travel += self.channel.velocity(dof) * CYCLE_S;
            }
        }
        if now.is_multiple_of(MOVE_EVERY_TICKS) {
            let mut whole = [0i32; 3];
            for ((travel, sent), delta) in self.travel.iter().zip(&mut self.sent).zip(&mut whole) {
                let now_whole = travel.round() as i64;
                *delta = i32::try_from(now_whole - *sent).unwrap_or(0);
                *sent = now_whole;
            }
            let [dx, dy, wheel] = whole;
            let motion = PointerMove { dx, dy, wheel };
            if !motion.is_zero() {
                push(out, OutputCommand::Pointer(motion));
            }
        }
    }
}

/// Adds a command; the list has room for a tick's (see
/// [`MAX_OUTPUT_COMMANDS`](crate::control::output_command::MAX_OUTPUT_COMMANDS)).
fn push(out: &mut OutputCommands, command: OutputCommand) {
    let _ = out.push(command);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn held(mode: Mode, direction: Direction) -> ModeOutput {
        ModeOutput {
            state: ModeState::Command(mode),
            direction,
            strength_volts: 0.5,
            speed_fraction: None,
        }
    }

    /// Runs `ticks` ticks from `*t` and sums the moves handed out.
    fn run(p: &mut Pointer, t: &mut Tick, command: ModeOutput, ticks: u64) -> PointerMove {
        let mut sum = PointerMove::default();
        for _ in 0..ticks {
            let mut out = OutputCommands::default();
            p.step(*t, &command, &mut out);
            for c in out.iter() {
                if let OutputCommand::Pointer(m) = c {
                    sum.dx += m.dx;
                    sum.dy += m.dy;
                    sum.wheel += m.wheel;
                }
            }
            *t += 1;
        }
        sum
    }

    #[test]
    fn a_short_breath_nudges_and_a_long_one_travels() {
        let mut p = Pointer::new(&PointerConfig::default());
        let mut t = 1;
        let pointer_x = held(Mode::PointerX, Direction::Positive);
        let nudge = run(&mut p, &mut t, pointer_x, 300);
        let after = run(&mut p, &mut t, ModeOutput::default(), 500);
        let total = p.travel[X];
        assert!((5.0..=9.0).contains(&total), "{total}");
        // Nothing moves once the breath ends (but the last rounding).
        assert!(nudge.dy == 0 && after.dx.abs() <= 1, "{nudge:?} {after:?}");
        let mut p = Pointer::new(&PointerConfig::default());
        let mut t = 1;
        let moved = run(&mut p, &mut t, pointer_x, 2000);
        let coasted = run(&mut p, &mut t, ModeOutput::default(), 1000);
        // Full speed, 800 counts/s, after the ramp: well over 1000 counts.
        assert!(moved.dx > 1000, "{moved:?}");
        // Every count of the travel went out, to within the rounding.
        assert!((f64::from(moved.dx + coasted.dx) - p.travel[X]).abs() <= 0.5);
    }

    /// The figures the default's doc comment and the configuration doc
    /// give: a breath's travel, counts; nothing moves once it ends.
    #[test]
    fn the_defaults_creep_then_run() {
        let travel = |ms: u64| {
            let mut p = Pointer::new(&PointerConfig::default());
            let mut t = 1;
            run(
                &mut p,
                &mut t,
                held(Mode::PointerX, Direction::Positive),
                ms,
            );
            run(&mut p, &mut t, ModeOutput::default(), 1500);
            p.travel[X]
        };
        let (tap, half, second, two) = (travel(150), travel(500), travel(1000), travel(2000));
        assert!((0.5..1.5).contains(&tap), "{tap}");
        assert!((25.0..40.0).contains(&half), "{half}");
        assert!((220.0..290.0).contains(&second), "{second}");
        // From about 1.4 s on, 800 counts a second.
        assert!((two - second - 770.0).abs() < 50.0, "{second} {two}");
    }

    #[test]
    fn puff_is_up_and_sip_down() {
        let mut p = Pointer::new(&PointerConfig::default());
        let mut t = 1;
        let up = run(
            &mut p,
            &mut t,
            held(Mode::PointerY, Direction::Positive),
            600,
        );
        assert!(up.dy < 0 && up.dx == 0);
        let wheel = run(
            &mut p,
            &mut t,
            held(Mode::Scroll, Direction::Negative),
            2000,
        );
        assert!(wheel.wheel < 0);
    }

    #[test]
    fn the_arm_modes_move_no_pointer() {
        let mut p = Pointer::new(&PointerConfig::default());
        let mut t = 1;
        let m = run(
            &mut p,
            &mut t,
            held(Mode::TranslateX, Direction::Positive),
            500,
        );
        assert_eq!(m, PointerMove::default());
    }

    #[test]
    fn a_drag_holds_the_button_through_pointer_modes_only() {
        let mut p = Pointer::new(&PointerConfig::default());
        let mut out = OutputCommands::default();
        p.on_match(Target::Drag, &mut out);
        p.on_match(Target::Mode(Mode::PointerX), &mut out);
        p.on_match(Target::Mode(Mode::Fingers), &mut out);
        let got: Vec<_> = out.iter().copied().collect();
        assert_eq!(
            got,
            [
                OutputCommand::Button { down: true },
                OutputCommand::Button { down: false }
            ]
        );
        assert!(!p.dragging());
    }
}
