//! A seeded stochastic model of a sip-and-puff user, run in closed loop
//! with the production core: the user breathes into the synthetic sensor,
//! the signal goes through the same detector, selection interface, mode
//! machine and motion layer as in production, tick by tick, and the user
//! reacts to what the interface shows (the highlight, the matched mode,
//! the return to detection mode).

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, LogNormal, Normal};

use crate::arm::sim::SimulatedJaco;
use crate::config::Config;
use crate::control::Tick;
use crate::control::action::{Action, Breath};
use crate::control::event::Event;
use crate::control::mode::{Direction, Mode, ModeState};
use crate::control::pipeline::Pipeline;
use crate::control::selection::{Interface, SequenceEntry};
use crate::control::tick::{TickInput, TickOutput};
use crate::sim::sensor_model::{SignalGenerator, SignalParams, Step};
use crate::sim::study::tasks::{Task, TaskStep};

/// How a user breathes and reacts. Times in ms, as (mean, standard
/// deviation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UserModel {
    /// From seeing something (the target highlighted, the mode entered)
    /// to starting a breath. Log-normal.
    pub reaction_ms: (f64, f64),
    /// A short burst, as the user means it. Normal.
    pub short_ms: (f64, f64),
    /// A long burst. Normal.
    pub long_ms: (f64, f64),
    /// Rest between the bursts of a sequence. Normal.
    pub gap_ms: (f64, f64),
    /// Chance that a selection goes wrong: in ASP one burst of the sequence
    /// in the wrong length class; in BSP a puff one highlight late.
    pub error_rate: f64,
    /// BSP: chance of letting the target's highlight pass and waiting a
    /// whole cycle.
    pub miss_rate: f64,
    /// Standard deviation of a hold, as a fraction of the task's moving
    /// time for the step.
    pub hold_sd: f64,
    /// Between-participant spread: each participant's mean reaction time
    /// is the population's times a log-normal factor of this σ.
    pub between_users: f64,
    /// Chance, at each change of mode, that the user slips: starts the next
    /// selection right after the move instead of waiting for the return to
    /// detection mode (the slip the motion onset is for). 0 in the paper's
    /// population.
    pub slip_rate: f64,
    /// The longest breath the user can hold, ms: a longer move is made of
    /// several holds. Unlimited in the paper's population.
    pub hold_capacity_ms: f64,
}

impl UserModel {
    /// The population the study draws its participants from: healthy
    /// adults after ten minutes of practice, as in the paper. Its error and
    /// miss rates are assumptions (the paper reports missed modes during
    /// the auto-scroll without a rate); the sensitivity sweep shows how
    /// much each matters.
    pub const POPULATION: UserModel = UserModel {
        // Simple visual reaction is about 0.2–0.3 s in healthy adults; a
        // user who must also judge the highlight is slower.
        reaction_ms: (450.0, 120.0),
        // Well inside the default 40 ms and 500 ms boundaries: a long
        // burst falls under 500 ms about once in 160.
        short_ms: (150.0, 35.0),
        long_ms: (800.0, 120.0),
        gap_ms: (300.0, 60.0),
        error_rate: 0.05,
        miss_rate: 0.10,
        hold_sd: 0.10,
        between_users: 0.20,
        slip_rate: 0.0,
        hold_capacity_ms: f64::INFINITY,
    };

    /// One participant drawn from the population: their own mean reaction
    /// time; the rest as the population.
    pub fn participant(&self, seed: u64) -> UserModel {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let factor = LogNormal::new(0.0, self.between_users)
            .map(|d| d.sample(&mut rng))
            .unwrap_or(1.0);
        UserModel {
            reaction_ms: (self.reaction_ms.0 * factor, self.reaction_ms.1 * factor),
            ..*self
        }
    }
}

/// A reaction time drawn from a log-normal of `(mean, sd)` ms, kept
/// within 100–5000 ms.
pub fn reaction_ms((mean, sd): (f64, f64), rng: &mut ChaCha8Rng) -> u32 {
    let sigma2 = (1.0 + (sd / mean).powi(2)).ln();
    let mu = mean.ln() - sigma2 / 2.0;
    let ms = LogNormal::new(mu, sigma2.sqrt())
        .map(|d| d.sample(rng))
        .unwrap_or(mean);
    ms.clamp(100.0, 5000.0) as u32
}

