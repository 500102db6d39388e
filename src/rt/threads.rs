//! `run`: the control loop on its own real-time thread, and the threads
//! around it.
//!
//! ```text
//! sensor (producer thread, or computed in the loop)
//!    │ rtrb
//!    ▼
//! control thread (SCHED_FIFO, pinned, no allocation) ─rtrb─► arm thread (100 Hz, zero command at the end)
//!    │ rtrb: tick records, events
//!    ▼
//! telemetry (the calling thread): histograms, events, the report;
//!    │ with `run --record`, each tick's core input, each event and a
//!    ▼ copy of each arm command (its own rtrb ring) go on to
//! the session recorder (see [`recorder`](super::recorder))
//! ```
//!
//! Every ring is bounded and allocated before the loop; a full ring never
//! blocks the control thread: the item is dropped and counted (see
//! [`Drops`]), and the counts are in the report. Safe stop (a signal, see
//! [`signals`](super::signals); the end of the run; an arm error; an
//! output that failed): the core goes to detection mode for good, the arm
//! brakes through Ruckig, and the loop runs on until the motion has been
//! still for two arm cycles; then the command stream ends with a zero
//! command and the arm is stopped.

use std::fmt;
use std::io;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::thread;
use std::time::{Duration, Instant};

use nalgebra::{UnitQuaternion, Vector3};
use rtrb::RingBuffer;

use crate::arm::{Arm, ArmError, ArmState};
use crate::control::core_config::CoreConfig;
use crate::control::event::TimedEvent;
use crate::control::motion::stream::ArmCommand;
use crate::control::motion::workspace;
use crate::control::pipeline::Pipeline;
use crate::rt::arm_thread::{ArmStream, run_arm};
use crate::rt::clock::{MonotonicClock, SimClock};
use crate::rt::control_loop::{
    ControlTick, LoopOptions, OutputRings, StopReason, TickWork, control_loop,
};
use crate::rt::recorder::{Lost, SessionRecorder};
use crate::rt::report::RunReport;
use crate::rt::setup::RtOptions;
use crate::rt::stop::StopRequest;
use crate::rt::telemetry::{Drops, Latencies, TelemetryObserver, TickRecord};
use crate::sensor::{Samples, Sensor, SensorError};

const ARM_RING: usize = 256;
/// One arm command's cycle, s.
const ARM_CYCLE_S: f64 = 0.01;
/// Measured poses to the control thread: 64 ms at 1 kHz of feedback.
const FEEDBACK_RING: usize = 64;
/// After connecting, how long a measuring arm has to report its pose.
const FIRST_POSE_WAIT: Duration = Duration::from_secs(2);
const RECORD_RING: usize = 16_384;
const EVENT_RING: usize = 1024;
/// Copies of arm commands for the recorder: 10 s at 100 Hz.
const RECORDED_COMMAND_RING: usize = 1024;

/// How to run.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Run this long; `None`: until the sensor's script or file ends.
    pub seconds: Option<f64>,
    /// Real-time settings to ask for.
    pub rt: RtOptions,
    /// Hybrid wait: sleep until this long before each deadline, then spin.
    pub spin_margin_ns: Option<u64>,
    /// A safe stop requested: by a signal handler ([`signals::install`](super::signals::install)),
    /// or by `run` itself when its output fails.
    pub stop: StopRequest,
}

/// Where `run`'s events go, on the telemetry thread (not RT-safe). An
/// error from either method means the output has failed: the run stops
/// safely ([`StopReason::OutputFailed`]), the sink is called no more, and
/// the error is in the report.
pub trait EventSink {
    /// Writes one event.
    fn event(&mut self, event: &TimedEvent) -> io::Result<()>;

