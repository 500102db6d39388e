//! Motion: the mode machine's command becomes a jerk-limited Cartesian
//! velocity for the JACO, every tick, without allocating.
//!
//! * **Modes.** A held puff or sip gives ± the configured speed on the
//!   mode's axis (translations in the base frame, rotations about the tool's
//!   axes, fingers in JACO2 finger units); release gives zero. Optionally
//!   the speed scales with the pressure.
//! * **One line at a time.** The linear velocity is a scalar speed along
//!   one unit axis, the angular velocity a scalar rate about one unit axis
//!   (both in the base frame). `rsruckig` shapes the two scalars (velocity
//!   interface, 1 ms cycle, `Synchronization::None`), so the limits on the
//!   speed, acceleration and jerk hold for the *vectors*, exactly. An axis
//!   changes only from rest: a new direction asked for while the tool still
//!   moves another way first brakes it to rest, then starts. Targets are
//!   clamped to the speed limits (the velocity interface ignores
//!   `max_velocity`). Fingers have their own one-axis Ruckig.
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

mod boundaries;
pub mod braking;
pub mod feedback;
mod goto;
pub mod home;
pub mod limits;
pub mod orientation;
pub mod still;
pub mod stream;
mod targets;
pub mod workspace;

use nalgebra::{Isometry3, UnitQuaternion, Vector3};
use rsruckig::prelude::*;
use serde::{Serialize, Serializer};

use crate::control::Tick;
use crate::control::mode::{Direction, Mode, ModeState};
use crate::control::modes::ModeOutput;
use feedback::{ArmFault, FeedbackConfig, Measurement, PoseTracker};
use home::HomeConfig;
use limits::MotionConfig;
use orientation::{OrientationLimits, RoomGeometry};
use stream::{ArmCommand, Decimator};
use workspace::{Boundary, WorkspaceConfig};

/// The control cycle, s.
pub const CYCLE_S: f64 = 0.001;
/// Finger travel kept at each end, units.
pub const FINGER_MARGIN: f64 = 10.0;
/// From rest, the tool does not start towards a boundary with less room
/// than this past the stop margin, m (no creeping by fractions of a mm).
pub const MIN_START_M: f64 = 0.002;
/// From rest, the tool does not start turning towards an orientation limit
/// with less room than this, rad.
pub const MIN_START_RAD: f64 = 0.002;
/// Kept inside the stop margin and the orientation limits for rounding
/// (the pose is integrated tick by tick), m or rad.
pub const ROUNDING_GUARD: f64 = 1e-6;
/// Closer than this to the saved point (m and rad) counts as there.
pub const AT_POINT: (f64, f64) = (1e-4, 1e-3);

/// Ruckig's degree of freedom for the speed along the linear axis.
const LINEAR: usize = 0;
/// Ruckig's degree of freedom for the rate about the angular axis.
const ANGULAR: usize = 1;

/// Something the motion layer reports. Serialized as an event-log entry
/// (`{"event":"saved",…}`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum MotionEvent {
    /// The pose was saved.
    Saved {
        /// Saved position, m.
        position: [f64; 3],
    },
    /// Moving to the saved pose.
    GotoStarted {
        /// Straight-line distance, m.
        distance_m: f64,
        /// Rotation, rad.
        angle_rad: f64,
    },
    /// The saved pose was reached.
    GotoReached,
    /// `goto_point` with nothing saved: nothing moves.
    #[serde(serialize_with = "no_saved_point")]
    NoSavedPoint,
    /// `goto_point` while already at the saved pose.
    #[serde(rename = "at_saved_point")]
    AlreadyAtSavedPoint,
    /// Motion stopped at a boundary.
    WorkspaceLimit {
        /// Which one.
        boundary: Boundary,
    },
    /// The trajectory generator failed (unreachable with a validated
    /// config): the arm brakes on the fallback profile until still.
    #[serde(serialize_with = "trajectory_error")]
    TrajectoryError,
    /// The measured pose moved the estimate by at least
    /// [`LOGGED_CORRECTION_M`]: the limits now see where the arm really is.
    PoseCorrected {
        /// The translation added to the estimate, m.
        by_m: [f64; 3],
        /// The corrected position, m, base frame.
        position_m: [f64; 3],
    },
}

/// Corrections from the measured pose this large are logged, m (smaller
/// ones are the arm's noise and lag).
pub const LOGGED_CORRECTION_M: f64 = 0.002;

/// The event log says why nothing moves.
fn no_saved_point<S: Serializer>(serializer: S) -> Result<S::Ok, S::Error> {
    Reason {
        reason: "goto_point: no pose has been saved",
    }
    .serialize(serializer)
}

/// The event log says what the arm does instead.
fn trajectory_error<S: Serializer>(serializer: S) -> Result<S::Ok, S::Error> {
    Reason {
        reason: "trajectory generator failed; braking jerk-limited until still",
    }
    .serialize(serializer)
}

/// A constant explanation beside an event's name.
#[derive(Serialize)]
struct Reason {
    reason: &'static str,
}

impl MotionOutput {
    /// The commanded velocity as `[vx, vy, vz, wx, wy, wz, fingers]`.
    pub fn velocity(&self) -> [f64; 7] {
        let [vx, vy, vz] = self.linear;
        let [wx, wy, wz] = self.angular;
        [vx, vy, vz, wx, wy, wz, self.fingers_velocity]
    }

    /// Nothing is commanded to move.
    pub fn is_still(&self) -> bool {
        self.velocity() == [0.0; 7]
    }
}

/// The motion layer's output for one tick. `Copy`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MotionOutput {
    /// Commanded linear velocity, m/s, base frame.
    pub linear: [f64; 3],
    /// Commanded angular velocity, rad/s, base frame.
    pub angular: [f64; 3],
    /// Commanded finger velocity, units/s (positive closes).
    pub fingers_velocity: f64,
    /// The pose the commands lead to (integrated), base frame.
    pub pose: Isometry3<f64>,
    /// The finger position the commands lead to, units.
    pub fingers: f64,
    /// A command for the arm, every 10 ticks.
    pub arm_command: Option<ArmCommand>,
    /// Ruckig computed a new trajectory on this tick (a new target).
    pub recalculated: bool,
    /// At most two events per tick.
    pub events: [Option<MotionEvent>; 2],
}

