//! `run`: the control loop on its own real-time thread, and the threads
//! around it.
//!
//! ```text
//! sensor (producer thread, or computed in the loop)
//!    │ rtrb
//!    ▼
//! control thread (SCHED_FIFO, pinned, no allocation) ─rtrb─► arm thread (100 Hz, zero command at the end)
//!    │                                                 └rtrb─► one thread per output (`--output`: keys and
//!    │                                                         pointer, home events; lets go of all at the end)
//!    │ rtrb: tick records, events
//!    ▼
//! telemetry (the calling thread): histograms, events, the report;
//!    │ with `run --record`, each tick's core input, each event and a
//!    ▼ copy of each arm command (its own rtrb ring) go on to
//! the session recorder (see [`recorder`](super::recorder))
//! ```
//!
//! Priorities: the control thread at `--priority` (80) on the last CPU;
//! the sensor's readers, the arm thread and the uinput output's thread
//! SCHED_FIFO 10, 20 and 30 below it, on the other CPUs
//! ([`setup_serving_thread`]); the telemetry, display, recorder and MQTT
//! threads SCHED_OTHER. Each grant or denial is in the report.
//!
//! Every ring is bounded and allocated before the loop (see
//! [`rings`](super::rings)). Safe stop (a signal, see
//! [`signals`](super::signals); the end of the run; an arm error; an
//! output that failed): the core goes to detection mode for good, the arm
//! brakes through Ruckig, and the loop runs on until the motion has been
//! still for two arm cycles; then the command stream ends with a zero
//! command and the arm is stopped.

use std::fmt;
use std::os::unix::thread::JoinHandleExt;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::thread;
use std::time::{Duration, Instant};

use rtrb::RingBuffer;

use crate::arm::{Arm, ArmError, ArmState, ThreadRef};
use crate::clock::{Clock, MonotonicClock};
use crate::control::core_config::CoreConfig;
use crate::control::motion::workspace;
use crate::control::pipeline::Pipeline;
use crate::output::Output;
use crate::rt::arm_thread::{ArmStream, run_arm};
use crate::rt::control_loop::{ControlTick, LoopOptions, TickWork, control_loop};
use crate::rt::output_thread::{OutputThread, Serves, TickZero};
use crate::rt::recorder::SessionRecorder;
use crate::rt::report::{RunFacts, RunReport};
use crate::rt::rings::{FEEDBACK_RING, Rings};
use crate::rt::service_watchdog::ServiceNotifier;
use crate::rt::serving::ServingReport;
use crate::rt::setup::{RtOptions, RtSetting, lock_process_memory, setup_serving_thread};
use crate::rt::stop::StopRequest;
use crate::rt::telemetry_thread::{EventSink, Telemetry, Watchers};
use crate::sensor::{Samples, Sensor, SensorError};
use crate::wakes::keep_heap_resident;

/// After connecting, how long a measuring arm has to report its pose.
const FIRST_POSE_WAIT: Duration = Duration::from_secs(2);
/// How often the telemetry thread empties the rings.
const DRAIN_EVERY: Duration = Duration::from_millis(5);

/// How the control loop runs: how long, with which real-time settings,
/// and what stops it.
#[derive(Debug, Clone)]
pub struct LoopSettings {
    /// Run this long, s; `None`: until the sensor ends ([`Samples::ended`]).
    pub seconds: Option<f64>,
    /// Real-time settings to ask for.
    pub rt: RtOptions,
    /// Hybrid wait: sleep until this long before each deadline, then spin.
    pub spin_margin_ns: Option<u64>,
    /// A safe stop requested: by a signal handler
    /// ([`signals::install`](super::signals::install)), or by `run` itself
    /// when its event sink fails.
    pub stop: StopRequest,
}

impl LoopSettings {
    /// `seconds` long, asking for no real-time setting, stopped by
    /// nothing else (tests and simulations).
    pub fn plain(seconds: f64) -> LoopSettings {
        LoopSettings {
            seconds: Some(seconds),
            rt: RtOptions::NONE,
            spin_margin_ns: None,
            stop: StopRequest::new(),
        }
    }
}

/// What the control thread runs at each deadline, made there from the
/// production tick: the tick itself ([`Production`]), or a wrapper
/// around it (`bench latency` interleaves reference ticks).
pub trait Work<S: Samples>: Send + 'static {
    /// The work made.
    type Tick: TickWork;

    /// Makes the work around the production tick.
    fn around(self, tick: ControlTick<S>) -> Self::Tick;
}