    /// Called every few milliseconds while the run goes on, between
    /// events: an error if the output is already known dead (a closed
    /// pipe) before anything is written to it.
    fn check(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// A closure is a sink that never fails (tests, benches).
impl<F: FnMut(&TimedEvent)> EventSink for F {
    fn event(&mut self, event: &TimedEvent) -> io::Result<()> {
        self(event);
        Ok(())
    }
}

/// Why a run could not start or finish.
#[derive(Debug)]
#[non_exhaustive]
pub enum RunError {
    /// The sensor could not start.
    Sensor(SensorError),
    /// The arm could not connect.
    Arm(ArmError),
    /// A thread could not be started, or died.
    Thread(String),
}

impl fmt::Display for RunError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RunError::Sensor(e) => write!(f, "sensor: {e}"),
            RunError::Arm(e) => write!(f, "{e}"),
            RunError::Thread(what) => f.write_str(what),
        }
    }
}

impl std::error::Error for RunError {}

/// The control thread's output rings and their consumers.
struct Rings {
    outputs: OutputRings,
    arm_rx: rtrb::Consumer<ArmCommand>,
    event_rx: rtrb::Consumer<TimedEvent>,
    records: rtrb::Producer<TickRecord>,
    record_rx: rtrb::Consumer<TickRecord>,
    recorded_rx: Option<rtrb::Consumer<ArmCommand>>,
}

impl Rings {
    /// Allocated once, before the loop; the recorder's command ring only
    /// if `recording`.
    fn new(recording: bool) -> Rings {
        let (arm, arm_rx) = RingBuffer::new(ARM_RING);
        let (events, event_rx) = RingBuffer::new(EVENT_RING);
        let (records, record_rx) = RingBuffer::new(RECORD_RING);
        let (recorded, recorded_rx) = if recording {
            let (tx, rx) = RingBuffer::new(RECORDED_COMMAND_RING);
            (Some(tx), Some(rx))
        } else {
            (None, None)
        };
        Rings {
            outputs: OutputRings {
                arm,
                events,
                recorded,
            },
            arm_rx,
            event_rx,
            records,
            record_rx,
            recorded_rx,
        }
    }
}

/// Runs the control loop with its threads until it ends; this thread is
/// the telemetry thread and gives `sink` each event as it arrives. If the
/// sink fails, the run stops safely and says so in its report.
pub fn run<S: Sensor>(
    config: &CoreConfig,
    sensor: S,
    arm: Box<dyn Arm>,
    options: &RunOptions,
    sink: &mut impl EventSink,
) -> Result<RunReport, RunError> {
    run_watched(config, sensor, arm, options, sink, Watchers::default())
}

/// [`run`], handing every tick's core input, every arm command and every
/// event to `recorder` on the telemetry thread (`run --record`).
pub fn run_recorded<S: Sensor>(
    config: &CoreConfig,
    sensor: S,
    arm: Box<dyn Arm>,
    options: &RunOptions,
    sink: &mut impl EventSink,
    recorder: &mut dyn SessionRecorder,
) -> Result<RunReport, RunError> {
    let watchers = Watchers {
        recorder: Some(recorder),
        observer: None,
    };
    run_watched(config, sensor, arm, options, sink, watchers)
}

/// Who else watches a run from the telemetry thread, besides its event
/// sink: the session recorder (`run --record`) and an observer (the
/// display).
#[derive(Default)]
pub struct Watchers<'a> {
    /// Gets every tick's core input, arm command and event.
    pub recorder: Option<&'a mut dyn SessionRecorder>,
    /// Gets every record and event (after the sink and the recorder).
    pub observer: Option<&'a mut dyn TelemetryObserver>,
}

/// [`run`], with `watchers` on the telemetry thread.
pub fn run_watched<S: Sensor>(
    config: &CoreConfig,
    sensor: S,
    arm: Box<dyn Arm>,
    options: &RunOptions,
    sink: &mut impl EventSink,
    watchers: Watchers<'_>,
) -> Result<RunReport, RunError> {
    run_with(config, sensor, arm, options, sink, watchers, |tick| tick)
}

