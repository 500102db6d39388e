//! What the motion layer says about a tick: its output (the commanded
//! twist, the pose it leads to, the arm's 100 Hz command) and its events.

use nalgebra::Isometry3;
use serde::{Serialize, Serializer};

use crate::control::motion::stream::ArmCommand;
use crate::control::motion::workspace::Boundary;

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