/// What Ruckig's two degrees of freedom are doing.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Plan {
    /// Velocity interface: speeds along the axes.
    Velocity,
    /// Position interface: distance along the line and angle about the
    /// axis, from the goto's start.
    Goto,
}

type Otg<const N: usize> = Ruckig<N, ThrowErrorHandler>;

/// The motion layer. Construct at start-up; [`Motion::step`] is RT-safe
/// (no allocation, no panic, no clock).
pub struct Motion {
    limits: MotionConfig,
    workspace: WorkspaceConfig,
    orientation: OrientationLimits,
    /// What the angular room takes from `orientation`, worked out once.
    orientation_room: RoomGeometry,
    otg: Otg<2>,
    input: InputParameter<2>,
    output: OutputParameter<2>,
    finger_otg: Otg<1>,
    finger_input: InputParameter<1>,
    finger_output: OutputParameter<1>,
    plan: Plan,
    /// The line the linear speed is along (unit, base frame).
    linear_axis: Vector3<f64>,
    /// The axis the angular rate is about (unit, base frame).
    angular_axis: Vector3<f64>,
    /// Ruckig failed: braking on the fallback profile until still.
    fallback: bool,
    pose: Isometry3<f64>,
    fingers: f64,
    /// Last tick's commanded velocity `[v (3), ω (3), fingers]`.
    last: [f64; 7],
    saved: Option<Isometry3<f64>>,
    /// A requested linear direction held off by a boundary.
    linear_blocked: Option<Vector3<f64>>,
    /// A requested turning direction held off by an orientation limit.
    angular_blocked: Option<Vector3<f64>>,
    /// A requested finger direction held off by an end.
    finger_blocked: Option<f64>,
    /// `goto_point` is held and waits for the tool to come to rest.
    goto_pending: bool,
    /// The current goto puff is done with (reached, blocked, nothing saved).
    goto_done: bool,
    previous_direction: Direction,
    decimator: Decimator,
    /// The measured pose, when the arm reports one.
    tracker: PoseTracker,
    /// The arm's trajectory (linear and angular) is at rest and its last
    /// update changed nothing (every velocity and acceleration, now and
    /// asked, zero; Ruckig's own state the same). Until its next update,
    /// nothing changes its Ruckig's state but the targets — what would
    /// ([`Motion::halt`], the switch of plans, a start from rest towards a
    /// new direction) clears this — so while its targets stay zero an
    /// update would compute nothing again and give back the same still
    /// state: it is skipped, whatever the fingers do
    /// (`tests/it/fast_paths.rs` runs both paths side by side; debug
    /// builds check every skip against Ruckig's own comparison). Off with
    /// [`Motion::always_update`].
    arm_rest: bool,
    /// The same for the fingers' trajectory, whatever the arm does.
    finger_rest: bool,
    /// The inputs of the updates that found each trajectory at rest
    /// (debug builds: every skip is checked against them).
    #[cfg(debug_assertions)]
    rest_inputs: (InputParameter<2>, InputParameter<1>),
    /// Never skip an update or a pose step (the reference path of the
    /// equivalence tests).
    always_update: bool,
    /// Ticks whose updates were skipped at rest.
    skipped_updates: u64,
    /// Updates of one trajectory skipped at rest while the other ran.
    skipped_single_updates: u64,
    /// Rest ticks that repeated the last one ([`Motion::still_rest`]).
    still_repeats: u64,
    /// The zero-velocity step (velocities and pose) known to leave the
    /// pose as it is.
    still_step: still::StillStep,
    /// The last tick rested ([`Motion::rest_into`]) with every velocity a
    /// zero (of either sign) at a pose a step at those very velocities is
    /// known to leave as it is; nothing has changed since (every other
    /// change of the pose or the velocities clears it). The next rest
    /// tick is then the same tick again.
    still_rest: bool,
    /// Each channel's last question of braking (linear, angular,
    /// fingers): cruising, the same one comes every tick.
    brake_rooms: [braking::BrakeRoomMemo; 3],
    /// Questions of braking answered again ([`Motion::brake_room`]).
    brake_room_repeats: u64,
}

impl std::fmt::Debug for Motion {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Motion")
            .field("plan", &self.plan)
            .field("pose", &self.pose)
            .field("fingers", &self.fingers)
            .finish_non_exhaustive()
    }
}

impl Motion {
    /// At the configured home pose, at rest. Not RT-safe (call at start-up).
    pub fn new(limits: &MotionConfig, workspace: &WorkspaceConfig, home: &HomeConfig) -> Self {
        let limits = *limits;
        let mut input = InputParameter::new(None);
        input.control_interface = ControlInterface::Velocity;
        input.synchronization = Synchronization::None;
        set_all(
            &mut input.max_velocity,
            [limits.linear_speed_mps, limits.angular_speed_radps],
        );
        set_all(
            &mut input.max_acceleration,
            [
                limits.linear_acceleration_mps2,
                limits.angular_acceleration_radps2,
            ],
        );
        set_all(
            &mut input.max_jerk,
            [limits.linear_jerk_mps3, limits.angular_jerk_radps3],
        );
        let mut finger_input = InputParameter::new(None);
        finger_input.control_interface = ControlInterface::Velocity;
        finger_input.synchronization = Synchronization::None;
        finger_input.max_velocity.fill(limits.finger_speed);
        finger_input
            .max_acceleration
            .fill(limits.finger_acceleration);
        finger_input.max_jerk.fill(limits.finger_jerk);
        let pose = home.pose();
        let orientation = OrientationLimits {
            home: pose.rotation,
            max_tilt_rad: workspace.max_tilt_rad,
            max_twist_rad: workspace.max_twist_rad,
        };
        #[cfg(debug_assertions)]
        let rest_inputs = (input.clone(), finger_input.clone());
        Motion {
            limits,
            workspace: *workspace,
            orientation,
            orientation_room: RoomGeometry::new(&orientation),
            otg: Otg::new(None, CYCLE_S),
            input,
            output: OutputParameter::new(None),
            finger_otg: Otg::new(None, CYCLE_S),
            finger_input,
            finger_output: OutputParameter::new(None),
            plan: Plan::Velocity,
            linear_axis: Vector3::x(),
            angular_axis: Vector3::x(),
            fallback: false,
            pose,
            fingers: home.home_fingers,
            last: [0.0; 7],
            saved: None,
            linear_blocked: None,
            angular_blocked: None,
            finger_blocked: None,
            goto_pending: false,
            goto_done: false,
            previous_direction: Direction::Still,
            decimator: Decimator::default(),
            tracker: PoseTracker::new(FeedbackConfig::default()),
            arm_rest: false,
            finger_rest: false,
            #[cfg(debug_assertions)]
            rest_inputs,
            always_update: false,
            skipped_updates: 0,
            skipped_single_updates: 0,
            still_repeats: 0,
            still_step: still::StillStep::default(),
            still_rest: false,
            brake_rooms: Default::default(),
            brake_room_repeats: 0,
        }
    }

