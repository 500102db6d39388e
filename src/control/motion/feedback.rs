//! Measured-pose feedback: when the arm's driver reports the tool pose,
//! the pose the limits check is the *measured* one, carried forward by the
//! commands sent since; and a measurement that does not fit the commanded
//! motion is a fault.
//!
//! * **Matching.** The measured pose lags the commands (transport, the
//!   arm's own ramps). So a measurement is compared with the commanded
//!   path over the last `window_ms`, not with the pose of this tick: the
//!   path point it is nearest to (in units of the tolerances) is where
//!   the arm was told to be when it was measured.
//! * **Correction.** The difference between the measurement and that path
//!   point is added to the estimate (and to the path), so from then on
//!   the workspace and orientation limits see the real arm, plus the
//!   motion commanded since (e.g. a JACO2 whose firmware dead band
//!   swallowed the slowest part of a ramp).
//! * **Disagreement.** Further than `tolerance_m` or `tolerance_rad` from
//!   every point of the window: the arm was pushed, or it lags the
//!   commands by more than the window (blocked: nearest to the window's
//!   oldest point, which is then no correction — corrections would
//!   otherwise absorb a blocked arm a little at a time). The corrections
//!   of the last window, added up, beyond the tolerances: the arm runs
//!   ahead of its commands. And while nothing has been commanded to move
//!   for a whole window, the measured pose must stay within the
//!   tolerances of where it settled: an arm moved slowly by hand is caught
//!   too.
//! * **Silence.** No measurement for `timeout_ms`: the driver, the link or
//!   the arm is gone.
//!
//! Everything here is allocation-free after [`PoseTracker::new`] and takes
//! time as ticks.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use serde::Serialize;

use crate::control::Tick;

/// The path is kept at one point every this many ticks (≤ 0.5 mm apart at
/// the JACO2's 0.2 m/s cap), ms.
pub const PATH_STEP_TICKS: u64 = 5;
/// Points of path kept: 1.28 s at [`PATH_STEP_TICKS`].
pub const PATH_POINTS: usize = 256;
/// The longest `window_ms` (what the path holds, with room to spare), ms.
pub const MAX_WINDOW_MS: u32 = 1000;
/// Corrections remembered: a window's worth at 100 Hz, and more.
const CORRECTIONS: usize = 128;

/// `[arm.feedback]`: how a measured pose is checked. Used only when the
/// arm backend measures the pose.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FeedbackConfig {
    /// No measured pose for this long is a fault, ms.
    pub timeout_ms: u32,
    /// A measured position further than this from the commanded path is a
    /// fault, m.
    pub tolerance_m: f64,
    /// A measured orientation further than this from the commanded path
    /// is a fault, rad.
    pub tolerance_rad: f64,
    /// How far back the commanded path is searched for the point a
    /// measurement matches (the arm's lag and the feedback's latency), ms.
    pub window_ms: u32,
}

impl Default for FeedbackConfig {
    fn default() -> Self {
        FeedbackConfig {
            timeout_ms: 250,
            tolerance_m: 0.05,
            tolerance_rad: 0.25,
            window_ms: 250,
        }
    }
}

/// Why the measured pose cannot be trusted, or the arm's link is gone.
/// `Copy`; written in plain words in the event log and the report.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ArmFault {
    /// The backend lost its link (the receiver, the master, the device)
    /// or the arm refused a command (the report says which).
    LinkLost,
    /// The arm reported something that is not a pose: a coordinate not
    /// finite, or a quaternion that is not a rotation (a malformed
    /// message).
    PoseInvalid,
    /// No measured pose for `ms`.
    PoseSilent {
        /// Time since the last measurement, ms.
        ms: u64,
    },
    /// The measured pose is off the commanded path (or moved while nothing
    /// was commanded).
    PoseDisagrees {
        /// Distance from the nearest commanded pose, m.
        distance_m: f64,
        /// Angle from it, rad.
        angle_rad: f64,
        /// The measured position, m, base frame.
        measured_m: [f64; 3],
        /// The commanded (expected) position it was compared with, m.
        expected_m: [f64; 3],
    },
}

impl std::fmt::Display for ArmFault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ArmFault::LinkLost => f.write_str("arm link lost or a command refused — arm stopped"),
            ArmFault::PoseInvalid => f.write_str(
                "the arm reported a pose that is not one (not finite, or not a rotation) — arm stopped",
            ),
            ArmFault::PoseSilent { ms } => {
                write!(f, "no measured arm pose for {ms} ms — arm stopped")
            }
            ArmFault::PoseDisagrees {
                distance_m,
                angle_rad,
                measured_m: m,
                expected_m: e,
            } => write!(
                f,
                "the measured arm pose is {:.0} mm and {:.1}° from the commanded one (arm blocked or moved by hand?): measured ({:.3}, {:.3}, {:.3}) m, expected ({:.3}, {:.3}, {:.3}) m — arm stopped",
                distance_m * 1000.0,
                angle_rad.to_degrees(),
                m[0],
                m[1],
                m[2],
                e[0],
                e[1],
                e[2]
            ),
        }
    }
}

