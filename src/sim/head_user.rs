//! A simulated person who selects with head gestures and moves the arm by
//! tilting their head, in closed loop with the production core: their
//! head's motion goes through the IMU they wear into the same gesture
//! front end, matcher, mode machine and motion layer as in production,
//! tick by tick, and they react to what the interface shows (the mode
//! matched, a movement not read, the return to selection) and to how far
//! the arm has gone.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::arm::sim::SimulatedJaco;
use crate::config::Config;
use crate::control::Tick;
use crate::control::event::Event;
use crate::control::gesture::features::norm3;
use crate::control::mode::{Direction, Mode, ModeState};
use crate::control::pipeline::Pipeline;
use crate::control::tick::{TickInput, TickOutput};
use crate::control::token::Token;
use crate::sim::head_gesture::{GestureName, gesture_example};
use crate::sim::head_motion::{Axis, Step};
use crate::sim::imu_user::ImuUser;
use crate::sim::live_head::LiveHead;
use crate::sim::study::tasks::TaskStep;
use crate::sim::user::{TaskRun, reaction_ms};

/// Longest a task may take in simulation before it is abandoned, ticks.
const MAX_TASK_TICKS: u64 = 30 * 60 * 1000;
/// How long tilting the head to drive, or bringing it back, takes at
/// speed 1, ms.
pub const TILT_MS: f64 = 400.0;
/// Rest between the gestures of one sequence, ms: longer than the front
/// end's `rest_ms` (300 ms), after which a gesture is read.
pub const BETWEEN_GESTURES_MS: u64 = 600;
/// The arm held still this long while the head is tilted past the dead
/// zone (a workspace limit): the person takes it as far as it goes, ms.
const STALLED_MS: u32 = 500;
/// Rest after bringing the head back before the next step, ms.
const AFTER_DRIVE_MS: u64 = 250;
/// How far a person of amplitude 1 tilts their head to drive, degrees:
/// past the default dead zone (12°), 62.5–90 % of full speed for the
/// built-in people's amplitudes 0.7–1.3.
pub const DRIVE_DEG: f64 = 24.0;

/// A person in the study who uses their head.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeadParticipant {
    /// How they move, and what their body and sensor add.
    pub user: ImuUser,
    /// From seeing something to starting to move, ms (mean, SD;
    /// log-normal), as the breath study's participants.
    pub reaction_ms: (f64, f64),
}

impl HeadParticipant {
    /// How far they tilt their head to drive, degrees.
    pub fn drive_deg(&self) -> f64 {
        DRIVE_DEG * self.user.amplitude
    }
}

/// What the person is doing.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// Working out the next move from what the interface shows.
    Decide,
    /// Head tilted `sign` (chin down +1), held until the arm has gone as
    /// far as `need_ms` at full speed would take it (the breath study's
    /// hold).
    /// `stalled_ms`: how long the tilt has been past the dead zone with
    /// the arm still (held at a workspace limit).
    Driving {
        sign: f64,
        moved_ms: f64,
        need_ms: f64,
        stalled_ms: u32,
    },
    /// Gestures made (the last ends at `made_until`): waiting for the
    /// match until `deadline`.
    AwaitMatch {
        target: Mode,
        made_until: Tick,
        deadline: Tick,
    },
    /// Waiting for the interface to return to selection.
    AwaitDetection,
    /// The last move is made.
    Done,
}

struct Agent<'a> {
    person: HeadParticipant,
    config: &'a Config,
    steps: &'a [TaskStep],
    next: usize,
    phase: Phase,
    rng: ChaCha8Rng,
    run: TaskRun,
    /// Until this tick the person is still making the moves decided.
    busy_until: Tick,
    /// When the person decided to select the mode they are selecting.
    selecting_since: Option<Tick>,
}

