//! Keeping the tool inside its workspace and orientation limits and the
//! fingers inside their travel: a request is held off when braking one
//! tick later could no longer stop short of a limit.
//!
//! The linear room is the distance along the line of travel to the
//! workspace shrunk by the stop margin (plus a rounding guard): the margin
//! holds as a normal distance to every boundary, whatever the direction of
//! travel. The angular room is the turn about the axis to the first
//! orientation limit (see [`orientation`](super::orientation)).

use nalgebra::{Isometry3, Vector3};

use crate::control::motion::braking;
use crate::control::motion::channel::CYCLE_S;
use crate::control::motion::orientation::{OrientationLimits, RoomGeometry};
use crate::control::motion::workspace::{self, Boundary, WorkspaceConfig};

/// Kept inside the stop margin and the orientation limits for rounding
/// (the pose is integrated tick by tick), m or rad.
pub const ROUNDING_GUARD: f64 = 1e-6;
/// Finger travel kept at each end, units.
pub const FINGER_MARGIN: f64 = 10.0;

/// Where the tool and the fingers may go. `Copy`, RT-safe.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    workspace: WorkspaceConfig,
    /// The workspace shrunk by the stop margin and the rounding guard.
    inner: WorkspaceConfig,
    orientation: OrientationLimits,
    /// What the angular room takes from `orientation`, worked out once.
    orientation_room: RoomGeometry,
}

impl Bounds {
    /// The workspace, and the orientation limits about `home`.
    pub fn new(workspace: &WorkspaceConfig, orientation: OrientationLimits) -> Self {
        Bounds {
            workspace: *workspace,
            inner: workspace::shrunk(workspace, workspace.stop_margin_m + ROUNDING_GUARD),
            orientation,
            orientation_room: RoomGeometry::new(&orientation),
        }
    }

    /// The orientation limits and the home orientation they start from.
    pub fn orientation(&self) -> &OrientationLimits {
        &self.orientation
    }

    /// Distance along the unit `u` from `pose`'s position to the workspace
    /// shrunk by the margin, and which boundary is there.
    pub fn linear_room(&self, pose: &Isometry3<f64>, u: &Vector3<f64>) -> (f64, Option<Boundary>) {
        workspace::distance_to_boundary(&pose.translation.vector, u, &self.inner)
    }

    /// Turn about the unit `u` from `pose`'s orientation to the first
    /// orientation limit (less the rounding guard), and which one.
    pub fn angular_room(&self, pose: &Isometry3<f64>, u: &Vector3<f64>) -> (f64, Option<Boundary>) {
        let (room, limit) = self.orientation_room.room(&pose.rotation, u);
        ((room - ROUNDING_GUARD).max(0.0), limit)
    }

    /// Finger travel from `fingers` to the margin at the end in the
    /// direction `sign` (+ closes), and which end.
    pub fn finger_room(&self, fingers: f64, sign: f64) -> (f64, Boundary) {
        if sign > 0.0 {
            (
                self.workspace.finger_closed - FINGER_MARGIN - fingers,
                Boundary::FingersClosed,
            )
        } else {
            (fingers - FINGER_MARGIN, Boundary::FingersOpen)
        }
    }
}

/// How one degree of freedom may brake and how little room it may start
/// into.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Braking {
    /// Acceleration limit.
    pub max_acceleration: f64,
    /// Jerk limit.
    pub max_jerk: f64,
    /// From rest, no start towards a limit with less room than this (no
    /// creeping by fractions of a unit).
    pub min_start: f64,
}

impl Braking {
    /// Whether something at speed `v` and acceleration `a` (positive
    /// towards the limit) must brake now to stop within `room`: the worst
    /// case of full jerk ahead for a tick, then braking; `min_start` from
    /// rest.
    pub fn must_brake(&self, v: f64, a: f64, room: f64) -> bool {
        let need = if v.abs() < 1e-9 && a <= 0.0 {
            self.min_start
        } else {
            braking::room_to_brake_next_cycle(v, a, self.max_acceleration, self.max_jerk, CYCLE_S)
        };
        need >= room
    }
}