/// What one measurement did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Measurement {
    /// It fitted: the estimate moved by this much to agree with it.
    Corrected {
        /// The translation added to the estimate, m.
        by: [f64; 3],
        /// The rotation applied to it, rad (rotation vector, base frame).
        by_rad: [f64; 3],
    },
    /// It did not: a fault.
    Fault(ArmFault),
}

/// The commanded path of the last [`PATH_POINTS`] × [`PATH_STEP_TICKS`]
/// ticks, the measurements checked against it, and the correction they
/// give. RT-safe after [`PoseTracker::new`].
#[derive(Debug, Clone)]
pub struct PoseTracker {
    config: FeedbackConfig,
    /// Measuring: set by [`PoseTracker::start`].
    enabled: bool,
    path: Box<[Isometry3<f64>; PATH_POINTS]>,
    /// Where the next path point goes.
    next: usize,
    /// Path points stored (up to [`PATH_POINTS`]).
    stored: usize,
    /// Ticks since the last stored point.
    since_point: u64,
    /// The tick of the last measurement (or of the start).
    last_measured: Option<Tick>,
    /// Ticks the commanded motion has been still.
    still_ticks: u64,
    /// Where the arm settled, measured, once still for a whole window.
    settled: Option<Isometry3<f64>>,
    /// The latest corrections: (tick, translation m, rotation vector rad).
    corrections: [(Tick, Vector3<f64>, Vector3<f64>); CORRECTIONS],
    /// Where the next correction goes.
    next_correction: usize,
    /// A fault was reported: nothing more is checked.
    faulted: bool,
    /// Measurements taken.
    measurements: u64,
    /// The largest correction applied, m.
    largest_correction_m: f64,
}

impl PoseTracker {
    /// Not measuring until [`PoseTracker::start`]. Not RT-safe (allocates
    /// the path).
    pub fn new(config: FeedbackConfig) -> Self {
        PoseTracker {
            config,
            enabled: false,
            path: Box::new([Isometry3::identity(); PATH_POINTS]),
            next: 0,
            stored: 0,
            since_point: 0,
            last_measured: None,
            still_ticks: 0,
            settled: None,
            corrections: [(0, Vector3::zeros(), Vector3::zeros()); CORRECTIONS],
            next_correction: 0,
            faulted: false,
            measurements: 0,
            largest_correction_m: 0.0,
        }
    }

    /// From now on measurements are expected (their silence is a fault).
    pub fn start(&mut self) {
        self.enabled = true;
    }

    /// Measurements are expected.
    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// Measurements taken so far.
    pub fn measurements(&self) -> u64 {
        self.measurements
    }

    /// The largest correction applied so far, m.
    pub fn largest_correction_m(&self) -> f64 {
        self.largest_correction_m
    }

    /// Records the commanded pose reached at the end of tick `now` and
    /// whether anything was commanded to move on it. RT-safe.
    pub fn record(&mut self, now: Tick, pose: &Isometry3<f64>, still: bool) {
        if !self.enabled {
            return;
        }
        self.last_measured.get_or_insert(now);
        self.still_ticks = if still { self.still_ticks + 1 } else { 0 };
        if !still {
            self.settled = None;
        }
        if self.stored == 0 || self.since_point + 1 >= PATH_STEP_TICKS {
            self.since_point = 0;
            if let Some(slot) = self.path.get_mut(self.next) {
                *slot = *pose;
            }
            self.next = (self.next + 1) % PATH_POINTS;
            self.stored = (self.stored + 1).min(PATH_POINTS);
        } else {
            self.since_point += 1;
        }
    }

    /// The measurement's silence, checked at tick `now`. RT-safe.
    pub fn check_silence(&mut self, now: Tick) -> Option<ArmFault> {
        if !self.enabled || self.faulted {
            return None;
        }
        let since = now.saturating_sub(self.last_measured?);
        if since > u64::from(self.config.timeout_ms) {
            self.faulted = true;
            return Some(ArmFault::PoseSilent { ms: since });
        }
        None
    }