    /// Ticks on which the Ruckig updates were skipped at rest.
    pub fn skipped_updates(&self) -> u64 {
        self.skipped_updates
    }

    /// Updates of one trajectory skipped at rest while the other ran
    /// (the arm's while the fingers move, or the fingers' while the arm
    /// does): the equivalence tests show they ran.
    #[doc(hidden)]
    pub fn skipped_single_updates(&self) -> u64 {
        self.skipped_single_updates
    }

    /// Rest ticks that repeated the last one (no twist, mean or pose
    /// step): the equivalence tests show they ran.
    #[doc(hidden)]
    pub fn still_repeats(&self) -> u64 {
        self.still_repeats
    }

    /// Questions of braking answered again, not computed (the
    /// equivalence tests show they ran).
    #[doc(hidden)]
    pub fn brake_room_repeats(&self) -> u64 {
        self.brake_room_repeats
    }

    /// Runs every Ruckig update and every pose step, at rest too: the
    /// reference the skipped work is proven against. Not for production.
    #[doc(hidden)]
    pub fn always_update(&mut self) {
        self.always_update = true;
    }

    /// The same motion layer checking measured poses with `config`. Not
    /// RT-safe.
    pub fn with_feedback(mut self, config: &FeedbackConfig) -> Self {
        self.tracker = PoseTracker::new(*config);
        self
    }

    /// The arm reports its pose, measured: the first measurement, `pose`,
    /// is where the motion starts (instead of the configured home), and
    /// from now on measurements are expected ([`Motion::measure`]); their
    /// silence is a fault. Call before the first tick. RT-safe.
    pub fn start_measured(&mut self, pose: Isometry3<f64>) {
        self.still_rest = false;
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
        self.still_rest = false;
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

    /// An output with no motion at the current pose (a placeholder before
    /// [`Motion::step`] fills the real one).
    pub fn idle_output(&self) -> MotionOutput {
        MotionOutput {
            linear: [0.0; 3],
            angular: [0.0; 3],
            fingers_velocity: 0.0,
            pose: self.pose,
            fingers: self.fingers,
            arm_command: None,
            recalculated: false,
            events: [None; 2],
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
        &self.orientation
    }

    /// The arm has stopped on its own (no command reached it for longer
    /// than its watchdog, e.g. the process stalled): every channel is set
    /// to rest where the pose estimate stands and the next commands start
    /// from zero. A go-to under way starts again from rest if its puff is
    /// still held. RT-safe.
    pub fn halt(&mut self) {
        self.still_rest = false;
        self.arm_rest = false;
        self.finger_rest = false;
        self.goto_pending = !self.goto_done && (self.plan == Plan::Goto || self.goto_pending);
        self.switch_to_velocity_plan();
        self.fallback = false;
        for input in [
            &mut self.input.current_velocity,
            &mut self.input.current_acceleration,
        ] {
            input.fill(0.0);
        }
        self.input.target_velocity.fill(0.0);
        self.finger_input.current_velocity.fill(0.0);
        self.finger_input.current_acceleration.fill(0.0);
        self.finger_input.target_velocity.fill(0.0);
        self.last = [0.0; 7];
    }

    /// One tick. RT-safe.
    pub fn step(&mut self, now: Tick, command: &ModeOutput) -> MotionOutput {
        let mut out = self.idle_output();
        self.step_into(now, command, &mut out);
        out
    }

    /// [`Motion::step`], writing the output in place (the pipeline's
    /// tick output holds it: no copy of it a tick). RT-safe.
    #[inline]
    pub fn step_into(&mut self, now: Tick, command: &ModeOutput, out: &mut MotionOutput) {
        if command.direction == Direction::Still && self.resting() {
            if self.still_rest {
                self.still_into(now, out);
            } else {
                self.rest_into(now, out);
            }
        } else {
            self.move_into(now, command, out);
        }
    }

    /// [`Motion::step_into`] on any other tick: every stage. (Not
    /// inlined: the rest path then saves none of its registers.)
    #[inline(never)]
    fn move_into(&mut self, now: Tick, command: &ModeOutput, out: &mut MotionOutput) {
        self.still_rest = false;
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
        let scale = self.speed_scale(command.strength_volts);

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
                    self.goto_done = false;
                    self.goto_pending = true;
                }
            }
        }
        // A request: (signed unit direction, speed).
        let linear = linear.map(|(axis, speed)| (axis * direction, speed * scale));
        let angular = angular.map(|(axis, speed)| (axis * direction, speed * scale));

        let goto_held = mode == Some(Mode::GotoPoint) && command.direction == Direction::Positive;
        if !goto_held {
            self.goto_pending = false;
            if self.plan == Plan::Goto {
                self.brake_goto(); // released: brake along the line
            }
        }
        if self.goto_pending
            && !self.fallback
            && let Some(event) = self.try_start_goto()
        {
            emit(event);
        }
        if self.plan == Plan::Goto
            && let Some(boundary) = self.goto_blocked()
        {
            self.brake_goto();
            self.goto_done = true;
            emit(MotionEvent::WorkspaceLimit { boundary });
        }