impl Agent<'_> {
    fn reaction(&mut self) -> Tick {
        Tick::from(reaction_ms(self.person.reaction_ms, &mut self.rng))
    }

    fn tilt_ms(&self) -> f64 {
        TILT_MS / self.person.user.speed
    }

    /// A pitch of the head by `degrees` from `at` ms.
    fn pitch(&self, head: &mut LiveHead, at: Tick, degrees: f64) {
        head.add(
            at,
            &[Step {
                axis: Axis::Pitch,
                start: 0.0,
                duration: self.tilt_ms() / 1000.0,
                amount: degrees.to_radians(),
            }],
        );
    }

    /// After tick `now`'s output: what the person sees and does.
    fn act(&mut self, now: Tick, out: &TickOutput, head: &mut LiveHead) {
        let state = out.command.state;
        let matches = out
            .events
            .iter()
            .filter(|e| matches!(e, Event::Match { .. }));
        self.run.selections += matches.count() as u32;
        if let Phase::AwaitMatch {
            target,
            made_until,
            deadline,
        } = self.phase
        {
            self.await_match(now, out, target, made_until, deadline);
        }
        if let Phase::Driving {
            sign,
            moved_ms,
            need_ms,
            stalled_ms,
        } = self.phase
        {
            self.drive(now, out, head, sign, (moved_ms, need_ms), stalled_ms);
        }
        if now < self.busy_until {
            return;
        }
        match self.phase {
            Phase::AwaitDetection if state == ModeState::Detection => self.phase = Phase::Decide,
            Phase::Decide => self.decide(now, state, head),
            _ => {}
        }
    }

    fn await_match(
        &mut self,
        now: Tick,
        out: &TickOutput,
        target: Mode,
        made_until: Tick,
        deadline: Tick,
    ) {
        for event in out.events.iter() {
            match event {
                Event::Match {
                    target: matched, ..
                } => {
                    if matched.mode() == Some(target) {
                        if let Some(since) = self.selecting_since.take() {
                            self.run.selecting_s += now.saturating_sub(since) as f64 / 1000.0;
                            self.run.selections_timed += 1;
                        }
                        self.phase = Phase::Decide;
                    } else {
                        self.run.wrong_selections += 1;
                        self.phase = Phase::AwaitDetection;
                    }
                    return;
                }
                Event::Reset { .. } => {
                    self.run.retries += 1;
                    self.phase = Phase::Decide;
                    return;
                }
                // "Movement not read as a gesture": once every gesture is
                // made, the person tries again.
                Event::GestureRejected { .. } if now >= made_until => {
                    self.run.retries += 1;
                    self.phase = Phase::Decide;
                    return;
                }
                _ => {}
            }
        }
        if now >= deadline {
            self.run.retries += 1;
            self.phase = Phase::Decide;
        }
    }

    /// How fast the arm is commanded on this tick, as a share of its
    /// mode's full speed: what the person watches to judge how far it has
    /// gone (a millisecond at full speed adds 1).
    fn speed_share(&self, out: &TickOutput) -> f64 {
        let limits = self.config.core().motion();
        let m = &out.motion;
        (norm3(m.linear) / limits.linear_speed_mps)
            .max(norm3(m.angular) / limits.angular_speed_radps)
            .max(m.fingers_velocity.abs() / limits.finger_speed)
    }

    fn drive(
        &mut self,
        now: Tick,
        out: &TickOutput,
        head: &mut LiveHead,
        sign: f64,
        (mut moved_ms, need_ms): (f64, f64),
        mut stalled_ms: u32,
    ) {
        let step = self.steps[self.next];
        let share = self.speed_share(out);
        moved_ms += share;
        let pressing = out.command.direction != Direction::Still;
        stalled_ms = if pressing && share == 0.0 {
            stalled_ms + 1
        } else {
            0
        };
        let gone = out.command.state != ModeState::Command(step.mode);
        if moved_ms < need_ms && stalled_ms < STALLED_MS && !gone {
            self.phase = Phase::Driving {
                sign,
                moved_ms,
                need_ms,
                stalled_ms,
            };
            return;
        }
        // Far enough, as far as it goes, or the mode is gone: the head
        // comes back.
        self.pitch(head, now, -sign * self.person.drive_deg());
        self.busy_until = now + self.tilt_ms() as Tick + AFTER_DRIVE_MS;
        if gone {
            self.phase = Phase::AwaitDetection;
        } else {
            self.next += 1;
            self.phase = Phase::Decide;
        }
    }

    fn decide(&mut self, now: Tick, state: ModeState, head: &mut LiveHead) {
        let Some(&step) = self.steps.get(self.next) else {
            self.phase = Phase::Done;
            return;
        };
        match state {
            ModeState::Command(mode) if mode == step.mode => {
                let start = now + self.reaction();
                let sign = Direction::of(step.breath).sign();
                self.pitch(head, start, sign * self.person.drive_deg());
                self.busy_until = start;
                self.phase = Phase::Driving {
                    sign,
                    moved_ms: 0.0,
                    need_ms: f64::from(step.moving_ms),
                    stalled_ms: 0,
                };
            }
            ModeState::Command(_) => self.phase = Phase::AwaitDetection,
            ModeState::Detection => self.select(now, step.mode, head),
        }
    }

    /// Makes the gestures of the library's first entry for `mode`.
    fn select(&mut self, now: Tick, mode: Mode, head: &mut LiveHead) {
        let gestures: Vec<GestureName> = self
            .config
            .core()
            .sequences()
            .iter()
            .filter(|e| e.target.mode() == Some(mode))
            .find_map(|e| {
                e.actions
                    .as_slice()
                    .iter()
                    .map(|t| match t {
                        Token::Gesture(name) => GestureName::parse(name.as_str()).ok(),
                        Token::Breath(_) => None,
                    })
                    .collect::<Option<Vec<_>>>()
            })
            .unwrap_or_default();
        if gestures.is_empty() {
            // Nothing to make (the study refuses such a library).
            self.busy_until = now + 1;
            return;
        }
        self.selecting_since.get_or_insert(now);
        let mut at = now + self.reaction();
        let mut made_until = at;
        for name in gestures {
            let example = gesture_example(name, &self.person.user, &mut self.rng);
            head.add(at, &example.steps);
            made_until = at + (example.duration * 1000.0).ceil() as Tick;
            at = made_until + BETWEEN_GESTURES_MS;
        }
        let core = self.config.core();
        let rest = core.gestures().map_or(300, |g| g.recognizer.rest_ms);
        let wait = rest + core.matcher().sequence_timeout_ms + 500;
        self.busy_until = made_until;
        self.phase = Phase::AwaitMatch {
            target: mode,
            made_until,
            deadline: made_until + Tick::from(wait),
        };
    }
}

