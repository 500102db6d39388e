//! Motion: the mode machine's command becomes a jerk-limited Cartesian
//! velocity for the JACO, every tick, without allocating.
//!
//! * **Modes.** A held puff or sip gives ± the configured speed on the
//!   mode's axis (translations in the base frame, rotations about the tool's
//!   axes, fingers in JACO2 finger units); release gives zero. Optionally
//!   the speed scales with the pressure.
//! * **Two channels, one line at a time.** The linear velocity is a
//!   scalar speed along one unit axis, the angular velocity a scalar rate
//!   about one unit axis (both in the base frame): the arm's
//!   [`Channel`](channel) of two degrees of freedom, which `rsruckig`
//!   shapes (velocity interface, 1 ms cycle, `Synchronization::None`), so
//!   the limits on the speed, acceleration and jerk hold for the
//!   *vectors*, exactly. An axis changes only from rest: a new direction
//!   asked for while the tool still moves another way first brakes it to
//!   rest, then starts. Targets are clamped to the speed limits (the
//!   velocity interface ignores `max_velocity`). The fingers are a channel
//!   of their own.
//! * **Save and go to point.** A puff in `save_point` stores the pose; a
//!   puff held in `goto_point` first brakes whatever still moves, then,
//!   from rest, moves there along a straight line and about one fixed axis
//!   (Ruckig's position interface on the distance and the angle,
//!   `Synchronization::Time`: both arrive together). Release brakes along
//!   the same line.
//! * **Workspace and orientation.** Before each tick, if braking one tick
//!   later could no longer stop the tool inside the workspace shrunk by
//!   `stop_margin_m` (reach sphere, base sphere, table: the margin is a
//!   normal distance, whatever the direction of travel), or inside the
//!   orientation limits (tilt cone, twist range), the target becomes zero:
//!   Ruckig brakes within the limits and the tool stops short of the
//!   boundary, never jumps.
//! * **Faults.** A sensor fault returns the mode machine to detection mode,
//!   whose target is zero: the arm brakes through Ruckig like any release.
//!   If Ruckig itself ever failed, the arm would brake on the same
//!   time-optimal jerk-limited profile computed here
//!   ([`braking::brake_step`]) until still.
//! * **At rest** nothing changes, and the work that would find so is
//!   skipped ([`rest`]).

mod boundaries;
pub mod braking;
pub mod channel;
pub mod feedback;
mod goto;
pub mod home;
pub mod limits;
pub mod orientation;
mod output;
pub mod rest;
pub mod stream;
pub mod targets;
#[cfg(test)]
mod tests;
pub mod workspace;

use nalgebra::{Isometry3, UnitQuaternion, Vector3};

use crate::control::Tick;
use crate::control::mode::{Direction, Mode, ModeState};
use crate::control::modes::ModeOutput;
use boundaries::Bounds;
use channel::{Channel, Update};
use feedback::{ArmFault, FeedbackConfig, Measurement, PoseTracker};
use home::HomeConfig;
use limits::MotionConfig;
use orientation::OrientationLimits;
use rest::RestTicks;
use stream::Decimator;
use workspace::WorkspaceConfig;

pub use boundaries::{FINGER_MARGIN, ROUNDING_GUARD};
pub use channel::CYCLE_S;
pub use output::{LOGGED_CORRECTION_M, MotionEvent, MotionOutput};

/// Closer than this to the saved point (m and rad) counts as there.
pub const AT_POINT: (f64, f64) = (1e-4, 1e-3);

/// The arm channel's degree of freedom for the speed along the line.
const LINEAR: usize = 0;
/// The arm channel's degree of freedom for the rate about the axis.
const ANGULAR: usize = 1;

/// What the arm channel's two degrees of freedom are doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Plan {
    /// Velocity interface: speeds along the axes.
    Velocity,
    /// Position interface: distance along the line and angle about the
    /// axis, from the go-to's start.
    Goto,
    /// The planner failed: every channel brakes on the fallback profile
    /// ([`braking::brake_step`]) until still, then the velocity plan
    /// resumes.
    Fallback,
}

/// Where the current `goto_point` puff stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Goto {
    /// No go-to asked, or one under way (the plan says which).
    Idle,
    /// Held: waits for the tool to come to rest, then starts.
    Waiting,
    /// This puff's go-to is over: reached, blocked, or nothing to go to.
    Done,
}

