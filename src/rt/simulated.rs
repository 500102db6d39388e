//! The simulation harness: the production control loop and tick (the
//! functions [`run`](super::threads::run) starts) on a simulated clock, on
//! the calling thread, as fast as they go. For RealtimeSanitizer and the
//! allocation checks of the loop itself: under RTSan, any allocation,
//! lock or blocking call inside a tick aborts the process.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::thread;

use nalgebra::{Isometry3, UnitQuaternion, Vector3};
use rtrb::RingBuffer;

use crate::clock::SimClock;
use crate::control::core_config::CoreConfig;
use crate::control::motion::stream::ArmCommand;
use crate::control::output_command::OutputCommand;
use crate::control::pipeline::Pipeline;
use crate::output::{Output, OutputReport};
use crate::rt::control_loop::{
    ControlTick, LoopOptions, StopReason, TickOutcome, TickWork, WorkSummary, control_loop,
};
use crate::rt::output_thread::{OutputThread, Serves, TickZero};
use crate::rt::rings::{FEEDBACK_RING, Rings};
use crate::rt::scheduler::Wake;
use crate::rt::setup::RtOptions;
use crate::rt::stop::StopRequest;
use crate::rt::telemetry::Drops;
use crate::rt::telemetry_thread::TelemetryRings;
use crate::sensor::Samples;

/// One arm command's cycle, s.
const ARM_CYCLE_S: f64 = 0.01;
/// Commands an output's ring holds in a simulated run: a whole session's,
/// as the unpaced loop runs a minute in a fraction of a second.
pub const SIMULATED_OUTPUT_RING: usize = 1 << 16;

/// The simulated loop's measuring arm, on the control thread (a thread of
/// its own would fall behind a simulated clock): after each tick that made
/// a command, the pose that command leads to after its 10 ms, into the
/// measured-pose ring, as an arm's backend would send it. RT-safe.
struct EchoingArm<S: Samples> {
    work: ControlTick<S>,
    /// `None`: the arm measures nothing.
    poses: Option<rtrb::Producer<Isometry3<f64>>>,
    pose: Isometry3<f64>,
    last_seq: Option<u64>,
}

impl<S: Samples> TickWork for EchoingArm<S> {
    fn tick(&mut self, wake: &Wake, stop: Option<StopReason>) -> TickOutcome {
        let outcome = self.work.tick(wake, stop);
        if let Some(poses) = &mut self.poses {
            let command = self.work.summary().last_arm_command;
            if self.last_seq != Some(command.seq) && (command.seq > 0 || !command.is_zero()) {
                self.last_seq = Some(command.seq);
                let dt = ARM_CYCLE_S;
                self.pose.translation.vector += Vector3::from(command.linear) * dt;
                self.pose.rotation =
                    UnitQuaternion::from_scaled_axis(Vector3::from(command.angular) * dt)
                        * self.pose.rotation;
                // A full ring drops the pose: the next one follows.
                let _ = poses.push(self.pose);
            }
        }
        outcome
    }

    fn stopping(&self) -> bool {
        self.work.stopping()
    }

    fn summary(&self) -> WorkSummary {
        self.work.summary()
    }
}

/// What [`run_simulated`] did.
#[derive(Debug, Clone)]
pub struct SimulatedRun {
    /// Ticks the loop ran.
    pub ticks: u64,
    /// Events the loop pushed (and a drain thread received).
    pub events: u64,
    /// Arm commands pushed.
    pub arm_commands: u64,
    /// Copies of them pushed for the session recorder.
    pub recorded_commands: u64,
    /// Ring drops.
    pub drops: Drops,
    /// Heap allocations on the loop's thread after start-up.
    pub allocations: u64,
    /// Why the loop ended.
    pub stop_reason: StopReason,
    /// The last command sent to the arm.
    pub last_arm_command: ArmCommand,
    /// Measured poses the core took in ([`run_simulated_measured`]).
    pub measured_poses: u64,
    /// Commands the loop offered the two outputs (the computer's and the
    /// home's): carried out or dropped.
    pub output_commands: u64,
    /// Output commands dropped because a ring was full.
    pub output_drops: u64,
    /// Sensor faults the core reported, as a run's report counts them.
    pub faults: crate::rt::control_loop::SensorFaults,
}

/// The simulated run's outputs: they count what they are given.
#[derive(Default)]
struct Counting {
    applied: u64,
}

impl Output for Counting {
    fn describe(&self) -> String {
        "counting".into()
    }

    fn apply(&mut self, _command: &OutputCommand) {
        self.applied += 1;
    }

    fn close(&mut self) -> OutputReport {
        OutputReport {
            applied: self.applied,
            ..OutputReport::default()
        }
    }
}

/// Runs the loop fed by `samples` until they end and the arm brakes to a
/// stop, asking for no real-time settings; its rings are drained on
/// another thread, as in `run`.
pub fn run_simulated<S: Samples>(config: &CoreConfig, samples: S) -> SimulatedRun {
    simulate(
        config,
        samples,
        false,
        counting_outputs(),
        SIMULATED_OUTPUT_RING,
    )
    .0
}