/// Runs `steps` with `person` on `config` (a person with gestures: its
/// library names them), tick by tick through the production core and the
/// simulated arm, from selection at rest until the last move ends.
pub fn run_head_task(
    config: &Config,
    steps: &[TaskStep],
    person: &HeadParticipant,
    seed: u64,
) -> TaskRun {
    let mut head = LiveHead::new(&person.user, seed);
    let mut core = Pipeline::new(config.core());
    let mut arm = SimulatedJaco::new(config.core());
    let mut agent = Agent {
        person: *person,
        config,
        steps,
        next: 0,
        phase: Phase::Decide,
        rng: ChaCha8Rng::seed_from_u64(seed ^ 0x004e_ad5e),
        run: TaskRun::default(),
        busy_until: 0,
        selecting_since: None,
    };
    let mut out = TickOutput::default();
    let (mut moving_ticks, mut last_moving) = (0u64, 0u64);
    let mut tick = 0;
    while agent.phase != Phase::Done && tick < MAX_TASK_TICKS {
        core.step(&TickInput::imu(tick, head.input(tick)), &mut out);
        arm.tick(out.motion.arm_command.as_ref());
        if out.command.direction != Direction::Still {
            moving_ticks += 1;
            last_moving = tick;
        }
        agent.act(tick, &out, &mut head);
        tick += 1;
    }
    agent.run.timed_out = agent.phase != Phase::Done;
    agent.run.completion_s = (last_moving + 1) as f64 / 1000.0;
    agent.run.moving_s = moving_ticks as f64 / 1000.0;
    agent.run
}