impl Goto {
    /// The puff was released: a go-to not yet started is not wanted.
    fn released(self) -> Goto {
        match self {
            Goto::Waiting => Goto::Idle,
            other => other,
        }
    }

    /// After a halt: a go-to waiting or under way (`in_goto`) starts
    /// again from rest if its puff is still held.
    fn after_halt(self, in_goto: bool) -> Goto {
        match self {
            Goto::Idle if in_goto => Goto::Waiting,
            other => other,
        }
    }
}

/// The motion layer. Construct at start-up; [`Motion::step`] is RT-safe
/// (no allocation, no panic, no clock).
pub struct Motion {
    limits: MotionConfig,
    bounds: Bounds,
    plan: Plan,
    /// The tool's trajectory: [`LINEAR`] along `axes[LINEAR]`,
    /// [`ANGULAR`] about `axes[ANGULAR]`.
    arm: Channel<2>,
    fingers: Channel<1>,
    /// The line the linear speed is along and the axis the angular rate
    /// is about (unit, base frame).
    axes: [Vector3<f64>; 2],
    /// The pose the commands lead to (integrated), base frame.
    pose: Isometry3<f64>,
    /// The finger position the commands lead to, units.
    finger_position: f64,
    /// Last tick's commanded velocity `[v (3), ω (3), fingers]`.
    last: [f64; 7],
    saved: Option<Isometry3<f64>>,
    goto: Goto,
    /// The command's direction on the last tick (a puff's start saves the
    /// point or asks for the go-to).
    previous_direction: Direction,
    decimator: Decimator,
    /// The measured pose, when the arm reports one.
    tracker: PoseTracker,
    rest: RestTicks,
}

impl std::fmt::Debug for Motion {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Motion")
            .field("plan", &self.plan)
            .field("pose", &self.pose)
            .field("fingers", &self.finger_position)
            .finish_non_exhaustive()
    }
}

impl Motion {
    /// At the configured home pose, at rest. Not RT-safe (call at start-up).
    pub fn new(limits: &MotionConfig, workspace: &WorkspaceConfig, home: &HomeConfig) -> Self {
        let l = *limits;
        let pose = home.pose();
        let orientation = OrientationLimits {
            home: pose.rotation,
            max_tilt_rad: workspace.max_tilt_rad,
            max_twist_rad: workspace.max_twist_rad,
        };
        Motion {
            limits: l,
            bounds: Bounds::new(workspace, orientation),
            plan: Plan::Velocity,
            arm: Channel::new(
                [l.linear_speed_mps, l.angular_speed_radps],
                [l.linear_acceleration_mps2, l.angular_acceleration_radps2],
                [l.linear_jerk_mps3, l.angular_jerk_radps3],
            ),
            fingers: Channel::new([l.finger_speed], [l.finger_acceleration], [l.finger_jerk]),
            axes: [Vector3::x(); 2],
            pose,
            finger_position: home.home_fingers,
            last: [0.0; 7],
            saved: None,
            goto: Goto::Idle,
            previous_direction: Direction::Still,
            decimator: Decimator::default(),
            tracker: PoseTracker::new(FeedbackConfig::default()),
            rest: RestTicks::default(),
        }
    }

    /// The same motion layer checking measured poses with `config`. Not
    /// RT-safe.
    pub fn with_feedback(mut self, config: &FeedbackConfig) -> Self {
        self.tracker = PoseTracker::new(*config);
        self
    }

    /// Runs every Ruckig update and every step of a tick at rest: the
    /// reference the skipped work is proven against.
    #[cfg(any(test, feature = "testing"))]
    pub fn use_reference_path(&mut self) {
        self.arm.use_reference_path();
        self.fingers.use_reference_path();
        self.rest.use_reference_path();
    }

    /// Work skipped so far: the arm's and the fingers' updates, and rest
    /// ticks that repeated the last one.
    #[cfg(any(test, feature = "testing"))]
    pub fn skipped(&self) -> [u64; 3] {
        [
            self.arm.skipped().get(),
            self.fingers.skipped().get(),
            self.rest.repeats().get(),
        ]
    }

    /// The arm reports its pose, measured: the first measurement, `pose`,
    /// is where the motion starts (instead of the configured home), and
    /// from now on measurements are expected ([`Motion::measure`]); their
    /// silence is a fault. Call before the first tick. RT-safe.
    pub fn start_measured(&mut self, pose: Isometry3<f64>) {
        self.rest.touched();
        self.pose = pose;
        self.tracker.start();
    }