/// How one run of a task went.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct TaskRun {
    /// From the start (detection mode, nothing held) to the end of the
    /// last move, s.
    pub completion_s: f64,
    /// Time the arm was commanded to move (a breath held in command mode), s.
    pub moving_s: f64,
    /// Modes entered.
    pub selections: u32,
    /// Modes entered that were not the one wanted.
    pub wrong_selections: u32,
    /// ASP: sequences reset; BSP: target highlights let pass.
    pub retries: u32,
    /// The run hit the time cap before finishing (never expected).
    pub timed_out: bool,
    /// Selections started in command mode by a slip.
    pub slips: u32,
    /// Selections started in command mode on purpose (motion onset on and
    /// a sequence of short bursts only: no need to wait).
    pub direct_switches: u32,
    /// Distance the arm was commanded to move while the user was entering
    /// a selection (motion nobody wanted), mm.
    pub unintended_mm: f64,
    /// The same for rotation, rad.
    pub unintended_rad: f64,
    /// ASP: time from deciding to select a mode to being in it, summed
    /// over the run's mode changes (retries and wrong selections
    /// included), s.
    pub selecting_s: f64,
    /// ASP: the mode changes `selecting_s` sums.
    pub selections_timed: u32,
}

/// Longest a task may take in simulation before it is abandoned, ticks.
const MAX_TASK_TICKS: u64 = 30 * 60 * 1000;
/// Rest after a hold before the user considers the next step, ms.
const AFTER_HOLD_MS: u32 = 250;
/// Rest between the holds of one move too long for one breath, ms (well
/// inside any inactivity timeout).
const BETWEEN_HOLDS_MS: u32 = 400;

/// What the user is doing.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// Working out the next move from what the interface shows.
    Decide,
    /// A selection was made; waiting for the interface to answer until the
    /// deadline (set when the selection's last breath is out).
    AwaitMatch {
        target: Mode,
        deadline: Option<Tick>,
    },
    /// Waiting for the interface to return to detection mode.
    AwaitDetection,
    /// BSP: waiting for the target to be highlighted, letting `skip`
    /// highlights of it pass.
    AwaitHighlight { target: Mode, skip: u32 },
    /// The last move is made.
    Done,
}

struct Agent<'a> {
    user: UserModel,
    config: &'a Config,
    steps: &'a [TaskStep],
    next: usize,
    phase: Phase,
    rng: ChaCha8Rng,
    highlighted: Option<Mode>,
    run: TaskRun,
    /// ASP: when the user decided to select the mode they are selecting.
    selecting_since: Option<Tick>,
    /// The tick of the last match the interface made.
    matched_at: Tick,
}