        // Zero targets in the velocity plan: Ruckig is asked for nothing.
        let mut arm_asked_nothing = false;
        if self.plan == Plan::Velocity {
            let (speed, boundary) = self.linear_target(linear);
            if let Some(boundary) = boundary {
                emit(MotionEvent::WorkspaceLimit { boundary });
            }
            let (rate, boundary) = self.angular_target(angular);
            if let Some(boundary) = boundary {
                emit(MotionEvent::WorkspaceLimit { boundary });
            }
            set_all(&mut self.input.target_velocity, [speed, rate]);
            self.input.target_acceleration.fill(0.0);
            arm_asked_nothing = speed == 0.0 && rate == 0.0;
        }
        if let Some(boundary) = self.hold_fingers_at_end(&mut fingers) {
            emit(MotionEvent::WorkspaceLimit { boundary });
        }
        let finger_target = finite_or_zero(fingers).clamp(-l.finger_speed, l.finger_speed);
        self.finger_input.target_velocity.fill(finger_target);
        let fingers_asked_nothing = finger_target == 0.0;

        if let Some(event) = self.update_trajectories(arm_asked_nothing, fingers_asked_nothing) {
            emit(event);
        }
        let reached = self.plan == Plan::Goto && self.goto_done;
        if reached {
            emit(MotionEvent::GotoReached);
        }
        self.finish_tick(now, reached, events, out);
    }

    /// Both trajectories rest untouched since the update that found them
    /// still ([`Motion::at_rest`]), in the velocity plan, not braking on
    /// the fallback: a tick that asks for no motion then changes nothing
    /// but what [`Motion::rest_into`] does.
    fn resting(&self) -> bool {
        self.arm_rest && self.finger_rest && !self.fallback && self.plan == Plan::Velocity
    }

    /// [`Motion::rest_into`] after a [`Motion::still_rest`] tick, reduced
    /// to its effects: that tick was a rest tick and nothing since cleared
    /// `still_rest` (every other way to the requests does), so what it
    /// cleared is still clear and needs no writing again.
    #[inline(always)]
    fn still_into(&mut self, now: Tick, out: &mut MotionOutput) {
        debug_assert!(self.requests_cleared(), "a still rest tick found a request");
        self.skip_update_at_rest();
        self.finish_still_tick(now, out);
    }

    /// Nothing requested, as [`Motion::rest_into`] leaves it: no press,
    /// nothing held off, no go-to pending, zero targets (`+0`).
    fn requests_cleared(&self) -> bool {
        let zeros = |values: &[f64]| values.iter().all(|v| v.to_bits() == 0);
        self.previous_direction == Direction::Still
            && !self.goto_pending
            && self.linear_blocked.is_none()
            && self.angular_blocked.is_none()
            && self.finger_blocked.is_none()
            && zeros(&self.input.target_velocity)
            && zeros(&self.input.target_acceleration)
            && zeros(&self.finger_input.target_velocity)
    }

    /// [`Motion::step_into`] for a command with no direction while
    /// [`Motion::resting`], reduced to its effects: whatever the mode,
    /// nothing is requested (no press, nothing held off, no go-to pending
    /// or under way, zero targets), so the updates are skipped and the
    /// tick ends as every tick does. `tests/it/fast_paths.rs` runs it side
    /// by side with the full step, which never takes it. (Not inlined:
    /// the still path then saves none of its registers.)
    #[inline(never)]
    fn rest_into(&mut self, now: Tick, out: &mut MotionOutput) {
        self.previous_direction = Direction::Still;
        self.goto_pending = false;
        self.linear_blocked = None;
        self.angular_blocked = None;
        self.finger_blocked = None;
        // (As many writes as channels: no `memset` a tick.)
        set_all(&mut self.input.target_velocity, [0.0, 0.0]);
        set_all(&mut self.input.target_acceleration, [0.0, 0.0]);
        set_all(&mut self.finger_input.target_velocity, [0.0]);
        self.skip_update_at_rest();
        self.finish_tick(now, false, [None; 2], out);
        // The next rest tick's twist is this one (nothing changes the
        // velocities or their axes on the way), and so is its mean: the
        // mean of two equal zeros is that zero, sign and all.
        self.still_rest = !self.always_update
            && still::all_zero(&self.last)
            && self.still_step.known(
                &still::velocity_bits(&self.last),
                &still::pose_bits(&self.pose, self.fingers),
            );
    }

    /// [`Motion::finish_tick`] on a tick after a [`Motion::still_rest`]
    /// one, reduced to its effects: the twist is the last one, zeros (the
    /// same velocities, the same signs), so is the mean, the pose step at
    /// it is known to change nothing, and nothing is reached or logged.
    fn finish_still_tick(&mut self, now: Tick, out: &mut MotionOutput) {
        let twist = self.last;
        debug_assert!(
            still::velocity_bits(&self.twist()) == still::velocity_bits(&twist)
                && still::all_zero(&twist)
                && self.still_step.known(
                    &still::velocity_bits(&twist),
                    &still::pose_bits(&self.pose, self.fingers)
                ),
            "a still rest tick would have moved"
        );
        self.tracker.record(now, &self.pose, true);
        self.still_repeats += 1;
        self.write_output(now, twist, twist, [None; 2], out);
    }

    /// The end of every tick: the commanded twist integrated into the
    /// pose, the tracker and the arm's stream fed, the output written.
    /// (Inlined into both callers: the rest path's constants then write
    /// less.)
    #[inline(always)]
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
            self.switch_to_velocity_plan();
        }
        self.write_output(now, twist, mean, events, out);
    }

    /// The tick's output: its twist, the pose, the arm's stream fed with
    /// the tick's mean velocity. (Inlined: a still tick's constants then
    /// write less.)
    #[inline(always)]
    fn write_output(
        &mut self,
        now: Tick,
        twist: [f64; 7],
        mean: [f64; 7],
        events: [Option<MotionEvent>; 2],
        out: &mut MotionOutput,
    ) {
        out.linear = [twist[0], twist[1], twist[2]];
        out.angular = [twist[3], twist[4], twist[5]];
        out.fingers_velocity = twist[6];
        out.pose = self.pose;
        out.fingers = self.fingers;
        out.arm_command = self.decimator.push(now, mean);
        out.recalculated = self.output.new_calculation || self.finger_output.new_calculation;
        out.events = events;
    }

    /// Both still at rest (no update ran since the one that found each,
    /// and nothing else changed Ruckig's state: see `arm_rest`), nothing
    /// asked: both updates would return `Finished` with this very state
    /// and no new calculation, so they are skipped.
    #[inline]
    fn skip_update_at_rest(&mut self) {
        self.check_arm_skip();
        self.check_finger_skip();
        self.skipped_updates += 1;
    }

    /// Debug builds: the arm's update skipped at rest would have seen the
    /// inputs of the update that found it still (Ruckig's own comparison).
    #[inline]
    fn check_arm_skip(&self) {
        #[cfg(debug_assertions)]
        debug_assert!(
            self.input == self.rest_inputs.0,
            "an arm update skipped at rest would have seen new inputs"
        );
    }

    /// [`Motion::check_arm_skip`] for the fingers' update.
    #[inline]
    fn check_finger_skip(&self) {
        #[cfg(debug_assertions)]
        debug_assert!(
            self.finger_input == self.rest_inputs.1,
            "a finger update skipped at rest would have seen new inputs"
        );
    }

    /// Runs both Ruckig instances one cycle and feeds their output back
    /// (either skipped where it rests and is asked nothing: see
    /// `arm_rest`); if either fails, brakes on the fallback profile until
    /// still.
    fn update_trajectories(
        &mut self,
        arm_asked_nothing: bool,
        fingers_asked_nothing: bool,
    ) -> Option<MotionEvent> {
        let skip_arm = self.arm_rest && arm_asked_nothing;
        let skip_fingers = self.finger_rest && fingers_asked_nothing;
        if skip_arm && skip_fingers && !self.fallback {
            self.skip_update_at_rest();
            return None;
        }
        let was_falling_back = self.fallback;
        let (mut arm_finished, mut fingers_finished) = (true, true);
        if !self.fallback {
            if skip_arm {
                self.check_arm_skip();
                self.skipped_single_updates += 1;
            } else {
                self.arm_rest = false;
                match update_trajectory(&mut self.otg, &mut self.input, &mut self.output) {
                    Some(finished) => {
                        arm_finished = finished;
                        if finished && self.plan == Plan::Goto {
                            self.goto_done = true;
                        }
                    }
                    None => self.fallback = true,
                }
            }
        }
        if !self.fallback {
            if skip_fingers {
                self.check_finger_skip();
                self.skipped_single_updates += 1;
            } else {
                self.finger_rest = false;
                match update_trajectory(
                    &mut self.finger_otg,
                    &mut self.finger_input,
                    &mut self.finger_output,
                ) {
                    Some(finished) => fingers_finished = finished,
                    None => self.fallback = true,
                }
            }
        }
        if self.fallback {
            self.arm_rest = false;
            self.finger_rest = false;
            self.fallback_brake();
        } else if !self.always_update {
            if !self.arm_rest
                && arm_finished
                && self.plan == Plan::Velocity
                && !self.output.new_calculation
                && is_still(&self.input)
                && comes_out_still(&self.output)
            {
                #[cfg(debug_assertions)]
                self.rest_inputs.0.copy_from(&self.input);
                self.arm_rest = true;
            }
            if !self.finger_rest
                && fingers_finished
                && !self.finger_output.new_calculation
                && is_still(&self.finger_input)
                && comes_out_still(&self.finger_output)
            {
                #[cfg(debug_assertions)]
                self.rest_inputs.1.copy_from(&self.finger_input);
                self.finger_rest = true;
            }
        }
        (self.fallback && !was_falling_back).then_some(MotionEvent::TrajectoryError)
    }

    /// One cycle of braking every channel on the time-optimal jerk-limited
    /// profile with the full limits (the planner failed). Braking is
    /// always inside the workspace: each tick's checks kept room for it.
    fn fallback_brake(&mut self) {
        self.switch_to_velocity_plan();
        self.goto_pending = false;
        let l = self.limits;
        for (dof, a_max, j_max) in [
            (LINEAR, l.linear_acceleration_mps2, l.linear_jerk_mps3),
            (
                ANGULAR,
                l.angular_acceleration_radps2,
                l.angular_jerk_radps3,
            ),
        ] {
            let input = &mut self.input;
            let (v, a) = (
                get(&input.current_velocity, dof),
                get(&input.current_acceleration, dof),
            );
            let (v, a) = braking::brake_step(v, a, a_max, j_max, CYCLE_S);
            put(&mut input.current_velocity, dof, v);
            put(&mut input.current_acceleration, dof, a);
        }
        let (v, a) = braking::brake_step(
            get(&self.finger_input.current_velocity, 0),
            get(&self.finger_input.current_acceleration, 0),
            l.finger_acceleration,
            l.finger_jerk,
            CYCLE_S,
        );
        put(&mut self.finger_input.current_velocity, 0, v);
        put(&mut self.finger_input.current_acceleration, 0, a);
        self.input.target_velocity.fill(0.0);
        self.finger_input.target_velocity.fill(0.0);
        let still = self.input.current_velocity.iter().all(|v| *v == 0.0)
            && self.input.current_acceleration.iter().all(|a| *a == 0.0)
            && (v, a) == (0.0, 0.0);
        if still {
            self.fallback = false; // Ruckig starts again from rest
        }
    }

    /// This tick's commanded velocity: `[v (3), ω (3), fingers]`, base frame.
    fn twist(&self) -> [f64; 7] {
        let v = self.linear_axis * get(&self.input.current_velocity, LINEAR);
        let w = self.angular_axis * get(&self.input.current_velocity, ANGULAR);
        [
            v.x,
            v.y,
            v.z,
            w.x,
            w.y,
            w.z,
            get(&self.finger_input.current_velocity, 0),
        ]
    }

    /// Integrates the tick's mean velocity into the pose estimate.
    fn integrate(&mut self, mean: &[f64; 7]) {
        if !still::all_zero(mean) || self.always_update {
            self.integrate_step(mean);
            return;
        }
        // At rest: the step is skipped where it is known to change nothing.
        let velocity = still::velocity_bits(mean);
        let before = still::pose_bits(&self.pose, self.fingers);
        if self.still_step.known(&velocity, &before) {
            return;
        }
        self.integrate_step(mean);
        let after = still::pose_bits(&self.pose, self.fingers);
        self.still_step.observe(&velocity, &before, &after);
    }

    fn integrate_step(&mut self, mean: &[f64; 7]) {
        let v = Vector3::new(mean[0], mean[1], mean[2]);
        let w = Vector3::new(mean[3], mean[4], mean[5]);
        self.pose.translation.vector += v * CYCLE_S;
        self.pose.rotation = UnitQuaternion::from_scaled_axis(w * CYCLE_S) * self.pose.rotation;
        self.fingers += mean[6] * CYCLE_S;
    }
}