/// [`run`], with the production tick wrapped by `wrap` (as `bench
/// latency` interleaves reference ticks), and `watchers`.
pub fn run_with<S: Sensor, W: TickWork + 'static>(
    config: &CoreConfig,
    sensor: S,
    arm: Box<dyn Arm>,
    options: &RunOptions,
    sink: &mut impl EventSink,
    watchers: Watchers<'_>,
    wrap: impl FnOnce(ControlTick<S::Samples>) -> W + Send + 'static,
) -> Result<RunReport, RunError> {
    let Watchers {
        mut recorder,
        mut observer,
    } = watchers;
    let Rings {
        outputs,
        mut arm_rx,
        mut event_rx,
        mut records,
        mut record_rx,
        mut recorded_rx,
    } = Rings::new(recorder.is_some());
    let sensor_name = sensor.describe();
    let arm_name = arm.describe();
    if let Some(recorder) = recorder.as_deref_mut() {
        recorder.start(&sensor_name, &arm_name);
    }
    // The sensor first: if it cannot start, the arm was never taken.
    let started = sensor.start().map_err(RunError::Sensor)?;
    let producer = started.producer;
    // From here on the arm's stream ends with a zero command, whatever
    // happens (the stream's guard sees to it if a thread cannot start).
    let mut stream = ArmStream::connect(arm).map_err(RunError::Arm)?;
    let core = Pipeline::new(config);
    // An arm that measures its pose: the motion starts where it is, and
    // its measurements reach the core through their own ring.
    let (initial, measured, feedback) = if stream.measures_pose() {
        let state = first_measured_state(&mut stream, config)?;
        let (tx, rx) = RingBuffer::new(FEEDBACK_RING);
        (Some(state), Some(tx), Some((state.pose, rx)))
    } else {
        (None, None, None)
    };
    let arm_measured = measured.is_some();
    let limit_ticks = options.seconds.map(|s| (s * 1000.0).round() as u64);
    let mut work = ControlTick::new(core, started.samples, outputs, limit_ticks.is_none());
    if let Some((start, feedback)) = feedback {
        work = work.with_measured_poses(start, feedback);
    }

    // Set by the arm thread when the arm fails: the loop stops safely.
    let arm_fault = Arc::new(AtomicBool::new(false));
    let fault = arm_fault.clone();
    let arm_thread = thread::Builder::new()
        .name("arm".into())
        .spawn(move || run_arm(stream, &mut arm_rx, &fault, initial, measured))
        .map_err(|e| RunError::Thread(format!("cannot start the arm thread: {e}")))?;

    let cpu_before = cpu_seconds();
    let wall = Instant::now();
    let loop_options = LoopOptions {
        limit_ticks,
        rt: options.rt,
        spin_margin_ns: options.spin_margin_ns,
        stop: options.stop.clone(),
        arm_fault,
    };
    let stop = options.stop.clone();
    let control = thread::Builder::new()
        .name("control".into())
        .spawn(move || {
            let mut work = wrap(work);
            control_loop(MonotonicClock, &mut work, &mut records, &loop_options)
        });
    let control = match control {
        Ok(control) => control,
        Err(e) => {
            // The work went with the failed spawn: the command ring is
            // abandoned and the arm thread ends the stream; wait for it.
            let _ = arm_thread.join();
            return Err(RunError::Thread(format!(
                "cannot start the control thread: {e}"
            )));
        }
    };

    // Telemetry: this thread.
    let mut full = Latencies::default();
    let mut reference = Latencies::default();
    let mut events = 0u64;
    // The first failure of the sink: the run stops safely, nothing more is
    // written to it.
    let mut output_error: Option<io::Error> = None;
    // The ring drops the recorder has been told of.
    let mut told = Drops::default();
    let mut drain = |record_rx: &mut rtrb::Consumer<TickRecord>,
                     event_rx: &mut rtrb::Consumer<TimedEvent>,
                     recorder: &mut Option<&mut dyn SessionRecorder>| {
        if output_error.is_none()
            && let Err(e) = sink.check()
        {
            output_error = Some(e);
            stop.output_failed();
        }
        while let Ok(event) = event_rx.pop() {
            events += 1;
            if output_error.is_none()
                && let Err(e) = sink.event(&event)
            {
                output_error = Some(e);
                stop.output_failed();
            }
            if let Some(recorder) = recorder.as_deref_mut() {
                recorder.event(&event);
            }
            if let Some(observer) = observer.as_deref_mut() {
                observer.event(&event);
            }
        }
        if let (Some(recorder), Some(rx)) = (recorder.as_deref_mut(), recorded_rx.as_mut()) {
            while let Ok(command) = rx.pop() {
                recorder.command(&command);
            }
        }
        while let Ok(record) = record_rx.pop() {
            if record.reference {
                reference.record(&record);
            } else {
                full.record(&record);
            }
            if let Some(recorder) = recorder.as_deref_mut() {
                let lost = Lost::between(&told, &record.drops);
                told = record.drops;
                if !lost.is_empty() {
                    recorder.lost(lost);
                }
                if !record.reference {
                    recorder.input(&record.input);
                }
            }
            if let Some(observer) = observer.as_deref_mut() {
                observer.record(&record);
            }
        }
        if let Some(observer) = observer.as_deref_mut() {
            observer.drained();
        }
    };
    while !control.is_finished() {
        drain(&mut record_rx, &mut event_rx, &mut recorder);
        thread::sleep(Duration::from_millis(5));
    }
    // Every thread is joined before anything is returned: the arm's
    // stream has ended, with a zero command, by the time this returns.
    let control = control.join();
    drain(&mut record_rx, &mut event_rx, &mut recorder);
    let wall_seconds = wall.elapsed().as_secs_f64();
    let cpu_percent = 100.0 * (cpu_seconds() - cpu_before) / wall_seconds.max(1e-9);
    let sensor_error = producer.stop().err();
    let arm = arm_thread.join();
    let result = control.map_err(|_| RunError::Thread("the control thread panicked".into()))?;
    let arm = arm.map_err(|_| RunError::Thread("the arm thread panicked".into()))?;
    if let Some(recorder) = recorder {
        // Records dropped after the last one that arrived.
        let lost = Lost::between(&told, &result.drops);
        if !lost.is_empty() {
            recorder.lost(lost);
        }
    }

    let mut errors = Vec::new();
    if let Some(e) = sensor_error {
        errors.push(format!("sensor: {e}"));
    }
    if let Some(e) = &arm.error {
        errors.push(e.to_string());
    }
    let arm_fault = result.work.arm_fault.map(|f| f.to_string());
    if let (Some(fault), None) = (&arm_fault, &arm.error) {
        // The core's own finding (the arm's backend had no error).
        errors.push(format!("arm: {fault}"));
    }
    Ok(RunReport {
        sensor: sensor_name,
        arm_name,
        settings: result.settings,
        preempt_rt: result.preempt_rt,
        stats: result.stats,
        drift_ticks: result.drift_ticks,
        full,
        reference,
        drops: result.drops,
        control_thread_allocations: result.allocations,
        events,
        stop_reason: result.work.stop_reason,
        arm: arm.state,
        arm_commands: arm.commands,
        stream_ended_with_zero: arm.ended_with_zero,
        last_arm_command: result.work.last_arm_command,
        final_velocity: result.work.final_velocity,
        velocity_at_stop: result.work.velocity_at_stop,
        braking_ticks: result.work.braking_ticks,
        output_error: output_error.map(|e| e.to_string()),
        wall_seconds: result.wall_seconds,
        cpu_percent,
        errors,
        recording: None,
        display: None,
        arm_measured,
        measured_poses: result.work.measured_poses,
        measured_pose_drops: arm.feedback_drops,
        largest_correction_m: result.work.largest_correction_m,
        arm_fault,
    })
}