/// The production tick as it is: what `sipnpuff run` runs.
#[derive(Debug, Clone, Copy, Default)]
pub struct Production;

impl<S: Samples + 'static> Work<S> for Production {
    type Tick = ControlTick<S>;

    fn around(self, tick: ControlTick<S>) -> ControlTick<S> {
        tick
    }
}

/// Everything one run is made of: the sensor it reads, the arm it drives,
/// how its loop runs, the work on the control thread, and who watches
/// from the telemetry thread.
pub struct RunOptions<'a, S, W = Production> {
    /// Where the samples come from (started by the run).
    pub sensor: S,
    /// What the commands drive (connected by the run).
    pub arm: Box<dyn Arm>,
    /// How the loop runs.
    pub settings: LoopSettings,
    /// The work made from the production tick.
    pub work: W,
    /// The event sink, the recorder and the observer.
    pub watchers: Watchers<'a>,
    /// The outputs beyond the arm (opened by the caller), each with what
    /// it serves.
    pub outputs: Vec<(Serves, Box<dyn Output>)>,
}

impl<'a, S: Sensor> RunOptions<'a, S> {
    /// The production tick on `sensor` and `arm`, watched by no one.
    pub fn new(sensor: S, arm: Box<dyn Arm>, settings: LoopSettings) -> Self {
        RunOptions {
            sensor,
            arm,
            settings,
            work: Production,
            watchers: Watchers::default(),
            outputs: Vec::new(),
        }
    }
}

impl<'a, S, W> RunOptions<'a, S, W> {
    /// Gives each event to `sink` as it arrives.
    pub fn events(mut self, sink: &'a mut dyn EventSink) -> Self {
        self.watchers.events = Some(sink);
        self
    }

    /// Drives `output` too, with the commands it serves.
    pub fn output(mut self, serves: Serves, output: Box<dyn Output>) -> Self {
        self.outputs.push((serves, output));
        self
    }