impl Agent<'_> {
    fn normal(&mut self, (mean, sd): (f64, f64)) -> f64 {
        Normal::new(mean, sd.max(0.0))
            .map(|d| d.sample(&mut self.rng))
            .unwrap_or(mean)
    }

    fn reaction(&mut self) -> u32 {
        reaction_ms(self.user.reaction_ms, &mut self.rng)
    }

    fn burst_ms(&mut self, long: bool) -> u32 {
        let d = self.config.core().detector();
        let ms = if long {
            self.normal(self.user.long_ms)
        } else {
            self.normal(self.user.short_ms)
        };
        ms.clamp(f64::from(d.min_burst_ms) + 5.0, 5000.0) as u32
    }

    fn gap_ms(&mut self) -> u32 {
        let timeout = f64::from(self.config.core().matcher().sequence_timeout_ms);
        self.normal(self.user.gap_ms)
            .clamp(120.0, (timeout - 200.0).max(120.0)) as u32
    }

    /// Called whenever the user's breaths so far have been played; pushes
    /// at least one more step.
    fn decide(
        &mut self,
        now: Tick,
        state: ModeState,
        events: &[Event],
        signal: &mut SignalGenerator,
    ) {
        for _ in 0..4 {
            if let Some(next) = self.act(now, state, events, signal) {
                self.phase = next;
            } else {
                return;
            }
        }
        signal.push(Step::Rest { ms: 1 });
    }

    /// One decision: pushes steps and returns `None`, or returns the phase
    /// to decide in next, on this same tick.
    fn act(
        &mut self,
        now: Tick,
        state: ModeState,
        events: &[Event],
        signal: &mut SignalGenerator,
    ) -> Option<Phase> {
        let wait = |signal: &mut SignalGenerator| {
            signal.push(Step::Rest { ms: 1 });
            None
        };
        match self.phase {
            Phase::Done => wait(signal),
            Phase::Decide => {
                let Some(&step) = self.steps.get(self.next) else {
                    return Some(Phase::Done);
                };
                match state {
                    ModeState::Command(mode) if mode == step.mode => {
                        let reaction = self.reaction();
                        let hold = self.normal((
                            f64::from(step.moving_ms),
                            f64::from(step.moving_ms) * self.user.hold_sd,
                        ));
                        // With a motion onset the arm starts moving only
                        // after it: the user holds that much longer.
                        let onset = self.config.core().command().motion_onset_ms;
                        signal.push(Step::Rest { ms: reaction });
                        // A move longer than the user can hold is made of
                        // holds of at most their capacity, a breath apart.
                        let mut left = hold.max(100.0);
                        let capacity = self.user.hold_capacity_ms - f64::from(onset);
                        while left > capacity && capacity >= 100.0 {
                            signal.push(Step::Breath {
                                breath: step.breath,
                                ms: capacity as u32 + onset,
                            });
                            signal.push(Step::Rest {
                                ms: BETWEEN_HOLDS_MS,
                            });
                            left -= capacity;
                        }
                        signal.push(Step::Breath {
                            breath: step.breath,
                            ms: left.max(100.0) as u32 + onset,
                        });
                        signal.push(Step::Rest { ms: AFTER_HOLD_MS });
                        self.next += 1;
                        None
                    }
                    ModeState::Command(_) => {
                        // A sequence of short bursts only, all shorter than
                        // the motion onset, switches mode from here; anyone
                        // may also slip and start the selection too early.
                        let asp = self.config.core().interface() == Interface::Asp;
                        let direct = asp && self.switches_from_command_mode(step.mode);
                        // (No draw at a zero rate: a population that never
                        // slips draws the same numbers as without the option.)
                        let slip = asp
                            && !direct
                            && self.user.slip_rate > 0.0
                            && self.rng.random_bool(self.user.slip_rate);
                        if !(direct || slip) {
                            return Some(Phase::AwaitDetection);
                        }
                        if direct {
                            self.run.direct_switches += 1;
                        } else {
                            self.run.slips += 1;
                        }
                        self.selecting_since.get_or_insert(now);
                        self.enter_sequence(step.mode, signal);
                        self.phase = Phase::AwaitMatch {
                            target: step.mode,
                            deadline: None,
                        };
                        None
                    }
                    ModeState::Detection => match self.config.core().interface() {
                        Interface::Asp => {
                            self.selecting_since.get_or_insert(now);
                            self.enter_sequence(step.mode, signal);
                            self.phase = Phase::AwaitMatch {
                                target: step.mode,
                                deadline: None,
                            };
                            None
                        }
                        Interface::Bsp => {
                            let skip = u32::from(self.rng.random_bool(self.user.miss_rate));
                            if self.highlighted == Some(step.mode) && skip == 0 {
                                self.puff(signal);
                                self.phase = Phase::AwaitMatch {
                                    target: step.mode,
                                    deadline: None,
                                };
                                return None;
                            }
                            self.run.retries += skip;
                            Some(Phase::AwaitHighlight {
                                target: step.mode,
                                skip,
                            })
                        }
                    },
                }
            }
            Phase::AwaitDetection => {
                if state == ModeState::Detection {
                    Some(Phase::Decide)
                } else {
                    wait(signal)
                }
            }
            Phase::AwaitHighlight { target, skip } => {
                if state != ModeState::Detection {
                    return Some(Phase::Decide);
                }
                let seen = events
                    .iter()
                    .any(|e| matches!(e, Event::Highlight { mode } if *mode == target));
                if !seen {
                    return wait(signal);
                }
                if skip > 0 {
                    self.phase = Phase::AwaitHighlight {
                        target,
                        skip: skip - 1,
                    };
                    return wait(signal);
                }
                self.puff(signal);
                self.phase = Phase::AwaitMatch {
                    target,
                    deadline: None,
                };
                None
            }
            Phase::AwaitMatch { target, deadline } => {
                for event in events {
                    match event {
                        Event::Match {
                            target: matched, ..
                        } if matched.mode() == Some(target) => {
                            if let Some(since) = self.selecting_since.take() {
                                self.run.selecting_s +=
                                    self.matched_at.saturating_sub(since) as f64 / 1000.0;
                                self.run.selections_timed += 1;
                            }
                            return Some(Phase::Decide);
                        }
                        Event::Match { .. } => {
                            self.run.wrong_selections += 1;
                            return Some(Phase::AwaitDetection);
                        }
                        Event::Reset { .. } => {
                            self.run.retries += 1;
                            return Some(Phase::Decide);
                        }
                        _ => {}
                    }
                }
                match deadline {
                    None => {
                        let wait_ms =
                            u64::from(self.config.core().matcher().sequence_timeout_ms) + 500;
                        self.phase = Phase::AwaitMatch {
                            target,
                            deadline: Some(now + wait_ms),
                        };
                        wait(signal)
                    }
                    Some(d) if now >= d => Some(Phase::Decide),
                    Some(_) => wait(signal),
                }
            }
        }
    }

    /// With `motion_onset_ms`, whether the sequence for `mode` can be
    /// entered in command mode without moving the arm: each of its bursts
    /// (mean + 4 SD of its class) shorter than the onset.
    fn switches_from_command_mode(&self, mode: Mode) -> bool {
        let onset = f64::from(self.config.core().command().motion_onset_ms);
        let longest = |(mean, sd): (f64, f64)| mean + 4.0 * sd;
        let (short, long) = (longest(self.user.short_ms), longest(self.user.long_ms));
        onset > 0.0
            && self
                .config
                .core()
                .sequences()
                .iter()
                .filter(|e| e.target.mode() == Some(mode))
                .find_map(SequenceEntry::breaths)
                .is_some_and(|actions| {
                    actions
                        .as_slice()
                        .iter()
                        .all(|a| onset > if a.is_long() { long } else { short })
                })
    }

    /// ASP: the library's first sequence for `mode`, breathed with this
    /// user's timing; sometimes one burst in the wrong length class.
    fn enter_sequence(&mut self, mode: Mode, signal: &mut SignalGenerator) {
        let Some(breaths) = self
            .config
            .core()
            .sequences()
            .iter()
            .filter(|e| e.target.mode() == Some(mode))
            .find_map(SequenceEntry::breaths)
        else {
            // Not in the library: nothing to breathe; the caller waits.
            signal.push(Step::Rest { ms: 1 });
            return;
        };
        let actions: Vec<Action> = breaths.as_slice().to_vec();
        let wrong = self
            .rng
            .random_bool(self.user.error_rate)
            .then(|| self.rng.random_range(0..actions.len()));
        signal.push(Step::Rest {
            ms: self.reaction(),
        });
        for (i, action) in actions.iter().enumerate() {
            let long = action.is_long() != (wrong == Some(i));
            let ms = self.burst_ms(long);
            signal.push(Step::Breath {
                breath: action.breath(),
                ms,
            });
            let gap = self.gap_ms();
            signal.push(Step::Rest { ms: gap });
        }
    }

    /// BSP: a short puff after a reaction to the highlight; sometimes one
    /// dwell late.
    fn puff(&mut self, signal: &mut SignalGenerator) {
        let mut reaction = self.reaction();
        if self.rng.random_bool(self.user.error_rate) {
            reaction += self.config.core().scanning().dwell_ms;
        }
        signal.push(Step::Rest { ms: reaction });
        let ms = self.burst_ms(false);
        signal.push(Step::Breath {
            breath: Breath::Puff,
            ms,
        });
        signal.push(Step::Rest { ms: 1 });
    }
}