/// The pose a measuring arm reports after connecting (its backend waits
/// for the first one while connecting; this waits a little more), which
/// must be inside the workspace: the limits could not bring an arm back
/// from outside.
fn first_measured_state(stream: &mut ArmStream, config: &CoreConfig) -> Result<ArmState, RunError> {
    let deadline = Instant::now() + FIRST_POSE_WAIT;
    let state = loop {
        if let Some(state) = stream.feedback() {
            break state;
        }
        if Instant::now() >= deadline {
            return Err(RunError::Arm(ArmError::Unavailable {
                detail: format!(
                    "the arm was to report its measured pose but none came within {} ms of connecting: is the driver publishing it?",
                    FIRST_POSE_WAIT.as_millis()
                ),
            }));
        }
        thread::sleep(Duration::from_millis(5));
    };
    let p = state.pose.translation.vector;
    if !workspace::contains(&p, config.workspace()) {
        let w = config.workspace();
        return Err(RunError::Arm(ArmError::Unavailable {
            detail: format!(
                "the arm's measured position ({:.3}, {:.3}, {:.3}) m is outside the workspace (reach {} m, base {} m, table z = {} m): move it inside with its own controls before starting",
                p.x, p.y, p.z, w.reach_m, w.min_radius_m, w.table_z_m
            ),
        }));
    }
    Ok(state)
}

