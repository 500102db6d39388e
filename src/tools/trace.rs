//! The `--trace` CSV of both replays: per tick, the core's commanded
//! twist and the simulated arm's pose.

use std::io::Write;

use crate::arm::sim::SimulatedJaco;
use crate::control::motion::rest::{PoseBits, VelocityBits, pose_bits, velocity_bits};
use crate::control::tick::TickOutput;
use crate::tools::float_text::push_f64;

/// Header of the `--trace` CSV.
pub const TRACE_HEADER: &str = "tick,mode,vx,vy,vz,wx,wy,wz,fingers_vel,x,y,z,rx,ry,rz,fingers";

/// Writes trace rows: per tick, the core's 1 kHz commanded twist (base
/// frame) and the simulated arm's pose, the numbers as `format!("{}")`
/// writes them ([`push_f64`]). The twist's and the pose's text is laid
/// out again only when their bits change: the same bits give the same
/// text, and at rest or at a steady speed they do not change.
#[derive(Debug, Default)]
pub struct TraceRows {
    line: Vec<u8>,
    /// The last twist laid out (its bits), and its text.
    twist: Option<VelocityBits>,
    twist_text: Vec<u8>,
    /// The last pose laid out (its bits and fingers), and its text.
    pose: Option<PoseBits>,
    pose_text: Vec<u8>,
}

impl TraceRows {
    /// Writes the row of the tick `output` belongs to, `arm` having taken
    /// its command.
    pub fn write(
        &mut self,
        out: &mut dyn Write,
        output: &TickOutput,
        arm: &SimulatedJaco,
    ) -> std::io::Result<()> {
        let line = &mut self.line;
        line.clear();
        line.extend_from_slice(itoa::Buffer::new().format(output.tick).as_bytes());
        line.push(b',');
        line.extend_from_slice(output.command.state.name().as_bytes());
        let twist = output.motion.velocity();
        let bits = velocity_bits(&twist);
        if self.twist != Some(bits) {
            self.twist = Some(bits);
            let text = &mut self.twist_text;
            text.clear();
            for value in twist {
                text.push(b',');
                push_f64(text, value);
            }
        }
        line.extend_from_slice(&self.twist_text);
        let pose = arm.state().pose;
        let bits = pose_bits(&pose, arm.fingers());
        if self.pose != Some(bits) {
            self.pose = Some(bits);
            let text = &mut self.pose_text;
            text.clear();
            let r = pose.rotation.scaled_axis();
            let values = pose.translation.vector.iter().chain(r.iter());
            for &value in values.chain(std::iter::once(&arm.fingers())) {
                text.push(b',');
                push_f64(text, value);
            }
        }
        line.extend_from_slice(&self.pose_text);
        line.push(b'\n');
        out.write_all(line)
    }
}
