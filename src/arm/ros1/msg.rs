//! The three messages: `kinova_msgs/PoseVelocity` and
//! `kinova_msgs/PoseVelocityWithFingerVelocity` out (float32, little
//! endian, as ROS 1 serializes them), `geometry_msgs/PoseStamped` in.
//!
//! The definitions are kinova-ros's `kinova_msgs/msg/*.msg` files
//! (Kinovarobotics/kinova-ros, commit 924781d3); the md5sums are what
//! genmsg computes from them (`genmsg.gentools.compute_md5`: the field
//! lines `type name`, joined by newlines), checked against Debian's genmsg
//! by the peer tests.

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};

use crate::control::motion::stream::ArmCommand;

/// A message type as TCPROS names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MsgType {
    pub name: &'static str,
    pub md5sum: &'static str,
    pub definition: &'static str,
}

pub const POSE_VELOCITY: MsgType = MsgType {
    name: "kinova_msgs/PoseVelocity",
    md5sum: "37cb696ff239fbcc6aa4a04f7318d9da",
    definition: "float32 twist_linear_x\nfloat32 twist_linear_y\nfloat32 twist_linear_z\nfloat32 twist_angular_x\nfloat32 twist_angular_y\nfloat32 twist_angular_z\n",
};

pub const POSE_VELOCITY_WITH_FINGER_VELOCITY: MsgType = MsgType {
    name: "kinova_msgs/PoseVelocityWithFingerVelocity",
    md5sum: "d8789bad3911d8a482fde371a6b8abac",
    definition: "float32 twist_linear_x\nfloat32 twist_linear_y\nfloat32 twist_linear_z\nfloat32 twist_angular_x\nfloat32 twist_angular_y\nfloat32 twist_angular_z\nfloat32 finger1\nfloat32 finger2\nfloat32 finger3\n",
};

pub const POSE_STAMPED: MsgType = MsgType {
    name: "geometry_msgs/PoseStamped",
    md5sum: "d3812c3cbc69362b77dc0b19b345f8f5",
    definition: "",
};

/// The largest command frame: a 4-byte length and nine float32s.
pub const MAX_FRAME: usize = 4 + 9 * 4;

/// One command as a TCPROS frame (length prefix, then the float32
/// fields): `PoseVelocity` (6 fields) or, with `fingers`, three more, each
/// the command's finger velocity. Returns the frame's length.
pub fn encode_command(command: &ArmCommand, fingers: bool, frame: &mut [u8; MAX_FRAME]) -> usize {
    let mut fields = [0f32; 9];
    for i in 0..3 {
        fields[i] = command.linear[i] as f32;
        fields[3 + i] = command.angular[i] as f32;
    }
    let count = if fingers {
        fields[6..9].fill(command.fingers as f32);
        9
    } else {
        6
    };
    let body = count * 4;
    frame[..4].copy_from_slice(&(body as u32).to_le_bytes());
    for (i, v) in fields[..count].iter().enumerate() {
        frame[4 + 4 * i..8 + 4 * i].copy_from_slice(&v.to_le_bytes());
    }
    4 + body
}

/// A `PoseStamped`'s frame id and pose (the body, without the length).
pub fn decode_pose_stamped(body: &[u8]) -> Result<(String, Isometry3<f64>), String> {
    let mut at = 0usize;
    let mut take = |n: usize| -> Result<&[u8], String> {
        let slice = body
            .get(at..at + n)
            .ok_or_else(|| format!("a PoseStamped of {} bytes is too short", body.len()))?;
        at += n;
        Ok(slice)
    };
    // Header: seq, stamp (secs, nsecs), frame_id.
    take(12)?;
    let len = u32::from_le_bytes(take(4)?.try_into().unwrap_or_default()) as usize;
    let frame_id = String::from_utf8_lossy(take(len)?).into_owned();
    let mut f = [0f64; 7];
    for v in &mut f {
        *v = f64::from_le_bytes(take(8)?.try_into().unwrap_or_default());
    }
    if f.iter().any(|v| !v.is_finite()) {
        return Err(format!("a PoseStamped with a non-finite value: {f:?}"));
    }
    let q = Quaternion::new(f[6], f[3], f[4], f[5]);
    if q.norm() < 1e-6 {
        return Err("a PoseStamped with a zero quaternion".into());
    }
    let pose = Isometry3::from_parts(
        Translation3::new(f[0], f[1], f[2]),
        UnitQuaternion::from_quaternion(q),
    );
    Ok((frame_id, pose))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_are_little_endian_float32_in_the_msg_order() {
        let c = ArmCommand {
            linear: [0.1, -0.2, 0.3],
            angular: [0.4, -0.5, 0.6],
            fingers: 1000.0,
            ..ArmCommand::default()
        };
        let mut frame = [0u8; MAX_FRAME];
        assert_eq!(encode_command(&c, false, &mut frame), 28);
        assert_eq!(&frame[..4], &24u32.to_le_bytes());
        assert_eq!(&frame[4..8], &0.1f32.to_le_bytes());
        assert_eq!(&frame[24..28], &0.6f32.to_le_bytes());
        assert_eq!(encode_command(&c, true, &mut frame), 40);
        assert_eq!(&frame[..4], &36u32.to_le_bytes());
        for i in 0..3 {
            assert_eq!(&frame[28 + 4 * i..32 + 4 * i], &1000f32.to_le_bytes());
        }
    }

    #[test]
    fn a_pose_stamped_reads() {
        let mut body = Vec::new();
        body.extend_from_slice(&7u32.to_le_bytes());
        body.extend_from_slice(&[0; 8]);
        body.extend_from_slice(&4u32.to_le_bytes());
        body.extend_from_slice(b"base");
        let half = std::f64::consts::FRAC_1_SQRT_2;
        for v in [0.1, 0.2, 0.3, 0.0, 0.0, half, half] {
            body.extend_from_slice(&f64::to_le_bytes(v));
        }
        let (frame, pose) = decode_pose_stamped(&body).unwrap();
        assert_eq!(frame, "base");
        assert!((pose.translation.vector.y - 0.2).abs() < 1e-12);
        assert!((pose.rotation.angle() - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
        assert!(decode_pose_stamped(&body[..body.len() - 1]).is_err());
        let mut huge = body.clone();
        huge[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(decode_pose_stamped(&huge).is_err());
    }
}