/// Runs `task` with one user on one interface (the config's), tick by
/// tick through the production core and the simulated arm, from detection
/// mode at rest until the last move ends.
pub fn run_task(config: &Config, task: &Task, user: &UserModel, seed: u64) -> TaskRun {
    simulate(config, task.steps, user, study_signal(config, seed), seed).0
}

/// [`run_task`] with a sensor and person of given signal parameters (a
/// breather's), whatever the configuration reading them.
pub fn run_task_as(
    config: &Config,
    task: &Task,
    user: &UserModel,
    params: SignalParams,
    seed: u64,
) -> TaskRun {
    simulate(config, task.steps, user, params, seed).0
}

/// The study's sensor: clean breaths shaped for the configuration's
/// detector, with noise and hum.
fn study_signal(config: &Config, seed: u64) -> SignalParams {
    SignalParams::clean(config.core().detector(), seed)
        .with_noise(0.02)
        .with_hum(0.03)
}

/// The steps of `sipnpuff run`'s built-in user on the scanning interface:
/// save the home pose, forward 1.5 s, close the fingers 1.2 s and open
/// them 0.8 s, then hold a puff in `goto_point` until the pose is reached
/// (the same moves as the sequence user's).
pub const RUN_STEPS: [TaskStep; 5] = [
    TaskStep {
        mode: Mode::SavePoint,
        breath: Breath::Puff,
        moving_ms: 300,
    },
    TaskStep {
        mode: Mode::TranslateX,
        breath: Breath::Puff,
        moving_ms: 1500,
    },
    TaskStep {
        mode: Mode::Fingers,
        breath: Breath::Sip,
        moving_ms: 1200,
    },
    TaskStep {
        mode: Mode::Fingers,
        breath: Breath::Puff,
        moving_ms: 800,
    },
    TaskStep {
        mode: Mode::GotoPoint,
        breath: Breath::Puff,
        moving_ms: 2200,
    },
];