    /// Hands every tick's core input, every arm command and every event
    /// to `recorder` (`run --record`).
    pub fn recorder(mut self, recorder: &'a mut dyn SessionRecorder) -> Self {
        self.watchers.recorder = Some(recorder);
        self
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

/// Runs the control loop with its threads until it ends; this thread is
/// the telemetry thread and gives the watchers what the control thread
/// sends. If the event sink fails, the run stops safely and says so in
/// its report. Every thread is joined before this returns: the arm's
/// stream has ended, with a zero command.
pub fn run<S: Sensor, W: Work<S::Samples>>(
    config: &CoreConfig,
    options: RunOptions<'_, S, W>,
) -> Result<RunReport, RunError> {
    let RunOptions {
        sensor,
        arm,
        settings,
        work,
        mut watchers,
        outputs,
    } = options;
    let mut rings = Rings::new(watchers.recorder.is_some());
    let sensor_name = sensor.describe();
    let arm_name = arm.describe();
    if let Some(recorder) = watchers.recorder.as_deref_mut() {
        recorder.start(&sensor_name, &arm_name);
    }
    // Before any thread starts: memory locked, and heap memory, once
    // touched, kept (each deadline thread touches its own before its
    // loop, so none faults in it).
    let mut memory: Vec<RtSetting> = Vec::new();
    if settings.rt.lock_memory {
        memory.push(lock_process_memory());
        memory.push(RtSetting::from_result(
            "heap kept resident (no trim, no mmap)",
            keep_heap_resident(),
        ));
    }
    // The sensor first: if it cannot start, the arm was never taken.
    let started = sensor.start().map_err(RunError::Sensor)?;
    let producer = started.producer;
    // The threads the loop waits on, each at its priority below the
    // control thread and off its CPU: granted or denied, in the report.
    let serving_cpus = settings.rt.serving_cpu_list();
    let serve = |(name, thread): (String, ThreadRef), priority| {
        setup_serving_thread(thread, &name, priority, serving_cpus.as_deref())
    };
    let mut serving: Vec<RtSetting> = Vec::new();
    for thread in producer.threads() {
        let (name, thread) = thread;
        serving.extend(serve(
            (name, ThreadRef::Pthread(thread)),
            settings.rt.serving.sensor,
        ));
    }
    // From here on the arm's stream ends with a zero command, whatever
    // happens (the stream's guard sees to it if a thread cannot start).
    let mut stream = ArmStream::connect(arm).map_err(RunError::Arm)?;
    for thread in stream.backend_threads() {
        serving.extend(serve(thread, settings.rt.serving.arm));
    }
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
    let limit_ticks = settings.seconds.map(|s| (s * 1000.0).round() as u64);
    // The outputs' threads: each closes its output when the control
    // thread's end of its ring goes, however the loop ends.
    let tick_zero = TickZero::new();
    let mut output_threads = Vec::with_capacity(outputs.len());
    for (serves, output) in outputs {
        let (thread, lane) = OutputThread::start(serves, output, tick_zero.clone())
            .map_err(|e| RunError::Thread(format!("cannot start an output's thread: {e}")))?;
        if let Some(deadline) = thread.deadline_thread() {
            let (name, thread) = deadline;
            serving.extend(serve(
                (name, ThreadRef::Pthread(thread)),
                settings.rt.serving.output,
            ));
        }
        output_threads.push(thread);
        rings.outputs.outputs.push(lane);
    }
    let core = Pipeline::new(config);
    let mut tick = ControlTick::new(core, started.samples, rings.outputs, limit_ticks.is_none());
    if let Some((start, feedback)) = feedback {
        tick = tick.with_measured_poses(start, feedback);
    }

    // Set by the arm thread when the arm fails: the loop stops safely.
    let arm_fault = Arc::new(AtomicBool::new(false));
    let fault = arm_fault.clone();
    let mut commands = rings.arm;
    let arm_thread = thread::Builder::new()
        .name("arm".into())
        .spawn(move || run_arm(stream, &mut commands, &fault, initial, measured))
        .map_err(|e| RunError::Thread(format!("cannot start the arm thread: {e}")))?;
    tick.wakes_arm(arm_thread.thread().clone());
    serving.extend(serve(
        ("arm".into(), ThreadRef::Pthread(arm_thread.as_pthread_t())),
        settings.rt.serving.arm,
    ));

    let cpu_before = cpu_seconds();
    let wall = Instant::now();
    let loop_options = LoopOptions {
        limit_ticks,
        rt: settings.rt,
        spin_margin_ns: settings.spin_margin_ns,
        stop: settings.stop.clone(),
        arm_fault,
        tick_zero: Some(tick_zero),
    };
    let mut records = rings.records;
    let control = thread::Builder::new()
        .name("control".into())
        .spawn(move || {
            let mut work = work.around(tick);
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

    let mut telemetry = Telemetry::new(rings.telemetry, watchers, settings.stop);
    let mut service = ServiceNotifier::from_environment();
    let status = || format!("running: sensor {sensor_name}; arm {arm_name}");
    let mut clock = MonotonicClock;
    while !control.is_finished() {
        telemetry.drain();
        service.tend(clock.now_ns(), telemetry.liveness(), &status);
        thread::sleep(DRAIN_EVERY);
    }
    let looped = control.join();
    telemetry.drain();
    let wall_seconds = wall.elapsed().as_secs_f64();
    let cpu_percent = 100.0 * (cpu_seconds() - cpu_before) / wall_seconds.max(1e-9);
    let (sensor_stopped, sensor_wakes) = producer.stop_with_wakes();
    let sensor_error = sensor_stopped.err();
    let arm = arm_thread.join();
    let looped = looped.map_err(|_| RunError::Thread("the control thread panicked".into()))?;
    let arm = arm.map_err(|_| RunError::Thread("the arm thread panicked".into()))?;
    let (outputs, output_wakes): (Vec<_>, Vec<_>) =
        output_threads.into_iter().map(OutputThread::join).unzip();
    let telemetry = telemetry.finish(&looped.drops);
    let run = RunFacts {
        sensor: sensor_name,
        arm_name,
        arm_measured,
        sensor_error,
        cpu_percent,
    };
    let mut report = RunReport::new(run, looped, telemetry, arm);
    report.settings.splice(0..0, memory);
    report.settings.extend(serving);
    let sensors = sensor_wakes
        .into_iter()
        .map(|(name, wakes)| ServingReport::new(&name, wakes));
    report.serving.splice(0..0, sensors);
    report.serving.extend(output_wakes.into_iter().flatten());
    service.stopping(&format!("stopped by: {}", report.stop_reason));
    report.outputs = outputs;
    Ok(report)
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