/// Process CPU time (user + system), s.
fn cpu_seconds() -> f64 {
    // SAFETY: `usage` is a valid, writable rusage for getrusage to fill.
    let usage = unsafe {
        let mut usage: libc::rusage = std::mem::zeroed();
        libc::getrusage(libc::RUSAGE_SELF, &mut usage);
        usage
    };
    let t = |tv: libc::timeval| tv.tv_sec as f64 + tv.tv_usec as f64 / 1e6;
    t(usage.ru_utime) + t(usage.ru_stime)
}

/// The simulated loop's measuring arm, on the control thread (a thread of
/// its own would fall behind a simulated clock): after each tick that made
/// a command, the pose that command leads to after its 10 ms, into the
/// measured-pose ring, as an arm's backend would send it. RT-safe.
struct EchoingArm<S: Samples> {
    work: ControlTick<S>,
    /// `None`: the arm measures nothing.
    poses: Option<rtrb::Producer<nalgebra::Isometry3<f64>>>,
    pose: nalgebra::Isometry3<f64>,
    last_seq: Option<u64>,
}

impl<S: Samples> TickWork for EchoingArm<S> {
    fn tick(
        &mut self,
        wake: &crate::rt::scheduler::Wake,
        stop: Option<StopReason>,
    ) -> crate::rt::control_loop::TickOutcome {
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

    fn summary(&self) -> crate::rt::control_loop::WorkSummary {
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
}

/// The production control loop and tick (the same functions [`run`]
/// starts) on a simulated clock, on this thread, as fast as it goes, fed
/// by `samples` until they end and the arm brakes to a stop. No real-time
/// settings are asked for. For RealtimeSanitizer and allocation checks of
/// the loop itself: under RTSan, any allocation, lock or blocking call
/// inside a tick aborts the process.
pub fn run_simulated<S: Samples>(config: &CoreConfig, samples: S) -> SimulatedRun {
    simulate(config, samples, false)
}

/// [`run_simulated`] with an arm that measures its pose: the drain thread
/// executes each command for its 10 ms (from the configured home) and
/// sends the pose back through the measured-pose ring, so the ticks
/// checked take in a measurement every 10 ms.
pub fn run_simulated_measured<S: Samples>(config: &CoreConfig, samples: S) -> SimulatedRun {
    simulate(config, samples, true)
}

fn simulate<S: Samples>(config: &CoreConfig, samples: S, measured: bool) -> SimulatedRun {
    // With the recorder's command ring: the loop checked is the loop of
    // `run --record`.
    let Rings {
        outputs,
        mut arm_rx,
        mut event_rx,
        mut records,
        mut record_rx,
        mut recorded_rx,
    } = Rings::new(true);
    let options = LoopOptions {
        limit_ticks: None,
        rt: RtOptions::NONE,
        spin_margin_ns: None,
        stop: StopRequest::new(),
        arm_fault: Arc::new(AtomicBool::new(false)),
    };
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
                    thread::yield_now();
                }
            }
        });
        let result = control_loop(SimClock::default(), &mut work, &mut records, &options);
        // The rings' producers go with the work and the record ring: the
        // drain thread sees them abandoned and ends.
        drop(work);
        drop(records);
        let counts = drain.join().unwrap_or_default();
        (result, counts)
    });
    SimulatedRun {
        ticks: ticks + result.drops.records,
        events: events + result.drops.events,
        arm_commands: arm_commands + result.drops.arm_commands,
        recorded_commands: recorded + result.drops.recorded_commands,
        drops: result.drops,
        allocations: result.allocations,
        stop_reason: result.work.stop_reason,
        last_arm_command: result.work.last_arm_command,
        measured_poses: result.work.measured_poses,
    }
}
