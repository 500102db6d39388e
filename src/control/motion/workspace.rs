//! The tool's workspace in the base frame: inside a reach sphere, outside a
//! small sphere around the base, above the table. Pure geometry, RT-safe.

use nalgebra::Vector3;
use serde::Serialize;

use crate::control::motion::limits::caps;

/// Where the tool may go (`[workspace]` in the config file), in the base
/// frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WorkspaceConfig {
    /// Largest distance from the base, m.
    pub reach_m: f64,
    /// Smallest distance from the base, m.
    pub min_radius_m: f64,
    /// Height of the table plane, m (the tool stays above it).
    pub table_z_m: f64,
    /// The tool stops at least this far from any boundary, m.
    pub stop_margin_m: f64,
    /// Finger position when closed, units (open is 0).
    pub finger_closed: f64,
    /// Largest tilt of the tool's axis (its z axis) from its home
    /// direction, rad: a cone around the home direction.
    pub max_tilt_rad: f64,
    /// Largest rotation about the tool's axis from home, either way, rad.
    pub max_twist_rad: f64,
}

impl Default for WorkspaceConfig {
    fn default() -> Self {
        WorkspaceConfig {
            reach_m: caps::REACH_M,
            min_radius_m: 0.2,
            table_z_m: 0.0,
            stop_margin_m: 0.005,
            finger_closed: 6800.0,
            max_tilt_rad: std::f64::consts::FRAC_PI_2,
            max_twist_rad: std::f64::consts::FRAC_PI_2,
        }
    }
}

/// Which boundary stops the tool. Serialized by its name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Boundary {
    /// The reach sphere.
    Reach,
    /// The sphere around the base.
    Base,
    /// The table plane.
    Table,
    /// Fingers fully open.
    FingersOpen,
    /// Fingers fully closed.
    FingersClosed,
    /// The tool axis at its tilt limit (`max_tilt_rad`).
    Tilt,
    /// The tool at its twist limit (`max_twist_rad`).
    Twist,
}

/// Distance from `p` along the unit vector `u` to the first boundary, and
/// which one; `f64::INFINITY` if none is ahead. A point already outside a
/// boundary may only move back in: distance 0 towards it.
pub fn distance_to_boundary(
    p: &Vector3<f64>,
    u: &Vector3<f64>,
    w: &WorkspaceConfig,
) -> (f64, Option<Boundary>) {
    let mut best = (f64::INFINITY, None);
    let mut consider = |d: f64, b: Boundary| {
        if d < best.0 {
            best = (d.max(0.0), Some(b));
        }
    };
    let pu = p.dot(u);
    let pp = p.norm_squared();
    // Reach sphere |p + s u| = R: the exit point ahead.
    let r2 = w.reach_m * w.reach_m;
    if pp >= r2 {
        if pu >= 0.0 {
            consider(0.0, Boundary::Reach);
        }
    } else {
        consider(-pu + (pu * pu - (pp - r2)).sqrt(), Boundary::Reach);
    }
    // Base sphere |p + s u| = r: the entry point ahead, if the ray hits it.
    let m2 = w.min_radius_m * w.min_radius_m;
    if pp <= m2 {
        if pu <= 0.0 {
            consider(0.0, Boundary::Base);
        }
    } else {
        let disc = pu * pu - (pp - m2);
        if disc >= 0.0 {
            let s = -pu - disc.sqrt();
            if s >= 0.0 {
                consider(s, Boundary::Base);
            }
        }
    }
    // Table plane z = table.
    if u.z < 0.0 {
        consider((p.z - w.table_z_m) / -u.z, Boundary::Table);
    }
    best
}

/// Normal distance from `p` to the nearest of the reach sphere, the base
/// sphere and the table, m; negative outside.
pub fn clearance(p: &Vector3<f64>, w: &WorkspaceConfig) -> f64 {
    let r = p.norm();
    (w.reach_m - r)
        .min(r - w.min_radius_m)
        .min(p.z - w.table_z_m)
}

/// The workspace with every boundary moved inwards by `by`, m.
pub fn shrunk(w: &WorkspaceConfig, by: f64) -> WorkspaceConfig {
    WorkspaceConfig {
        reach_m: w.reach_m - by,
        min_radius_m: w.min_radius_m + by,
        table_z_m: w.table_z_m + by,
        ..*w
    }
}

/// Whether `p` is inside the workspace (boundaries included).
pub fn contains(p: &Vector3<f64>, w: &WorkspaceConfig) -> bool {
    let r = p.norm();
    r <= w.reach_m && r >= w.min_radius_m && p.z >= w.table_z_m
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ws() -> WorkspaceConfig {
        WorkspaceConfig::default() // reach 0.9, base 0.2, table 0
    }

    #[test]
    fn distances_along_the_axes() {
        let p = Vector3::new(0.5, 0.0, 0.3);
        let (d, b) = distance_to_boundary(&p, &Vector3::x(), &ws());
        // x² + 0.09 = 0.81 → x = √0.72
        assert!((d - (0.72f64.sqrt() - 0.5)).abs() < 1e-12);
        assert_eq!(b, Some(Boundary::Reach));
        let (d, b) = distance_to_boundary(&p, &-Vector3::z(), &ws());
        assert!((d - 0.3).abs() < 1e-12);
        assert_eq!(b, Some(Boundary::Table));
        // Towards the base along −x at z = 0.1: hits the base sphere at
        // x = √(0.04 − 0.01).
        let p = Vector3::new(0.5, 0.0, 0.1);
        let (d, b) = distance_to_boundary(&p, &-Vector3::x(), &ws());
        assert!((d - (0.5 - 0.03f64.sqrt())).abs() < 1e-12);
        assert_eq!(b, Some(Boundary::Base));
        // At z = 0.3 the same ray passes over the base sphere and meets the
        // reach sphere on the far side.
        let p = Vector3::new(0.5, 0.0, 0.3);
        let (d, b) = distance_to_boundary(&p, &-Vector3::x(), &ws());
        assert!((d - (0.5 + 0.72f64.sqrt())).abs() < 1e-12);
        assert_eq!(b, Some(Boundary::Reach));
    }

    #[test]
    fn outside_may_only_move_back_in() {
        let out = Vector3::new(0.95, 0.0, 0.1);
        assert_eq!(distance_to_boundary(&out, &Vector3::x(), &ws()).0, 0.0);
        assert!(distance_to_boundary(&out, &-Vector3::x(), &ws()).0 > 0.0);
        assert!(!contains(&out, &ws()));
        assert!(contains(&Vector3::new(0.5, 0.0, 0.3), &ws()));
        assert!(!contains(&Vector3::new(0.5, 0.0, -0.01), &ws()));
        assert!(!contains(&Vector3::new(0.1, 0.0, 0.1), &ws()));
    }
}