/// A scripted session for a real-time run: a user who makes no mistakes
/// does `steps` in closed loop with a simulated core; the script of
/// breaths that came out, played by the same sensor model with the same
/// seed, makes the real-time core do the same (the core is deterministic).
pub fn scripted_session(
    config: &Config,
    steps: &[TaskStep],
    seed: u64,
) -> (SignalParams, Vec<Step>) {
    let user = UserModel {
        error_rate: 0.0,
        miss_rate: 0.0,
        hold_sd: 0.0,
        ..UserModel::POPULATION
    };
    let (_, params, script) = simulate(config, steps, &user, study_signal(config, seed), seed);
    (params, script)
}

/// The closed loop: returns how it went, the sensor model and the script
/// of breaths the user made.
fn simulate(
    config: &Config,
    steps: &[TaskStep],
    user: &UserModel,
    params: SignalParams,
    seed: u64,
) -> (TaskRun, SignalParams, Vec<Step>) {
    let mut signal = SignalGenerator::live(params);
    let mut core = Pipeline::new(config.core());
    let mut arm = SimulatedJaco::new(config.core());
    let mut agent = Agent {
        user: *user,
        config,
        steps,
        next: 0,
        phase: Phase::Decide,
        rng: ChaCha8Rng::seed_from_u64(seed ^ 0x005e_1ec7),
        highlighted: None,
        run: TaskRun::default(),
        selecting_since: None,
        matched_at: 0,
    };
    let mut events: Vec<Event> = Vec::new();
    let mut state = ModeState::Detection;
    let mut moving_ticks = 0u64;
    let mut last_moving = 0u64;
    let mut unintended = false;
    let mut tick = 0u64;
    // One output, written in place each tick.
    let mut out = TickOutput::default();
    loop {
        let volts = loop {
            if let Some(v) = signal.next() {
                break v;
            }
            agent.decide(tick, state, &events, &mut signal);
            events.clear();
        };
        core.step(&TickInput::volts(tick, volts), &mut out);
        arm.tick(out.motion.arm_command.as_ref());
        for event in out.events.iter() {
            match event {
                Event::Highlight { mode } => agent.highlighted = Some(*mode),
                Event::Match { .. } => {
                    agent.run.selections += 1;
                    agent.highlighted = None;
                    agent.matched_at = tick;
                }
                _ => {}
            }
            events.push(*event);
        }
        state = out.command.state;
        // A breath of a selection that moves the arm: that motion, braking
        // included, is motion nobody wanted.
        if matches!(agent.phase, Phase::AwaitMatch { .. })
            && out.command.direction != Direction::Still
        {
            unintended = true;
        }
        if out.motion.is_still() {
            unintended = false;
        }
        if unintended {
            let norm = |v: [f64; 3]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
            agent.run.unintended_mm += norm(out.motion.linear);
            agent.run.unintended_rad += norm(out.motion.angular) / 1000.0;
        }
        if out.command.direction != Direction::Still {
            moving_ticks += 1;
            last_moving = tick;
        }
        tick += 1;
        // Done: the last hold and the rest after it have been played.
        let finished = agent.phase == Phase::Done;
        if finished || tick >= MAX_TASK_TICKS {
            agent.run.timed_out = !finished;
            break;
        }
    }
    agent.run.completion_s = (last_moving + 1) as f64 / 1000.0;
    agent.run.moving_s = moving_ticks as f64 / 1000.0;
    (agent.run, params, signal.script().to_vec())
}