/// [`run_simulated`] driving `outputs`, each on its thread as in `run`
/// with a ring of `ring` commands ([`crate::rt::output_thread::OUTPUT_RING`]
/// is `run`'s; a session's
/// worth makes what an output receives independent of how the host
/// schedules its thread); returns their reports too.
pub fn run_simulated_with_outputs<S: Samples>(
    config: &CoreConfig,
    samples: S,
    outputs: Vec<(Serves, Box<dyn Output>)>,
    ring: usize,
) -> (SimulatedRun, Vec<OutputReport>) {
    simulate(config, samples, false, outputs, ring)
}

/// Both kinds of output, counting what they are given.
fn counting_outputs() -> Vec<(Serves, Box<dyn Output>)> {
    vec![
        (Serves::Computer, Box::new(Counting::default())),
        (Serves::Home, Box::new(Counting::default())),
    ]
}

/// [`run_simulated`] with an arm that measures its pose: after each
/// command, the pose it leads to after its 10 ms (from the configured
/// home) comes back through the measured-pose ring, so the ticks checked
/// take in a measurement every 10 ms.
pub fn run_simulated_measured<S: Samples>(config: &CoreConfig, samples: S) -> SimulatedRun {
    simulate(
        config,
        samples,
        true,
        counting_outputs(),
        SIMULATED_OUTPUT_RING,
    )
    .0
}

fn simulate<S: Samples>(
    config: &CoreConfig,
    samples: S,
    measured: bool,
    outputs_to_drive: Vec<(Serves, Box<dyn Output>)>,
    output_ring: usize,
) -> (SimulatedRun, Vec<OutputReport>) {
    // With the recorder's command ring: the loop checked is the loop of
    // `run --record`.
    let Rings {
        mut outputs,
        mut records,
        arm: mut arm_rx,
        telemetry:
            TelemetryRings {
                records: mut record_rx,
                events: mut event_rx,
                recorded_commands: mut recorded_rx,
            },
    } = Rings::new(true);
    let options = LoopOptions {
        limit_ticks: None,
        rt: RtOptions::NONE,
        spin_margin_ns: None,
        stop: StopRequest::new(),
        arm_fault: Arc::new(AtomicBool::new(false)),
        tick_zero: None,
    };
    // The outputs, each on its thread as in `run`: the loop checked
    // offers them its commands.
    let mut output_threads = Vec::new();
    for (serves, output) in outputs_to_drive {
        if let Ok((thread, lane)) = OutputThread::start_with_ring(
            serves,
            output,
            TickZero::known(std::time::SystemTime::now()),
            output_ring,
        ) {
            output_threads.push(thread);
            outputs.outputs.push(lane);
        }
    }
    let work = ControlTick::new(Pipeline::new(config), samples, outputs, true);
    let home = config.home().pose();
    let (poses, poses_rx) = RingBuffer::new(FEEDBACK_RING);
    let mut work = EchoingArm {
        work: if measured {
            work.with_measured_poses(home, poses_rx)
        } else {
            work
        },
        poses: measured.then_some(poses),
        pose: home,
        last_seq: None,
    };
    // The loop's rings are drained on another thread, as in `run`.
    let (result, (ticks, events, arm_commands, recorded)) = thread::scope(|scope| {
        let drain = scope.spawn(move || {
            let (mut ticks, mut events, mut arm_commands, mut recorded) = (0u64, 0u64, 0u64, 0u64);
            loop {
                let abandoned = record_rx.is_abandoned();
                let mut popped = false;
                while record_rx.pop().is_ok() {
                    ticks += 1;
                    popped = true;
                }
                while event_rx.pop().is_ok() {
                    events += 1;
                    popped = true;
                }
                while arm_rx.pop().is_ok() {
                    arm_commands += 1;
                    popped = true;
                }
                while recorded_rx.as_mut().is_some_and(|rx| rx.pop().is_ok()) {
                    recorded += 1;
                    popped = true;
                }
                if abandoned {
                    break (ticks, events, arm_commands, recorded);
                }
                if !popped {
                    // Parked as the arm thread parks: a command handed
                    // over wakes it.
                    thread::park_timeout(std::time::Duration::from_micros(100));
                }
            }
        });
        // Each command handed over wakes the thread that takes it, as in
        // `run`.
        work.work.wakes_arm(drain.thread().clone());
        let result = control_loop(SimClock::default(), &mut work, &mut records, &options);
        // The rings' producers go with the work and the record ring: the
        // drain thread sees them abandoned and ends.
        drop(work);
        drop(records);
        let counts = drain.join().unwrap_or_default();
        (result, counts)
    });
    let reports: Vec<OutputReport> = output_threads
        .into_iter()
        .map(|thread| thread.join().0)
        .collect();
    let output_drops = reports.iter().map(|r| r.dropped).sum();
    let output_commands = reports.iter().map(|r| r.applied).sum::<u64>() + output_drops;
    let run = SimulatedRun {
        ticks: ticks + result.drops.records,
        events: events + result.drops.events,
        arm_commands: arm_commands + result.drops.arm_commands,
        recorded_commands: recorded + result.drops.recorded_commands,
        drops: result.drops,
        allocations: result.allocations,
        stop_reason: result.work.stop_reason,
        last_arm_command: result.work.last_arm_command,
        measured_poses: result.work.measured_poses,
        output_commands,
        output_drops,
        faults: result.work.faults,
    };
    (run, reports)
}