    /// Checks `measured`, taken at tick `now`, against the path; on
    /// success moves `estimate` (and the path) by the difference. RT-safe.
    pub fn measure(
        &mut self,
        now: Tick,
        measured: &Isometry3<f64>,
        estimate: &mut Isometry3<f64>,
    ) -> Option<Measurement> {
        if !self.enabled || self.faulted {
            return None;
        }
        self.last_measured = Some(now);
        self.measurements += 1;
        if !is_a_pose(measured) {
            // Nothing of it may reach the estimate.
            self.faulted = true;
            return Some(Measurement::Fault(ArmFault::PoseInvalid));
        }
        let c = self.config;
        let (nearest, distance, angle, oldest) = match self.nearest(measured) {
            Some(found) => found,
            // No path yet: the estimate is the measurement.
            None => (*estimate, 0.0, 0.0, false),
        };
        if distance > c.tolerance_m || angle > c.tolerance_rad {
            return Some(self.fault(measured, &nearest, distance, angle));
        }
        if oldest {
            // Behind the whole window: lag, not an offset to correct.
            return Some(Measurement::Corrected {
                by: [0.0; 3],
                by_rad: [0.0; 3],
            });
        }
        let window_ticks = u64::from(c.window_ms);
        if self.still_ticks >= window_ticks {
            match self.settled {
                None => self.settled = Some(*measured),
                Some(settled) => {
                    let (distance, angle) = apart(measured, &settled);
                    if distance > c.tolerance_m || angle > c.tolerance_rad {
                        return Some(self.fault(measured, &settled, distance, angle));
                    }
                }
            }
        }
        let by = measured.translation.vector - nearest.translation.vector;
        let turn = unit(measured.rotation * nearest.rotation.inverse());
        let (sum_m, sum_rad) = self.add_correction(now, by, turn.scaled_axis());
        if sum_m.norm() > c.tolerance_m || sum_rad.norm() > c.tolerance_rad {
            let expected = Isometry3::from_parts(
                Translation3::from(measured.translation.vector - sum_m),
                nearest.rotation,
            );
            return Some(self.fault(measured, &expected, sum_m.norm(), sum_rad.norm()));
        }
        // Renormalised: a product of rounded unit quaternions drifts from
        // unit length, and turning the path by turns computed from it
        // would compound the drift every measurement.
        let shift = |pose: &mut Isometry3<f64>| {
            pose.translation.vector += by;
            pose.rotation = unit(turn * pose.rotation);
        };
        shift(estimate);
        // Only the points stored: until the ring is full they are its
        // first `stored` slots.
        for point in self.path.iter_mut().take(self.stored) {
            shift(point);
        }
        self.largest_correction_m = self.largest_correction_m.max(by.norm());
        Some(Measurement::Corrected {
            by: by.into(),
            by_rad: turn.scaled_axis().into(),
        })
    }

    /// Remembers a correction; returns the sum of those of the last
    /// window (translation, rotation vector).
    fn add_correction(
        &mut self,
        now: Tick,
        by: Vector3<f64>,
        by_rad: Vector3<f64>,
    ) -> (Vector3<f64>, Vector3<f64>) {
        if let Some(slot) = self.corrections.get_mut(self.next_correction) {
            *slot = (now, by, by_rad);
        }
        self.next_correction = (self.next_correction + 1) % CORRECTIONS;
        let since = now.saturating_sub(u64::from(self.config.window_ms));
        self.corrections
            .iter()
            .filter(|(tick, ..)| *tick > since || (*tick == 0 && since == 0))
            .fold(
                (Vector3::zeros(), Vector3::zeros()),
                |(m, r), (_, b, br)| (m + b, r + br),
            )
    }

    fn fault(
        &mut self,
        measured: &Isometry3<f64>,
        expected: &Isometry3<f64>,
        distance_m: f64,
        angle_rad: f64,
    ) -> Measurement {
        self.faulted = true;
        Measurement::Fault(ArmFault::PoseDisagrees {
            distance_m,
            angle_rad,
            measured_m: measured.translation.vector.into(),
            expected_m: expected.translation.vector.into(),
        })
    }

    /// The path point of the last `window_ms` nearest to `measured`, in
    /// units of the tolerances (the newest of equals), with its distance
    /// and angle, and whether it is the oldest point of a full window.
    fn nearest(&self, measured: &Isometry3<f64>) -> Option<(Isometry3<f64>, f64, f64, bool)> {
        let c = self.config;
        let window = (u64::from(c.window_ms) / PATH_STEP_TICKS + 1) as usize;
        let points = window.min(self.stored);
        let mut best: Option<(f64, Isometry3<f64>, f64, f64, usize)> = None;
        for back in 1..=points {
            let index = (self.next + PATH_POINTS - back) % PATH_POINTS;
            let Some(point) = self.path.get(index) else {
                continue;
            };
            let (distance, angle) = apart(measured, point);
            let cost = (distance / c.tolerance_m).max(angle / c.tolerance_rad);
            if best.is_none_or(|(b, ..)| cost < b) {
                best = Some((cost, *point, distance, angle, back));
            }
        }
        best.map(|(_, point, distance, angle, back)| {
            (point, distance, angle, back == window && points == window)
        })
    }
}

/// `q` brought back to unit length.
fn unit(q: UnitQuaternion<f64>) -> UnitQuaternion<f64> {
    UnitQuaternion::new_normalize(q.into_inner())
}

/// Finite coordinates and a unit quaternion (within rounding): a pose.
fn is_a_pose(pose: &Isometry3<f64>) -> bool {
    let q = pose.rotation.quaternion();
    pose.translation.vector.iter().all(|v| v.is_finite())
        && q.coords.iter().all(|v| v.is_finite())
        && (q.norm() - 1.0).abs() < 1e-6
}

/// Distance (m) and angle (rad) between two poses.
fn apart(a: &Isometry3<f64>, b: &Isometry3<f64>) -> (f64, f64) {
    let distance = (a.translation.vector - b.translation.vector).norm();
    (distance, a.rotation.angle_to(&b.rotation))
}

/// A pose from a position (m) and a unit quaternion.
pub fn pose(position: [f64; 3], rotation: UnitQuaternion<f64>) -> Isometry3<f64> {
    Isometry3::from_parts(Translation3::from(position), rotation)
}
