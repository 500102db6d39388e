//! The pipeline: the core's stages wired together, detector (and the
//! head's gestures) → selection → mode machine → motion, one
//! [`Pipeline::step`] per tick. Pure and deterministic: the same inputs
//! give the same outputs in replay, in tests and on the real-time thread.

use crate::control::Tick;
use crate::control::core_config::CoreConfig;
use crate::control::detector::{BurstDetector, DetectorEvent, DetectorOutput};
use crate::control::event::Event;
use crate::control::head::{Head, HeadEvent, HeadGesture, HeadOutput};
use crate::control::mode::{Direction, ModeState};
use crate::control::modes::ModeMachine;
use crate::control::motion::Motion;
use crate::control::motion::feedback::ArmFault;
use crate::control::motion::stream::ARM_STOPS_AFTER_TICKS;
use crate::control::output_command::OutputCommand;
use crate::control::pointer::Pointer;
use crate::control::selection::Interface;
use crate::control::selection::matcher::{MatchEvent, ResetReason, SequenceMatcher};
use crate::control::selection::scanning::Scanner;
use crate::control::sequence::Sequence;
use crate::control::target::Target;
use crate::control::tick::{ArmInput, ArmPose, TickInput, TickOutput};
use crate::control::token::Token;
use crate::control::view::CoreView;

/// The deterministic core's pipeline. Build with [`Pipeline::new`] at
/// start-up (allocates the matcher's library); [`Pipeline::step`] is
/// RT-safe: no allocation, no panic, no clock.
#[derive(Debug)]
pub struct Pipeline {
    detector: BurstDetector,
    /// A breath sensor feeds the core (else the detector is not run).
    breath: bool,
    /// The head-worn IMU's stage, for a person with gestures.
    head: Option<Head>,
    selector: Selector,
    modes: ModeMachine,
    motion: Motion,
    pointer: Pointer,
    /// A fault or stop let go of the outputs' keys and buttons: said once
    /// until the next match.
    released: bool,
    /// The previous tick, to see gaps.
    last_tick: Option<Tick>,
    /// The arm fault, once there is one (it never clears).
    arm_fault: Option<ArmFault>,
    /// The direction commanded on the last tick (for [`Pipeline::view`]).
    direction: Direction,
}

/// How a mode is selected in detection mode.
#[derive(Debug)]
#[allow(
    clippy::large_enum_variant,
    reason = "built once and never moved; the matcher's sequence is inline"
)]
enum Selector {
    /// ASP: sequences matched against the library.
    Sequences(SequenceMatcher),
    /// BSP: the modes scroll; a puff enters the highlighted one.
    Scanning(Scanner),
}

impl Pipeline {
    /// Takes in what the arm said since the last step: its link lost, a
    /// measured pose (logged if it moved the estimate), or silence.
    /// Returns a new arm fault.
    fn take_arm_news(
        &mut self,
        now: Tick,
        arm: &ArmInput,
        out: &mut TickOutput,
    ) -> Option<ArmFault> {
        if arm.link_lost {
            return Some(ArmFault::LinkLost);
        }
        if self.arm_fault.is_some() {
            return None;
        }
        if let Some((ArmPose::Measured, pose)) = &arm.pose {
            match self.motion.measure(now, pose) {
                Err(fault) => return Some(fault),
                Ok(Some(event)) => out.log(Event::Motion(event)),
                Ok(None) => {}
            }
        }
        self.motion.check_feedback(now)
    }

    /// Builds the pipeline from a validated config.
    pub fn new(config: &CoreConfig) -> Self {
        Pipeline {
            detector: BurstDetector::new(config.detector()),
            breath: config.has_breath_sensor(),
            // A loaded setup was checked by `Head::new` when it was made.
            head: config
                .gestures()
                .and_then(|setup| Head::new(setup, config.head()).ok()),
            selector: match config.interface() {
                Interface::Asp => {
                    Selector::Sequences(SequenceMatcher::new(config.sequences(), config.matcher()))
                }
                Interface::Bsp => Selector::Scanning(Scanner::new(config.scanning())),
            },
            modes: ModeMachine::new(config.command()),
            motion: Motion::new(config.motion(), config.workspace(), config.home())
                .with_feedback(config.feedback()),
            pointer: Pointer::new(config.pointer()),
            released: true,
            last_tick: None,
            arm_fault: None,
            direction: Direction::Still,
        }
    }

    /// The arm fault, if there was one (the run should end once the arm
    /// is still).
    pub fn arm_fault(&self) -> Option<ArmFault> {
        self.arm_fault
    }

    /// The motion layer (pose estimate, saved point).
    pub fn motion(&self) -> &Motion {
        &self.motion
    }

    /// Skips nothing at rest, in the detector, the motion layer and its
    /// channels: the reference path the skipped work is proven against
    /// (`tests/it/fast_paths.rs`).
    #[cfg(any(test, feature = "testing"))]
    pub fn use_reference_path(&mut self) {
        self.detector.use_reference_path();
        self.motion.use_reference_path();
    }

