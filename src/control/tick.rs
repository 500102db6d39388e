//! What goes into the core on one tick and what comes out: the
//! parameters of [`Pipeline::step`](crate::control::pipeline::Pipeline::step),
//! its only call that changes the core. The sensor's sample, what the arm
//! said and the start of a safe stop are all one [`TickInput`]; the control
//! loop, replay, recordings, the study, the fuzzers, the benches and the
//! tests give the core nothing else, so the same inputs give the same
//! [`TickOutput`]s, bit for bit.

use nalgebra::Isometry3;

use crate::control::Tick;
use crate::control::event::{Event, Events};
use crate::control::imu::ImuInput;
use crate::control::mode::Held;
use crate::control::modes::ModeOutput;
use crate::control::motion::MotionOutput;
use crate::control::output_command::OutputCommands;
use crate::control::sample::Sample;

/// The core's whole input on one tick. `Copy`, RT-safe.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TickInput {
    /// The tick (1 ms each; skipped ticks and stalls show as jumps).
    pub tick: Tick,
    /// The breath sensor's sample, or none, or the device gone.
    pub sample: Sample,
    /// The head-worn IMU's sample, or none, or the device gone (read only
    /// when the person has gestures).
    pub imu: ImuInput,
    /// What the arm said since the last tick.
    pub arm: ArmInput,
    /// The safe stop begins on this tick: from it on the interface is in
    /// detection mode for good, every target is zero and the arm brakes
    /// through Ruckig under the usual limits.
    pub stop: bool,
}

impl TickInput {
    /// Tick `tick` with `sample` and nothing else.
    pub fn new(tick: Tick, sample: Sample) -> Self {
        TickInput {
            tick,
            sample,
            ..TickInput::default()
        }
    }

    /// Tick `tick` with a sample of `volts` and nothing else.
    pub fn volts(tick: Tick, volts: f64) -> Self {
        TickInput::new(tick, Sample::Volts(volts))
    }

    /// Tick `tick` with the IMU's input and nothing else.
    pub fn imu(tick: Tick, imu: ImuInput) -> Self {
        TickInput {
            tick,
            imu,
            ..TickInput::default()
        }
    }
}

/// What the arm said since the last tick. `Copy`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ArmInput {
    /// A pose it measured, and which kind.
    pub pose: Option<(ArmPose, Isometry3<f64>)>,
    /// Its backend lost the link (the receiver, the master or the device
    /// went away): an arm fault; the arm brakes and the interface stays in
    /// detection mode.
    pub link_lost: bool,
}

/// What a measured pose means to the core.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ArmPose {
    /// Where the arm is before the first tick: the motion starts there
    /// instead of the configured home, and from then on measurements are
    /// expected (their silence or disagreement with the commanded motion
    /// is an arm fault). Given on the first tick only.
    Start,
    /// A measurement (the newest wins).
    Measured,
}

impl ArmInput {
    /// Nothing from the arm.
    pub fn is_empty(&self) -> bool {
        self.pose.is_none() && !self.link_lost
    }
}

/// Everything the core says about one tick. `Copy`, RT-safe.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TickOutput {
    /// The tick this output belongs to.
    pub tick: Tick,
    /// Mode, direction and strength for the motion layer.
    pub command: ModeOutput,
    /// The breath held right now, whatever the mode.
    pub held: Held,
    /// The sensor is in fault.
    pub faulted: bool,
    /// The commanded motion (and, every 10 ticks, the arm's command).
    pub motion: MotionOutput,
    /// What happened on this tick.
    pub events: Events,
    /// What the computer's and the home's outputs are to do.
    pub outputs: OutputCommands,
    /// Events that did not fit in `events` (always 0; counted, never
    /// silently lost).
    pub dropped_events: u8,
}

impl TickOutput {
    /// The start of tick `now`'s output: nothing held, nothing happened
    /// (`motion` is written whole by the motion step).
    pub(crate) fn restart(&mut self, now: Tick) {
        self.tick = now;
        self.command = ModeOutput::default();
        self.held = Held::default();
        self.faulted = false;
        self.events.clear();
        self.outputs.clear();
        self.dropped_events = 0;
    }

    /// Logs `event` on this tick (counted in `dropped_events` if full).
    pub(crate) fn log(&mut self, event: Event) {
        if self.events.push(event).is_err() {
            self.dropped_events = self.dropped_events.saturating_add(1);
        }
    }
}
