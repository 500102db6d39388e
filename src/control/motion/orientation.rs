//! The tool's orientation limits: its axis (the tool's z axis) stays in a
//! cone of `max_tilt_rad` around its home direction, and its rotation about
//! that axis (the twist of a swing–twist decomposition relative to home)
//! within ±`max_twist_rad`. Pure geometry, RT-safe.
//!
//! The motion layer turns the tool about one fixed axis at a time, so it
//! asks how far the tool may turn about that axis before a limit is
//! reached ([`room`]): for the tilt and for the twist, a closed form.

use std::f64::consts::PI;

use nalgebra::{Quaternion, UnitQuaternion, Vector3};

use crate::control::motion::workspace::Boundary;

/// The limits and the home orientation they are measured from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrientationLimits {
    /// The tool's orientation at power-up, base frame.
    pub home: UnitQuaternion<f64>,
    /// Largest tilt of the tool axis from its home direction, rad.
    pub max_tilt_rad: f64,
    /// Largest twist about the tool axis, either way, rad.
    pub max_twist_rad: f64,
}

/// Tilt and twist of `rotation` relative to `home`, rad (twist in −π..π).
pub fn tilt_and_twist(rotation: &UnitQuaternion<f64>, home: &UnitQuaternion<f64>) -> (f64, f64) {
    let relative = home.inverse() * rotation;
    let z = relative * Vector3::z();
    let tilt = z.z.clamp(-1.0, 1.0).acos();
    let q = relative.quaternion();
    let twist = wrap(2.0 * q.k.atan2(q.w));
    (tilt, twist)
}

/// How far the tool may turn from `rotation` about the unit `axis` (base
/// frame, positive by the right-hand rule) before its tilt or twist reaches
/// its limit, rad, and which limit; `f64::INFINITY` if neither ever does.
pub fn room(
    rotation: &UnitQuaternion<f64>,
    axis: &Vector3<f64>,
    limits: &OrientationLimits,
) -> (f64, Option<Boundary>) {
    RoomGeometry::new(limits).room(rotation, axis)
}

/// What [`room`] takes from the limits, worked out once (the motion layer
/// asks on every tick it turns the tool): the same operations on the same
/// values as computed each time, so the same bits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoomGeometry {
    /// The home tool axis, base frame.
    home_axis: Vector3<f64>,
    /// The cosine of the tilt limit.
    cos_tilt: f64,
    /// From the base frame to home.
    to_home: Quaternion<f64>,
    /// The cosine and ± the sine of half the twist limit: the lines at
    /// ±ψ/2.
    half_twist: [(f64, f64); 2],
}

impl RoomGeometry {
    /// The geometry of `limits`.
    pub fn new(limits: &OrientationLimits) -> Self {
        let half = limits.max_twist_rad / 2.0;
        RoomGeometry {
            home_axis: limits.home * Vector3::z(),
            cos_tilt: limits.max_tilt_rad.cos(),
            to_home: *limits.home.inverse().quaternion(),
            half_twist: [1.0, -1.0].map(|sign| (half.cos(), sign * half.sin())),
        }
    }

    /// [`room`] for these limits.
    pub fn room(
        &self,
        rotation: &UnitQuaternion<f64>,
        axis: &Vector3<f64>,
    ) -> (f64, Option<Boundary>) {
        let tilt = self.tilt_room(rotation, axis);
        let twist = self.twist_room(rotation, axis);
        if tilt <= twist {
            (tilt, tilt.is_finite().then_some(Boundary::Tilt))
        } else {
            (twist, Some(Boundary::Twist))
        }
    }

    /// First turn about `u` at which the tilt reaches its limit.
    fn tilt_room(&self, rotation: &UnitQuaternion<f64>, u: &Vector3<f64>) -> f64 {
        let z0 = rotation * Vector3::z();
        let zh = self.home_axis;
        // The tool axis sweeps a cone about `u`; after a turn φ its dot
        // product with the home axis is z(φ)·zh = c + A cos φ + B sin φ
        // (Rodrigues' formula).
        let c = u.dot(&z0) * u.dot(&zh);
        let a = z0.dot(&zh) - c;
        let b = u.cross(&z0).dot(&zh);
        let k = self.cos_tilt;
        let m = a.hypot(b);
        if c - m >= k || m < 1e-15 {
            return f64::INFINITY; // the cone swept never leaves the limit
        }
        // Inside while cos(φ − φ0) ≥ q: |φ − φ0| ≤ α.
        let alpha = ((k - c) / m).clamp(-1.0, 1.0).acos();
        let now = wrap(-b.atan2(a));
        (alpha - now).max(0.0)
    }