    /// Where the user is, as the display shows it. RT-safe.
    pub fn view(&self) -> CoreView {
        let (sequence, decides_at, pending, highlighted) = match &self.selector {
            Selector::Sequences(matcher) => (
                *matcher.current(),
                matcher.decides_at(),
                matcher.pending(),
                None,
            ),
            Selector::Scanning(scanner) => (Sequence::EMPTY, None, None, scanner.highlighted()),
        };
        CoreView {
            neutral_volts: self.detector.neutral_volts(),
            held: self.detector.held(),
            sensor_faulted: self.detector.is_faulted()
                || self.head.as_ref().is_some_and(Head::is_faulted),
            sequence,
            decides_at,
            pending,
            highlighted,
            state: self.modes.state(),
            direction: self.direction,
            returns_at: self.modes.returns_at(),
            saved_point: self.motion.saved().is_some(),
            arm_faulted: self.arm_fault.is_some(),
            head: self.head.as_ref().and_then(Head::view),
        }
    }

    /// The detector (e.g. to read the tracked neutral).
    pub fn detector(&self) -> &BurstDetector {
        &self.detector
    }

    /// Takes tick `input.tick`'s whole input and writes what the core says
    /// about the tick into `out` (a previous tick's output, or
    /// [`TickOutput::default`] before the first: it is written whole). The
    /// only call that changes the core. RT-safe.
    pub fn step(&mut self, input: &TickInput, out: &mut TickOutput) {
        if let Some((ArmPose::Start, pose)) = input.arm.pose {
            self.motion.start_measured(pose);
        }
        if input.stop {
            self.modes.stop();
        }
        let now = input.tick;
        let detected = if self.breath {
            self.detector.step(now, input.sample)
        } else {
            DetectorOutput::default()
        };
        let commanding = matches!(self.modes.state(), ModeState::Command(_));
        let head = match &mut self.head {
            Some(head) => head.step(now, input.imu, commanding),
            None => HeadOutput::default(),
        };
        out.restart(now);
        self.process(now, detected, &head, &input.arm, out);
    }

    /// One tick into `out`: the arm's news, the selection (the paper's
    /// Figs. 2 and 3), the mode machine (Fig. 1), the motion layer.
    fn process(
        &mut self,
        now: Tick,
        detected: DetectorOutput,
        head: &HeadOutput,
        arm: &ArmInput,
        out: &mut TickOutput,
    ) {
        let gap = self.last_tick.map(|last| now.saturating_sub(last));
        self.last_tick = Some(now);
        if gap.is_some_and(|g| g > ARM_STOPS_AFTER_TICKS) {
            // No command reached the arm during the gap (a stalled
            // process): it has stopped on its own, as the JACO2 does when
            // its stream stops. The commands resume from rest, never from
            // the speed before the gap. (A gap over `stale_ms` is also a
            // fault: the detector reports it.)
            self.motion.halt();
            out.motion = self.motion.idle_output();
        }

        let faulted = detected.faulted || head.faulted;
        out.held = detected.held;
        out.faulted = faulted;
        if let Some(fault) = self.take_arm_news(now, arm, out) {
            if self.arm_fault.is_none() {
                self.arm_fault = Some(fault);
                out.log(Event::ArmFault { reason: fault });
            }
            // From this tick the interface is in detection mode for good:
            // every target is zero and the arm brakes.
            self.modes.stop();
            if let Selector::Sequences(matcher) = &mut self.selector {
                matcher.interrupt();
            }
        }
        let matched = self.select(now, &detected, head, out);
        let entered = matched.and_then(|(_, target)| target.mode());
        if let Some((sequence, target)) = matched {
            self.fire(now, sequence, target, out);
        }

        // A breath held moves; without one, the head's tilt (proportional
        // to how far it is past the dead zone).
        let head_moves = detected.held.breath.is_none() && head.tilt.breath.is_some();
        let held = if head_moves { head.tilt } else { detected.held };
        let (mut command, left) = self.modes.step(now, held, entered, faulted);
        if head_moves && command.direction != Direction::Still {
            command.speed_fraction = Some(head.speed_fraction);
        }
        out.command = command;
        self.direction = command.direction;
        if let Some(reason) = left {
            out.log(Event::Detection { reason });
        }
        // A fault or a stop lets go of every key and button held.
        if (faulted || self.modes.stopping()) && !self.released {
            self.released = true;
            self.pointer.release(&mut out.outputs);
        }
        self.pointer.step(now, &out.command, &mut out.outputs);
        // (An arm fault's stop takes effect through the mode machine.)
        self.motion.step(now, &out.command, &mut out.motion);
        for event in out.motion.events.into_iter().flatten() {
            out.log(Event::Motion(event));
        }
    }