/// A finished trajectory is at its target: drop the last ulps of rounding
/// so that "stopped" means exactly zero velocity.
/// No velocity or acceleration, now or asked.
fn is_still<const N: usize>(input: &InputParameter<N>) -> bool {
    [
        &input.current_velocity,
        &input.current_acceleration,
        &input.target_velocity,
        &input.target_acceleration,
    ]
    .iter()
    .all(|values| values.iter().all(|v| *v == 0.0))
}

/// Ruckig's own state after the update is still, as ours is: had
/// [`settle`] zeroed a leftover velocity or acceleration, Ruckig would
/// recalculate on the next update.
fn comes_out_still<const N: usize>(output: &OutputParameter<N>) -> bool {
    [&output.new_velocity, &output.new_acceleration]
        .iter()
        .all(|values| values.iter().all(|v| v.to_bits() == 0))
}

/// One cycle of one Ruckig instance, its output fed back into `input`
/// (settled once finished): whether it finished; `None` if it failed.
fn update_trajectory<const N: usize>(
    otg: &mut Otg<N>,
    input: &mut InputParameter<N>,
    output: &mut OutputParameter<N>,
) -> Option<bool> {
    match otg.update(input, output) {
        Ok(RuckigResult::Working) => {
            output.pass_to_input(input);
            Some(false)
        }
        Ok(RuckigResult::Finished) => {
            output.pass_to_input(input);
            settle(input);
            Some(true)
        }
        _ => None,
    }
}