    /// First turn about `u` at which the twist reaches ±its limit.
    fn twist_room(&self, rotation: &UnitQuaternion<f64>, u: &Vector3<f64>) -> f64 {
        // After a turn φ the rotation relative to home is the quaternion
        // cos(φ/2) P + sin(φ/2) Q; the twist reaches ±ψ where its (w, z)
        // components cross the line at angle ±ψ/2, an equation linear in
        // cos(φ/2) and sin(φ/2).
        let p = self.to_home * rotation.quaternion();
        let q = self.to_home * Quaternion::from_imag(*u) * rotation.quaternion();
        let mut best = f64::INFINITY;
        for (c, s) in self.half_twist {
            // The (w, z) components on the line at angle ±ψ/2:
            // α cos(φ/2) + β sin(φ/2) = 0.
            let alpha = p.k * c - p.w * s;
            let beta = q.k * c - q.w * s;
            if alpha.abs() < 1e-15 && beta.abs() < 1e-15 {
                continue; // the turn keeps the twist where it is
            }
            let first = (-alpha).atan2(beta).rem_euclid(PI);
            best = best.min(2.0 * first);
        }
        best
    }
}

/// An angle in −π..π.
fn wrap(angle: f64) -> f64 {
    (angle + PI).rem_euclid(2.0 * PI) - PI
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits(tilt: f64, twist: f64) -> OrientationLimits {
        OrientationLimits {
            home: UnitQuaternion::identity(),
            max_tilt_rad: tilt,
            max_twist_rad: twist,
        }
    }

    /// The first angle at which a limit is exceeded, by stepping.
    fn stepped(rotation: &UnitQuaternion<f64>, axis: &Vector3<f64>, l: &OrientationLimits) -> f64 {
        let step = 1e-5;
        for i in 1..700_000 {
            let phi = f64::from(i) * step;
            let r = UnitQuaternion::from_scaled_axis(axis * phi) * rotation;
            let (tilt, twist) = tilt_and_twist(&r, &l.home);
            if tilt > l.max_tilt_rad || twist.abs() > l.max_twist_rad {
                return phi;
            }
        }
        f64::INFINITY
    }

    #[test]
    fn about_the_tool_axis_only_the_twist_limits() {
        let l = limits(0.5, 1.0);
        let (room, limit) = room(&UnitQuaternion::identity(), &Vector3::z(), &l);
        assert!((room - 1.0).abs() < 1e-12, "{room}");
        assert_eq!(limit, Some(Boundary::Twist));
        let (back, _) = super::room(&UnitQuaternion::identity(), &-Vector3::z(), &l);
        assert!((back - 1.0).abs() < 1e-12);
    }

    #[test]
    fn tilting_reaches_the_cone() {
        let l = limits(0.5, 1.0);
        let (room, limit) = room(&UnitQuaternion::identity(), &Vector3::x(), &l);
        assert!((room - 0.5).abs() < 1e-12, "{room}");
        assert_eq!(limit, Some(Boundary::Tilt));
    }

    #[test]
    fn matches_stepping_from_random_orientations() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let l = OrientationLimits {
            home: UnitQuaternion::from_scaled_axis(Vector3::new(0.3, -0.2, 0.5)),
            max_tilt_rad: 1.2,
            max_twist_rad: 1.4,
        };
        let mut checked = 0;
        while checked < 200 {
            let r = UnitQuaternion::from_scaled_axis(Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )) * l.home;
            let (tilt, twist) = tilt_and_twist(&r, &l.home);
            if tilt > l.max_tilt_rad || twist.abs() > l.max_twist_rad {
                continue;
            }
            let axis = Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
            .normalize();
            let (exact, _) = room(&r, &axis, &l);
            let by_steps = stepped(&r, &axis, &l);
            if by_steps.is_finite() {
                assert!(
                    (exact - by_steps).abs() < 2e-5,
                    "{exact} vs {by_steps} from {r:?} about {axis:?}"
                );
            } else {
                assert!(exact > 6.9, "{exact}");
            }
            checked += 1;
        }
    }
}