    /// The measured-pose tracker (its figures for the report).
    pub fn feedback(&self) -> &PoseTracker {
        &self.tracker
    }

    /// A pose measured by the arm, taken at tick `now` (before the tick's
    /// step): checked against the commanded path and, if it fits, the
    /// estimate the limits use moves to agree with it. Returns the
    /// correction event to log, or the fault. RT-safe.
    pub fn measure(
        &mut self,
        now: Tick,
        measured: &Isometry3<f64>,
    ) -> Result<Option<MotionEvent>, ArmFault> {
        self.rest.touched();
        match self.tracker.measure(now, measured, &mut self.pose) {
            Some(Measurement::Fault(fault)) => Err(fault),
            Some(Measurement::Corrected { by, .. })
                if Vector3::from(by).norm() >= LOGGED_CORRECTION_M =>
            {
                Ok(Some(MotionEvent::PoseCorrected {
                    by_m: by,
                    position_m: self.pose.translation.vector.into(),
                }))
            }
            _ => Ok(None),
        }
    }

    /// Whether measurements have been silent too long at tick `now`.
    /// RT-safe.
    pub fn check_feedback(&mut self, now: Tick) -> Option<ArmFault> {
        self.tracker.check_silence(now)
    }

    /// An output with no motion at the current pose.
    pub fn idle_output(&self) -> MotionOutput {
        MotionOutput {
            pose: self.pose,
            fingers: self.finger_position,
            ..MotionOutput::default()
        }
    }

    /// The pose the commands lead to.
    pub fn pose(&self) -> Isometry3<f64> {
        self.pose
    }

    /// The saved pose, if any.
    pub fn saved(&self) -> Option<Isometry3<f64>> {
        self.saved
    }

    /// The configured limits.
    pub fn limits(&self) -> &MotionConfig {
        &self.limits
    }

    /// The orientation limits and the home orientation they start from.
    pub fn orientation_limits(&self) -> &OrientationLimits {
        self.bounds.orientation()
    }

    /// The arm has stopped on its own (no command reached it for longer
    /// than its watchdog, e.g. the process stalled): every channel is set
    /// to rest where the pose estimate stands and the next commands start
    /// from zero. A go-to under way starts again from rest if its puff is
    /// still held. RT-safe.
    pub fn halt(&mut self) {
        self.rest.touched();
        self.goto = self.goto.after_halt(self.plan == Plan::Goto);
        self.use_velocity_plan();
        self.arm.halt();
        self.fingers.halt();
        self.last = [0.0; 7];
    }

    /// One tick on the mode machine's `command`, written into `out`.
    /// RT-safe.
    pub fn step(&mut self, now: Tick, command: &ModeOutput, out: &mut MotionOutput) {
        let at_rest = self.plan == Plan::Velocity && self.arm.resting() && self.fingers.resting();
        if command.direction == Direction::Still && at_rest {
            self.rest_tick(now, out);
        } else {
            self.move_tick(now, command, out);
        }
    }

    /// A tick asking for no motion with both channels resting, reduced to
    /// its effects ([`rest`]): whatever the mode, nothing is requested,
    /// the updates are skipped and the tick ends as every tick does.
    fn rest_tick(&mut self, now: Tick, out: &mut MotionOutput) {
        if self.rest.repeats_last() {
            self.arm.skip();
            self.fingers.skip();
            self.tracker.record(now, &self.pose, true);
            self.write_output(now, self.last, self.last, [None; 2], out);
            return;
        }
        self.previous_direction = Direction::Still;
        self.goto = self.goto.released();
        self.arm.block(LINEAR, None);
        self.arm.block(ANGULAR, None);
        self.fingers.block(0, None);
        self.arm.ask_velocities([0.0; 2]);
        self.fingers.ask_velocities([0.0]);
        self.arm.skip();
        self.fingers.skip();
        let before = rest::pose_bits(&self.pose, self.finger_position);
        self.finish_tick(now, false, [None; 2], out);
        let after = rest::pose_bits(&self.pose, self.finger_position);
        self.rest.rested(&self.last, before == after);
    }

