//! The core's whole input on one tick, as the control tick gives it and a
//! recording keeps it: what the arm said, the sensor's sample, and whether
//! the safe stop began. `replay` of a recording repeats exactly these
//! calls, so the core's outputs come out the same, bit for bit.

use nalgebra::Isometry3;

use crate::control::Tick;
use crate::control::pipeline::{Pipeline, TickOutput};
use crate::control::sample::Sample;

/// What the arm told the core before one tick's step. `Copy`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ArmInput {
    /// A pose: the measured start (`Pipeline::start_measured`, on the
    /// first tick) or a measurement (`Pipeline::observe_arm`).
    pub pose: Option<(ArmPose, Isometry3<f64>)>,
    /// `Pipeline::arm_link_lost()`.
    pub link_lost: bool,
}

/// Which call a recorded pose was.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ArmPose {
    /// `Pipeline::start_measured`: where the motion starts.
    Start,
    /// `Pipeline::observe_arm`: a measurement.
    Measured,
}

impl ArmInput {
    /// Nothing from the arm.
    pub fn is_empty(&self) -> bool {
        self.pose.is_none() && !self.link_lost
    }

    /// Gives `core` what the arm said. RT-safe (`start_measured` is
    /// called on the first tick only).
    pub fn apply(&self, core: &mut Pipeline) {
        match self.pose {
            Some((ArmPose::Start, pose)) => core.start_measured(pose),
            Some((ArmPose::Measured, pose)) => core.observe_arm(&pose),
            None => {}
        }
        if self.link_lost {
            core.arm_link_lost();
        }
    }
}

/// Everything the control tick gave the core on one tick, in the order it
/// gave it: what the arm said, the step (its tick and sample), then, on
/// the tick the safe stop began, `Pipeline::begin_stop()`. With the
/// configuration, the sequence of these is the core's whole input.
/// `Copy`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CoreInput {
    /// The tick given to the core (skipped ticks and stalls show as
    /// jumps).
    pub tick: Tick,
    /// What the arm said before the step.
    pub arm: ArmInput,
    /// The sensor's sample, or none, or the device gone.
    pub sample: Sample,
    /// `Pipeline::begin_stop()` was called after this tick's step.
    pub began_stop: bool,
}

impl CoreInput {
    /// Gives `core` this tick's input, in order, its output into `out`:
    /// the one place a tick's input becomes core calls, on the control
    /// thread and in the replay of a recording. RT-safe.
    pub fn apply(&self, core: &mut Pipeline, out: &mut TickOutput) {
        self.arm.apply(core);
        core.step(self.tick, self.sample, out);
        if self.began_stop {
            core.begin_stop();
        }
    }
}
