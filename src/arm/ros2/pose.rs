//! The measured tool pose: a `geometry_msgs/msg/PoseStamped` (base frame,
//! m, unit quaternion) as the core's `Isometry3`.

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};

use super::messages::PoseStamped;

/// How far from 1 a quaternion's norm may be (float32 drivers round; a
/// message with garbage in it is refused, not normalized into a pose).
const NORM_TOLERANCE: f64 = 1e-3;

/// The pose a message carries, or why it cannot be used.
pub fn isometry(message: &PoseStamped) -> Result<Isometry3<f64>, String> {
    let p = message.pose.position;
    let o = message.pose.orientation;
    let values = [p.x, p.y, p.z, o.x, o.y, o.z, o.w];
    if values.iter().any(|v| !v.is_finite()) {
        return Err(format!("a pose with a non-finite value: {values:?}"));
    }
    let q = Quaternion::new(o.w, o.x, o.y, o.z);
    let norm = q.norm();
    if (norm - 1.0).abs() > NORM_TOLERANCE {
        return Err(format!(
            "a pose whose orientation is not a unit quaternion (norm {norm})"
        ));
    }
    Ok(Isometry3::from_parts(
        Translation3::new(p.x, p.y, p.z),
        UnitQuaternion::from_quaternion(q),
    ))
}

#[cfg(test)]
mod tests {
    use super::super::messages::{Point, Pose, Quaternion as Q};
    use super::*;

    fn stamped(position: [f64; 3], q: [f64; 4]) -> PoseStamped {
        PoseStamped {
            pose: Pose {
                position: Point {
                    x: position[0],
                    y: position[1],
                    z: position[2],
                },
                orientation: Q {
                    x: q[0],
                    y: q[1],
                    z: q[2],
                    w: q[3],
                },
            },
            ..PoseStamped::default()
        }
    }

    #[test]
    fn a_pose_becomes_the_same_isometry() {
        let half = std::f64::consts::FRAC_1_SQRT_2;
        let pose = isometry(&stamped([0.2, -0.3, 0.4], [0.0, 0.0, half, half])).unwrap();
        assert_eq!(pose.translation.vector.as_slice(), [0.2, -0.3, 0.4]);
        let axis = pose.rotation.scaled_axis();
        assert!(
            (axis.z - std::f64::consts::FRAC_PI_2).abs() < 1e-12,
            "{axis}"
        );
    }

    #[test]
    fn garbage_is_refused() {
        assert!(isometry(&stamped([f64::NAN, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0])).is_err());
        assert!(isometry(&stamped([0.0; 3], [0.0; 4])).is_err());
        assert!(isometry(&stamped([0.0; 3], [0.0, 0.0, 0.0, 2.0])).is_err());
    }
}