    /// Any other tick: the request becomes targets, the channels update,
    /// the pose moves.
    fn move_tick(&mut self, now: Tick, command: &ModeOutput, out: &mut MotionOutput) {
        self.rest.touched();
        let mut events = [None; 2];
        let mut emit = |e: MotionEvent| {
            if let Some(slot) = events.iter_mut().find(|s| s.is_none()) {
                *slot = Some(e);
            }
        };

        let mode = match command.state {
            ModeState::Command(mode) => Some(mode),
            ModeState::Detection => None,
        };
        let direction = command.direction.sign();
        let pressed = command.direction == Direction::Positive
            && self.previous_direction != Direction::Positive;
        self.previous_direction = command.direction;
        let scale = self.speed_scale(command);

        let l = self.limits;
        let mut linear = None;
        let mut angular = None;
        let mut fingers = 0.0;
        let tool_axis = |axis: Vector3<f64>| self.pose.rotation * axis;
        match (mode, command.direction) {
            (_, Direction::Still) | (None, _) => {}
            (Some(Mode::TranslateX), _) => linear = Some((Vector3::x(), l.linear_speed_mps)),
            (Some(Mode::TranslateY), _) => linear = Some((Vector3::y(), l.linear_speed_mps)),
            (Some(Mode::TranslateZ), _) => linear = Some((Vector3::z(), l.linear_speed_mps)),
            (Some(Mode::RotateX), _) => {
                angular = Some((tool_axis(Vector3::x()), l.angular_speed_radps));
            }
            (Some(Mode::RotateY), _) => {
                angular = Some((tool_axis(Vector3::y()), l.angular_speed_radps));
            }
            (Some(Mode::RotateZ), _) => {
                angular = Some((tool_axis(Vector3::z()), l.angular_speed_radps));
            }
            // Puff opens (towards 0), sip closes.
            (Some(Mode::Fingers), _) => fingers = -direction * l.finger_speed * scale,
            (Some(Mode::SavePoint), _) => {
                if pressed {
                    self.saved = Some(self.pose);
                    emit(MotionEvent::Saved {
                        position: self.pose.translation.vector.into(),
                    });
                }
            }
            (Some(Mode::GotoPoint), _) => {
                if pressed {
                    self.goto = Goto::Waiting;
                }
            }
            // The pointer's modes move the pointer, never the arm.
            (Some(Mode::PointerX | Mode::PointerY | Mode::Scroll), _) => {}
        }
        // A request: (signed unit direction, speed).
        let linear = linear.map(|(axis, speed)| (axis * direction, speed * scale));
        let angular = angular.map(|(axis, speed)| (axis * direction, speed * scale));

        let goto_held = mode == Some(Mode::GotoPoint) && command.direction == Direction::Positive;
        if !goto_held {
            self.goto = self.goto.released();
            if self.plan == Plan::Goto {
                self.brake_goto(); // released: brake along the line
            }
        }
        if self.goto == Goto::Waiting
            && self.plan != Plan::Fallback
            && let Some(event) = self.try_start_goto()
        {
            emit(event);
        }
        if self.plan == Plan::Goto
            && let Some(boundary) = self.goto_blocked()
        {
            self.brake_goto();
            self.goto = Goto::Done;
            emit(MotionEvent::WorkspaceLimit { boundary });
        }

        // Zero targets outside a go-to: Ruckig is asked for nothing.
        let mut arm_asked_nothing = false;
        if self.plan != Plan::Goto {
            let (speed, boundary) = self.arm_target(LINEAR, linear);
            if let Some(boundary) = boundary {
                emit(MotionEvent::WorkspaceLimit { boundary });
            }
            let (rate, boundary) = self.arm_target(ANGULAR, angular);
            if let Some(boundary) = boundary {
                emit(MotionEvent::WorkspaceLimit { boundary });
            }
            self.arm.ask_velocities([speed, rate]);
            arm_asked_nothing = speed == 0.0 && rate == 0.0;
        }
        if let Some(boundary) = self.hold_fingers_at_end(&mut fingers) {
            emit(MotionEvent::WorkspaceLimit { boundary });
        }
        let finger_target = finite_or_zero(fingers).clamp(-l.finger_speed, l.finger_speed);
        self.fingers.ask_velocities([finger_target]);

        if let Some(event) = self.update_channels(arm_asked_nothing, finger_target == 0.0) {
            emit(event);
        }
        let reached = self.plan == Plan::Goto && self.goto == Goto::Done;
        if reached {
            emit(MotionEvent::GotoReached);
        }
        self.finish_tick(now, reached, events, out);
    }