fn settle<const N: usize>(input: &mut InputParameter<N>) {
    let copy = |to: &mut [f64], from: &[f64]| {
        for (t, f) in to.iter_mut().zip(from) {
            *t = *f;
        }
    };
    if let ControlInterface::Position = input.control_interface {
        copy(&mut input.current_position, &input.target_position);
    }
    copy(&mut input.current_velocity, &input.target_velocity);
    copy(&mut input.current_acceleration, &input.target_acceleration);
}

/// Fills `slots` with `values` (as many as both have).
fn set_all<const N: usize>(slots: &mut [f64], values: [f64; N]) {
    for (slot, value) in slots.iter_mut().zip(values) {
        *slot = value;
    }
}

/// The value at `i` (0 past the end).
fn get(values: &[f64], i: usize) -> f64 {
    values.get(i).copied().unwrap_or(0.0)
}

/// Sets the value at `i` (nothing past the end).
fn put(values: &mut [f64], i: usize, value: f64) {
    if let Some(slot) = values.get_mut(i) {
        *slot = value;
    }
}

/// NaN and ±∞ become 0 (no motion).
fn finite_or_zero(x: f64) -> f64 {
    if x.is_finite() { x } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn command(mode: Mode, direction: Direction) -> ModeOutput {
        ModeOutput {
            state: ModeState::Command(mode),
            direction,
            strength_volts: 1.0,
        }
    }

    /// Runs `ticks` ticks of one command, returning the outputs.
    fn run(m: &mut Motion, tick: &mut Tick, c: ModeOutput, ticks: u64) -> Vec<MotionOutput> {
        (0..ticks)
            .map(|_| {
                *tick += 1;
                m.step(*tick, &c)
            })
            .collect()
    }

    fn events(outputs: &[MotionOutput]) -> Vec<MotionEvent> {
        outputs
            .iter()
            .flat_map(|o| o.events.into_iter().flatten())
            .collect()
    }

    /// Motion with the default limits, workspace and home pose.
    fn motion() -> Motion {
        motion_with(|_, _| {})
    }

    /// Motion with the defaults changed by `edit`.
    fn motion_with(edit: impl FnOnce(&mut MotionConfig, &mut HomeConfig)) -> Motion {
        let (mut limits, mut home) = (MotionConfig::default(), HomeConfig::default());
        edit(&mut limits, &mut home);
        Motion::new(&limits, &WorkspaceConfig::default(), &home)
    }

    const PUFF: Direction = Direction::Positive;
    const SIP: Direction = Direction::Negative;
    const STILL: Direction = Direction::Still;

    #[test]
    fn power_up_is_still() {
        let mut m = motion();
        let mut t = 0;
        let out = run(&mut m, &mut t, ModeOutput::default(), 100);
        assert!(
            out.iter()
                .all(|o| o.linear == [0.0; 3] && o.angular == [0.0; 3])
        );
        assert_eq!(out[99].pose, HomeConfig::default().pose());
    }

    #[test]
    fn translation_ramps_holds_and_brakes_within_the_limits() {
        // A = 0.64 m/s², J = 12.8 m/s³: 0 → 0.2 m/s takes 0.05 + 0.2625 +
        // 0.05 = 0.3625 s, and braking from 0.2 m/s covers 0.2 · 0.3625 / 2
        // = 0.03625 m.
        let mut m = motion();
        let mut t = 0;
        let held = run(&mut m, &mut t, command(Mode::TranslateX, PUFF), 2000);
        assert!(held[361].linear[0] < 0.2);
        assert!(
            (held[362].linear[0] - 0.2).abs() < 1e-12,
            "{}",
            held[362].linear[0]
        );
        assert_eq!(held[1999].linear, [0.2, 0.0, 0.0]);
        let x_at_release = held[1999].pose.translation.x;
        let released = run(&mut m, &mut t, command(Mode::TranslateX, STILL), 600);
        assert!(released[361].linear[0] > 0.0);
        assert_eq!(released[362].linear, [0.0; 3]);
        let travelled = released[599].pose.translation.x - x_at_release;
        assert!((travelled - 0.03625).abs() < 1e-6, "{travelled}");
    }

    #[test]
    fn rotation_is_about_the_tool_axis() {
        // Tool rotated 90° about base z: its x axis is the base y axis.
        let mut m = motion_with(|_, home| {
            home.home_rotation_vector_rad = [0.0, 0.0, std::f64::consts::FRAC_PI_2];
        });
        let mut t = 0;
        let out = run(&mut m, &mut t, command(Mode::RotateX, PUFF), 1000);
        let w = out[999].angular;
        assert!(
            w[0].abs() < 1e-12 && (w[1] - 1.07).abs() < 1e-12 && w[2].abs() < 1e-12,
            "{w:?}"
        );
        // The tool point does not move.
        assert_eq!(out[999].pose.translation, m.pose().translation);
        assert_eq!(
            out[999].pose.translation.vector,
            Vector3::new(0.21, -0.26, 0.48)
        );
    }

    #[test]
    fn fingers_stop_at_their_ends() {
        let mut m = motion();
        let mut t = 0;
        let out = run(&mut m, &mut t, command(Mode::Fingers, SIP), 4000);
        assert_eq!(
            events(&out),
            [MotionEvent::WorkspaceLimit {
                boundary: Boundary::FingersClosed
            }]
        );
        let closed = out[3999].fingers;
        assert!(
            closed <= 6800.0 - FINGER_MARGIN && closed > 6800.0 - FINGER_MARGIN - 5.0,
            "{closed}"
        );
        assert_eq!(out[3999].fingers_velocity, 0.0);
        // Puff opens from there.
        let out = run(&mut m, &mut t, command(Mode::Fingers, PUFF), 500);
        assert!(out[499].fingers < closed - 500.0);
    }

    #[test]
    fn the_table_stops_the_tool_at_the_margin() {
        let mut m = motion(); // z = 0.48, margin 5 mm
        let mut t = 0;
        let out = run(&mut m, &mut t, command(Mode::TranslateZ, SIP), 4000);
        assert_eq!(
            events(&out),
            [MotionEvent::WorkspaceLimit {
                boundary: Boundary::Table
            }]
        );
        let z = out[3999].pose.translation.z;
        assert!((0.005..0.006).contains(&z), "stopped at z = {z}");
        assert_eq!(out[3999].linear, [0.0; 3]);
        // Holding on moves nothing more; the other way is free.
        let out = run(&mut m, &mut t, command(Mode::TranslateZ, SIP), 500);
        assert_eq!(out[499].pose.translation.z, z);
        assert!(events(&out).is_empty(), "one event per hold");
        let out = run(&mut m, &mut t, command(Mode::TranslateZ, PUFF), 500);
        assert!(out[499].pose.translation.z > z + 0.01);
    }

    #[test]
    fn the_base_sphere_stops_the_tool() {
        let mut m = motion_with(|_, home| home.home_position_m = [0.35, 0.0, 0.1]);
        let mut t = 0;
        let out = run(&mut m, &mut t, command(Mode::TranslateX, SIP), 3000);
        assert_eq!(
            events(&out),
            [MotionEvent::WorkspaceLimit {
                boundary: Boundary::Base
            }]
        );
        let p = out[2999].pose.translation.vector;
        let to_sphere = p.norm() - 0.2;
        assert!(
            to_sphere > 0.0 && (0.005..0.006).contains(&(p.x - 0.03f64.sqrt())),
            "{p:?}"
        );
    }

    #[test]
    fn save_and_go_to_point() {
        let mut m = motion();
        let mut t = 0;
        // Nothing saved: nothing moves, and an event says why.
        let out = run(&mut m, &mut t, command(Mode::GotoPoint, PUFF), 200);
        assert_eq!(events(&out), [MotionEvent::NoSavedPoint]);
        assert!(out.iter().all(|o| o.linear == [0.0; 3]));
        run(&mut m, &mut t, command(Mode::GotoPoint, STILL), 10);
        let out = run(&mut m, &mut t, command(Mode::SavePoint, PUFF), 10);
        assert!(matches!(events(&out)[..], [MotionEvent::Saved { .. }]));
        let saved = m.saved().unwrap();
        run(&mut m, &mut t, command(Mode::SavePoint, STILL), 10);
        for (mode, ticks) in [
            (Mode::TranslateX, 1200),
            (Mode::TranslateY, 800),
            (Mode::RotateZ, 700),
            (Mode::RotateX, 500),
        ] {
            run(&mut m, &mut t, command(mode, PUFF), ticks);
            run(&mut m, &mut t, command(mode, STILL), 1000);
        }
        // Hold a puff: a straight line back, all axes arriving together.
        let out = run(&mut m, &mut t, command(Mode::GotoPoint, PUFF), 6000);
        let ev = events(&out);
        assert!(matches!(ev[0], MotionEvent::GotoStarted { .. }), "{ev:?}");
        assert_eq!(ev[1], MotionEvent::GotoReached);
        let end = out[5999].pose;
        assert!((end.translation.vector - saved.translation.vector).norm() < 1e-6);
        assert!(end.rotation.angle_to(&saved.rotation) < 1e-6);
        let start = out[0].pose.translation.vector;
        for o in &out {
            // On the line from start to goal.
            let p = o.pose.translation.vector - start;
            let line = saved.translation.vector - start;
            assert!(p.cross(&line).norm() / line.norm() < 1e-6);
            assert!(Vector3::from(o.linear).norm() <= 0.2 * (1.0 + 1e-9));
        }
        // At the point: a new puff says so and moves nothing.
        run(&mut m, &mut t, command(Mode::GotoPoint, STILL), 10);
        let out = run(&mut m, &mut t, command(Mode::GotoPoint, PUFF), 100);
        assert_eq!(events(&out), [MotionEvent::AlreadyAtSavedPoint]);
    }

    /// Saves the home pose, then moves 1.5 s forward and comes to rest.
    fn save_then_move_away(m: &mut Motion, t: &mut Tick) {
        run(m, t, command(Mode::SavePoint, PUFF), 5);
        run(m, t, command(Mode::SavePoint, STILL), 5);
        run(m, t, command(Mode::TranslateX, PUFF), 1500);
        run(m, t, command(Mode::TranslateX, STILL), 1000);
    }

    #[test]
    fn a_goto_resumes_from_rest_after_a_halt() {
        let mut m = motion();
        let mut t = 0;
        save_then_move_away(&mut m, &mut t);
        run(&mut m, &mut t, command(Mode::GotoPoint, PUFF), 500);
        m.halt(); // a stall: the arm stopped on its own
        let out = run(&mut m, &mut t, command(Mode::GotoPoint, PUFF), 4000);
        let one_tick_from_rest = m.limits().linear_jerk_mps3 * CYCLE_S * CYCLE_S;
        assert!(
            Vector3::from(out[0].linear).norm() <= one_tick_from_rest,
            "from rest"
        );
        let ev = events(&out);
        assert!(matches!(ev[0], MotionEvent::GotoStarted { .. }), "{ev:?}");
        assert_eq!(ev[1], MotionEvent::GotoReached);
        let goal = m.saved().unwrap().translation.vector;
        assert!((m.pose().translation.vector - goal).norm() < 1e-6);
    }

    #[test]
    fn releasing_a_goto_brakes_along_the_line() {
        let mut m = motion();
        let mut t = 0;
        save_then_move_away(&mut m, &mut t);
        run(&mut m, &mut t, command(Mode::TranslateZ, SIP), 1000);
        run(&mut m, &mut t, command(Mode::TranslateZ, STILL), 1000);
        let start = m.pose().translation.vector;
        let goal = m.saved().unwrap().translation.vector;
        run(&mut m, &mut t, command(Mode::GotoPoint, PUFF), 800);
        let out = run(&mut m, &mut t, command(Mode::GotoPoint, STILL), 1000);
        assert_eq!(out[999].linear, [0.0; 3]);
        let p = out[999].pose.translation.vector;
        assert!(
            (p - start).cross(&(goal - start)).norm() < 1e-9,
            "stopped on the line"
        );
        assert!((p - goal).norm() > 0.01, "short of the goal");
    }

    #[test]
    fn a_goto_through_the_base_sphere_stops_at_it() {
        // Save at (0.3, 0, 0.05), go round the base to (−0.3, 0, 0.05)
        // (0.2 m/s held T seconds moves 0.2·T m), then go back: the straight
        // line passes 0.05 m from the base, inside its 0.2 m sphere, which it
        // meets at x = −√(0.2² − 0.05²).
        let mut m = motion_with(|_, home| home.home_position_m = [0.3, 0.0, 0.05]);
        let mut t = 0;
        run(&mut m, &mut t, command(Mode::SavePoint, PUFF), 5);
        run(&mut m, &mut t, command(Mode::SavePoint, STILL), 5);
        for (mode, direction, ticks) in [
            (Mode::TranslateY, PUFF, 2000),
            (Mode::TranslateX, SIP, 3000),
            (Mode::TranslateY, SIP, 2000),
        ] {
            let out = run(&mut m, &mut t, command(mode, direction), ticks);
            assert!(events(&out).is_empty(), "{:?}", events(&out));
            run(&mut m, &mut t, command(mode, STILL), 1000);
        }
        let p = m.pose().translation.vector;
        assert!((p - Vector3::new(-0.3, 0.0, 0.05)).norm() < 1e-6, "{p:?}");
        let out = run(&mut m, &mut t, command(Mode::GotoPoint, PUFF), 3000);
        let ev = events(&out);
        assert!(matches!(ev[0], MotionEvent::GotoStarted { .. }), "{ev:?}");
        assert_eq!(
            ev[1..],
            [MotionEvent::WorkspaceLimit {
                boundary: Boundary::Base
            }]
        );
        let p = m.pose().translation.vector;
        let sphere_x = -(0.2f64 * 0.2 - 0.05 * 0.05).sqrt();
        let gap = sphere_x - p.x;
        assert!(
            (0.005..0.006).contains(&gap),
            "{p:?}, {gap} m from the sphere"
        );
        assert_eq!(out[2999].linear, [0.0; 3]);
    }

    #[test]
    fn proportional_speed_follows_the_pressure() {
        let mut m = motion_with(|limits, _| {
            limits.proportional_speed = true;
            limits.proportional_full_scale_volts = 1.0;
            limits.proportional_min_fraction = 0.25;
        });
        let mut t = 0;
        let mut half = command(Mode::TranslateX, PUFF);
        half.strength_volts = 0.5; // 0.25 + 0.75 · 0.5 = 62.5 % of 0.2 m/s
        let out = run(&mut m, &mut t, half, 2000);
        assert!(
            (out[1999].linear[0] - 0.125).abs() < 1e-12,
            "{}",
            out[1999].linear[0]
        );
    }

    /// Defect a's second half: when the planner fails, the arm must still
    /// brake within the jerk and acceleration limits until still.
    #[test]
    fn a_planner_failure_brakes_within_the_limits_until_still() {
        let mut m = motion();
        let mut t = 0;
        run(&mut m, &mut t, command(Mode::TranslateX, SIP), 1000);
        let l = *m.limits();
        m.input.max_jerk.fill(f64::NAN); // the planner fails from now on
        let out = run(&mut m, &mut t, command(Mode::TranslateX, STILL), 1000);
        assert!(events(&out).contains(&MotionEvent::TrajectoryError));
        let v: Vec<f64> = out.iter().map(|o| o.linear[0]).collect();
        for k in 2..v.len() {
            let a = (v[k] - v[k - 1]) / CYCLE_S;
            let j = (v[k] - 2.0 * v[k - 1] + v[k - 2]) / (CYCLE_S * CYCLE_S);
            assert!(
                a.abs() <= l.linear_acceleration_mps2 * (1.0 + 1e-9),
                "a {a} at {k}"
            );
            assert!(
                j.abs() <= l.linear_jerk_mps3 * (1.0 + 1e-9) + 1e-9,
                "jerk {j} at {k}"
            );
        }
        let stop_ms = (l.linear_speed_mps / l.linear_acceleration_mps2
            + l.linear_acceleration_mps2 / l.linear_jerk_mps3)
            * 1000.0;
        let still = out.iter().position(|o| o.is_still()).expect("stops");
        assert!(still as f64 <= stop_ms + 2.0, "still after {still} ms");
    }
}