    /// A match's action for the outputs: a drag begins or ends, a chord,
    /// a click or a home event fires (a mode is entered by the mode
    /// machine).
    fn fire(&mut self, now: Tick, sequence: Sequence, target: Target, out: &mut TickOutput) {
        self.released = false;
        self.pointer.on_match(target, &mut out.outputs);
        let fired = match target {
            Target::Key(chord) => Some(OutputCommand::Key(chord)),
            Target::Click(click) => Some(OutputCommand::Click(click)),
            Target::Home(event) => Some(OutputCommand::Home {
                event,
                tick: now,
                sequence,
            }),
            Target::Mode(_) | Target::Drag => None,
        };
        if let Some(command) = fired {
            // Room for it: see `MAX_OUTPUT_COMMANDS`.
            let _ = out.outputs.push(command);
        }
    }

    /// The head's news on this tick: its fault (the sequence begun is
    /// void), its recovery, a gesture (in detection mode, the sequence's
    /// next token) or a movement that is none.
    fn take_head_news(
        &mut self,
        now: Tick,
        head: &HeadOutput,
        in_detection: bool,
        out: &mut TickOutput,
    ) -> Option<MatchEvent> {
        let Selector::Sequences(matcher) = &mut self.selector else {
            return None;
        };
        match head.event {
            Some(HeadEvent::Fault(reason)) => {
                out.log(Event::Fault { reason });
                return matcher.interrupt();
            }
            Some(HeadEvent::Recovered) => out.log(Event::Recovered),
            None => {}
        }
        match head.gesture {
            Some(HeadGesture::Recognised { name, start }) => {
                out.log(Event::Gesture {
                    name,
                    start_tick: start,
                });
                in_detection
                    .then(|| matcher.on_token(Token::Gesture(name), now))
                    .flatten()
            }
            Some(HeadGesture::Rejected { nearest, why }) => {
                out.log(Event::GestureRejected { nearest, why });
                None
            }
            None => None,
        }
    }

    /// The detector's event and the selector's decision on this tick,
    /// logged: the sequence matched and what it selects, if any.
    fn select(
        &mut self,
        now: Tick,
        detected: &DetectorOutput,
        head: &HeadOutput,
        out: &mut TickOutput,
    ) -> Option<(Sequence, Target)> {
        let in_detection = self.modes.state() == ModeState::Detection;
        let mut decision = None;
        let mut scan_burst = None;
        match detected.event {
            Some(DetectorEvent::Burst(burst)) => {
                out.log(Event::Burst(burst));
                if in_detection {
                    match &mut self.selector {
                        Selector::Sequences(matcher) => decision = matcher.on_burst(&burst),
                        Selector::Scanning(_) => scan_burst = Some(burst),
                    }
                } else if let Selector::Sequences(matcher) = &mut self.selector {
                    // Motion onset: a short breath in command mode selects,
                    // a long one moved the arm and voids a selection begun.
                    if self.modes.selects_in_command_mode() {
                        decision = matcher.on_burst(&burst);
                    } else if self.modes.moved_in_command_mode() {
                        decision = matcher.void(ResetReason::Moved);
                    }
                }
            }
            Some(DetectorEvent::Fault(reason)) => {
                out.log(Event::Fault { reason });

                if let Selector::Sequences(matcher) = &mut self.selector {
                    decision = matcher.interrupt();
                }
            }
            Some(DetectorEvent::Recovered) => out.log(Event::Recovered),
            Some(DetectorEvent::Rezeroed {
                neutral_volts,
                previous_volts,
            }) => out.log(Event::Rezeroed {
                neutral_volts,
                previous_volts,
            }),
            None => {}
        }
        if decision.is_none() {
            decision = self.take_head_news(now, head, in_detection, out);
        }
        match &mut self.selector {
            Selector::Sequences(matcher) => {
                if decision.is_none() {
                    decision = matcher.on_tick(now, detected.in_progress || head.in_motion);
                }
            }
            Selector::Scanning(scanner) => {
                let scan =
                    scanner.step(now, in_detection && !detected.faulted, scan_burst.as_ref());
                if let Some(mode) = scan.highlight {
                    out.log(Event::Highlight { mode });
                }
                if let (Some(mode), Some(burst)) = (scan.selected, scan_burst) {
                    let mut sequence = Sequence::default();
                    // One action always fits.
                    let _ = sequence.try_push(burst.action);
                    decision = Some(MatchEvent::Match {
                        sequence,
                        target: Target::Mode(mode),
                    });
                }
            }
        }

        match decision {
            Some(MatchEvent::Match { sequence, target }) => {
                out.log(Event::Match { sequence, target });
                Some((sequence, target))
            }
            Some(MatchEvent::Reset { sequence, reason }) => {
                out.log(Event::Reset { sequence, reason });
                None
            }
            None => None,
        }
    }
}