    /// The end of every tick: the commanded twist integrated into the
    /// pose, the tracker and the arm's stream fed, the output written.
    fn finish_tick(
        &mut self,
        now: Tick,
        reached: bool,
        events: [Option<MotionEvent>; 2],
        out: &mut MotionOutput,
    ) {
        let twist = self.twist();
        let mut mean = [0.0; 7];
        for ((m, last), now) in mean.iter_mut().zip(self.last).zip(twist) {
            *m = (last + now) / 2.0;
        }
        self.last = twist;
        self.integrate(&mean);
        let still = twist == [0.0; 7] && mean == [0.0; 7];
        self.tracker.record(now, &self.pose, still);
        if reached {
            self.use_velocity_plan();
        }
        self.write_output(now, twist, mean, events, out);
    }

    /// The tick's output: its twist, the pose, the arm's stream fed with
    /// the tick's mean velocity.
    fn write_output(
        &mut self,
        now: Tick,
        twist: [f64; 7],
        mean: [f64; 7],
        events: [Option<MotionEvent>; 2],
        out: &mut MotionOutput,
    ) {
        let [vx, vy, vz, wx, wy, wz, fingers] = twist;
        out.linear = [vx, vy, vz];
        out.angular = [wx, wy, wz];
        out.fingers_velocity = fingers;
        out.pose = self.pose;
        out.fingers = self.finger_position;
        out.arm_command = self.decimator.push(now, mean);
        out.recalculated = self.arm.recalculated() || self.fingers.recalculated();
        out.events = events;
    }

    /// Runs both channels one cycle (each skipped where it rests and is
    /// asked nothing); if either fails, brakes on the fallback profile
    /// until still.
    fn update_channels(
        &mut self,
        arm_asked_nothing: bool,
        fingers_asked_nothing: bool,
    ) -> Option<MotionEvent> {
        let was_falling_back = self.plan == Plan::Fallback;
        if !was_falling_back {
            let arm = self.arm.update(arm_asked_nothing);
            if arm == Update::Finished && self.plan == Plan::Goto {
                self.goto = Goto::Done;
            }
            let failed = arm == Update::Failed
                || self.fingers.update(fingers_asked_nothing) == Update::Failed;
            if !failed {
                return None;
            }
        }
        self.brake_without_planner();
        (!was_falling_back).then_some(MotionEvent::TrajectoryError)
    }

    /// One cycle of braking every channel on the time-optimal jerk-limited
    /// profile with the full limits (the planner failed). Braking is
    /// always inside the workspace: each tick's checks kept room for it.
    fn brake_without_planner(&mut self) {
        self.use_velocity_plan();
        self.plan = Plan::Fallback;
        self.goto = self.goto.released();
        let l = self.limits;
        let arm_still = self.arm.brake_without_planner(
            [l.linear_acceleration_mps2, l.angular_acceleration_radps2],
            [l.linear_jerk_mps3, l.angular_jerk_radps3],
        );
        let fingers_still = self
            .fingers
            .brake_without_planner([l.finger_acceleration], [l.finger_jerk]);
        if arm_still && fingers_still {
            self.plan = Plan::Velocity; // Ruckig starts again from rest
        }
    }

    /// The arm channel back to the velocity plan.
    fn use_velocity_plan(&mut self) {
        self.plan = Plan::Velocity;
        self.arm.use_velocity_interface();
    }

    /// This tick's commanded velocity: `[v (3), ω (3), fingers]`, base frame.
    fn twist(&self) -> [f64; 7] {
        let [linear_axis, angular_axis] = self.axes;
        let v = linear_axis * self.arm.velocity(LINEAR);
        let w = angular_axis * self.arm.velocity(ANGULAR);
        [v.x, v.y, v.z, w.x, w.y, w.z, self.fingers.velocity(0)]
    }

    /// Integrates the tick's mean velocity into the pose estimate.
    fn integrate(&mut self, mean: &[f64; 7]) {
        let [vx, vy, vz, wx, wy, wz, fingers] = *mean;
        let (v, w) = (Vector3::new(vx, vy, vz), Vector3::new(wx, wy, wz));
        self.pose.translation.vector += v * CYCLE_S;
        self.pose.rotation = UnitQuaternion::from_scaled_axis(w * CYCLE_S) * self.pose.rotation;
        self.finger_position += fingers * CYCLE_S;
    }
}

/// NaN and ±∞ become 0 (no motion).
fn finite_or_zero(x: f64) -> f64 {
    if x.is_finite() { x } else { 0.0 }
}
