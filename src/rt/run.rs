//! `sipnpuff run` and `sipnpuff bench latency`: the 1 kHz control loop on
//! its own real-time thread, and the threads around it.
//!
//! ```text
//! sensor thread (csv) ─rtrb─► control thread ─rtrb─► arm thread (simulated JACO, 100 Hz)
//!   (synthetic: in the loop)   (SCHED_FIFO, pinned,  ─rtrb─► telemetry (this thread):
//!                               no allocation)              histograms, events, report
//! ```
//!
//! Every ring is bounded and allocated before the loop; a full ring never
//! blocks the control thread: the item is dropped and counted (see
//! [`Drops`]), and the counts are in the report. Safe stop (SIGINT,
//! SIGTERM, end of the run): the core goes to detection mode for good, the
//! arm brakes through Ruckig, and the loop runs on until the motion has
//! been still for [`STILL_TICKS`] ticks; then the arm stream ends and the
//! simulated arm stops, as a JACO2 does when its stream stops.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread;
use std::time::{Duration, Instant};

use rtrb::RingBuffer;

use crate::arm::{ArmBackend, ArmState, SimulatedJaco};
use crate::config::{Config, Interface};
use crate::csv_signal::CsvSignal;
use crate::motion::stream::ArmCommand;
use crate::pipeline::Core;
use crate::rt::clock::{Clock, MonotonicClock, SimClock};
use crate::rt::scheduler::{Scheduler, SchedulerStats};
use crate::rt::setup::{RtOptions, Setting, setup_current_thread};
use crate::rt::telemetry::{Drops, Latencies, TickRecord, TimedEvent};
use crate::signal::{SignalGenerator, SignalParams, Step, run_script};

/// The control period: 1 ms.
pub const PERIOD_NS: u64 = 1_000_000;
/// Still ticks (zero command) after a stop before the stream ends: two
/// full 10 ms arm windows.
pub const STILL_TICKS: u64 = 20;
/// Longest a safe stop may take before the loop ends anyway, ticks.
pub const MAX_STOP_TICKS: u64 = 5000;

const SAMPLE_RING: usize = 1024;
const ARM_RING: usize = 256;
const RECORD_RING: usize = 16_384;
const EVENT_RING: usize = 1024;

/// Where samples come from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SensorSource {
    /// The built-in scripted user on the seeded synthetic sensor,
    /// evaluated in the loop.
    Synthetic,
    /// A recording played in real time by a sensor thread.
    Csv(PathBuf),
}

/// How to run.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Run this long; `None`: until the sensor's script or file ends.
    pub seconds: Option<f64>,
    /// The sensor.
    pub sensor: SensorSource,
    /// Real-time settings to ask for.
    pub rt: RtOptions,
    /// Hybrid wait: sleep until this long before each deadline, then spin.
    pub spin_margin_ns: Option<u64>,
    /// Set (by a signal handler) to request a safe stop.
    pub stop: Arc<AtomicBool>,
    /// Print each event as a JSON line as it happens.
    pub print_events: bool,
    /// `bench latency`: alternate blocks of this many bare-wait reference
    /// ticks and full ticks.
    pub interleave: Option<u64>,
}

/// What a run did.
#[derive(Debug, Clone)]
pub struct RunReport {
    /// Real-time settings, granted or denied.
    pub settings: Vec<Setting>,
    /// The kernel is PREEMPT_RT.
    pub preempt_rt: bool,
    /// Scheduler counts.
    pub stats: SchedulerStats,
    /// Periods elapsed by the clock minus ticks run and skipped.
    pub drift_ticks: i64,
    /// Full ticks.
    pub full: Latencies,
    /// Reference ticks (`bench latency` only).
    pub reference: Latencies,
    /// Ring drops.
    pub drops: Drops,
    /// Heap allocations on the control thread after start-up.
    pub control_thread_allocations: u64,
    /// Events logged.
    pub events: u64,
    /// Why the run ended.
    pub stop_reason: &'static str,
    /// The arm at the end.
    pub arm: ArmState,
    /// Commands the arm received.
    pub arm_commands: u64,
    /// The last command sent to the arm.
    pub last_arm_command: ArmCommand,
    /// The last commanded twist `[v (3), ω (3), fingers]`.
    pub final_velocity: [f64; 7],
    /// Wall time of the loop, s.
    pub wall_seconds: f64,
    /// Process CPU time over wall time, %.
    pub cpu_percent: f64,
}

/// The control thread's result.
struct ControlResult {
    drops: Drops,
    settings: Vec<Setting>,
    preempt_rt: bool,
    stats: SchedulerStats,
    drift_ticks: i64,
    allocations: u64,
    stop_reason: &'static str,
    final_velocity: [f64; 7],
    last_arm_command: ArmCommand,
    wall_seconds: f64,
}

/// The sensor as the control loop sees it. RT-safe.
// One value on the control thread's (pre-faulted) stack: boxing the large
// variant would only add an indirection.
#[allow(clippy::large_enum_variant)]
enum LoopSensor<'a> {
    Synthetic {
        samples: SignalGenerator<'a>,
        /// Start the script again when it ends (`bench latency`).
        again: Option<(SignalParams, &'a [Step])>,
        rest_volts: f64,
        ended: bool,
    },
    Ring {
        samples: rtrb::Consumer<f64>,
        finished: Arc<AtomicBool>,
    },
}

impl LoopSensor<'_> {
    /// The sample for this tick, after `skipped` missed ticks; `None` if
    /// none arrived.
    fn sample(&mut self, skipped: u64, drops: &mut Drops) -> Option<f64> {
        match self {
            LoopSensor::Synthetic {
                samples,
                again,
                rest_volts,
                ended,
            } => {
                for _ in 0..skipped {
                    samples.next();
                }
                let mut v = samples.next();
                if let (None, Some((params, script))) = (v, again) {
                    // Seeding the generator allocates nothing.
                    *samples = SignalGenerator::new(*params, script);
                    v = samples.next();
                }
                *ended |= v.is_none();
                Some(v.unwrap_or(*rest_volts))
            }
            LoopSensor::Ring { samples, .. } => {
                // One sample per tick; after skipped ticks, their samples
                // are stale: keep the newest.
                let mut latest = None;
                for _ in 0..=skipped {
                    match samples.pop() {
                        Ok(v) => latest = Some(v),
                        Err(_) => break,
                    }
                }
                // A sensor running ahead: drop what piled up, counted.
                while samples.slots() > 2 {
                    if samples.pop().is_ok() {
                        drops.samples += 1;
                    }
                }
                latest
            }
        }
    }

    fn ended(&self) -> bool {
        match self {
            LoopSensor::Synthetic { ended, .. } => *ended,
            LoopSensor::Ring { samples, finished } => {
                finished.load(Ordering::Acquire) && samples.is_empty()
            }
        }
    }
}

struct Rings {
    arm: rtrb::Producer<ArmCommand>,
    records: rtrb::Producer<TickRecord>,
    events: rtrb::Producer<TimedEvent>,
}

impl Rings {
    /// The control thread's output rings, allocated before the loop, and
    /// their consumers: arm commands, tick records, events.
    fn new() -> (
        Rings,
        rtrb::Consumer<ArmCommand>,
        rtrb::Consumer<TickRecord>,
        rtrb::Consumer<TimedEvent>,
    ) {
        let (arm, arm_rx) = RingBuffer::new(ARM_RING);
        let (records, record_rx) = RingBuffer::new(RECORD_RING);
        let (events, event_rx) = RingBuffer::new(EVENT_RING);
        (
            Rings {
                arm,
                records,
                events,
            },
            arm_rx,
            record_rx,
            event_rx,
        )
    }
}

/// The control loop. Everything it needs is built before the first
/// deadline; inside the loop it neither allocates, locks nor blocks except
/// in the deadline sleep.
fn control_loop<C: Clock>(
    mut clock: C,
    mut core: Core,
    mut sensor: LoopSensor<'_>,
    mut rings: Rings,
    options: &RunOptions,
) -> ControlResult {
    let setup = setup_current_thread(&options.rt);
    let mut drops = Drops::default();
    let limit_ticks = options.seconds.map(|s| (s * 1000.0).round() as u64);
    let started = Instant::now();
    let allocations_before = crate::alloc_counter::thread_allocations();

    let start = clock.now_ns() + PERIOD_NS;
    let mut scheduler = Scheduler::new(start, PERIOD_NS, options.spin_margin_ns);
    let mut core_tick = 0u64;
    let mut previous_wake = 0u64;
    let mut stop_reason = "";
    let mut stopping_since: Option<u64> = None;
    let mut still_ticks = 0u64;
    let mut last_arm_command = ArmCommand::default();

    let (final_velocity, last_woke) = loop {
        let wake = scheduler.wait(&mut clock);
        // From the wake-up to the end of the iteration the thread must
        // neither allocate, lock nor block: RealtimeSanitizer checks it
        // when built in (`.ci/run`), and the guard ends the region before
        // the next deadline sleep.
        let _realtime = rtsan_standalone::ScopedSanitizeRealtime::default();
        let reference = stopping_since.is_none()
            && options
                .interleave
                .is_some_and(|block| (wake.tick / block.max(1)).is_multiple_of(2));
        let mut events = 0u8;
        let mut finished = None;
        if !reference {
            // The core counts its own ticks: in `bench latency` it only
            // runs in the full blocks, as if the reference blocks did not
            // exist; in `run` its ticks are the scheduler's, skips included.
            let skipped = if options.interleave.is_some() {
                0
            } else {
                wake.skipped
            };
            core_tick = if options.interleave.is_some() {
                core_tick + 1
            } else {
                wake.tick
            };
            let out = match sensor.sample(skipped, &mut drops) {
                Some(volts) => core.step(core_tick, volts),
                None => core.step_missing(core_tick),
            };
            if let Some(command) = out.motion.arm_command {
                last_arm_command = command;
                if rings.arm.push(command).is_err() {
                    drops.arm_commands += 1;
                }
            }
            for event in out.events.iter() {
                events = events.saturating_add(1);
                if rings.events.push((out.tick, *event)).is_err() {
                    drops.events += 1;
                }
            }

            if stopping_since.is_none() {
                let reason = if options.stop.load(Ordering::Relaxed) {
                    Some("signal")
                } else if limit_ticks.is_some_and(|n| wake.tick + 1 >= n) {
                    Some("time")
                } else if limit_ticks.is_none() && sensor.ended() {
                    Some("sensor ended")
                } else {
                    None
                };
                if let Some(reason) = reason {
                    stop_reason = reason;
                    stopping_since = Some(wake.tick);
                    core.begin_stop();
                }
            }
            if let Some(since) = stopping_since {
                still_ticks = if out.motion.is_still() {
                    still_ticks + 1
                } else {
                    0
                };
                let quiet = still_ticks >= STILL_TICKS && last_arm_command.is_zero();
                if quiet || wake.tick - since >= MAX_STOP_TICKS {
                    finished = Some((out.motion.velocity(), wake.woke_ns));
                }
            }
        }
        let end = clock.now_ns();
        let record = TickRecord {
            tick: wake.tick,
            wake_latency_ns: wake.latency_ns,
            compute_ns: end.saturating_sub(wake.woke_ns),
            period_ns: if previous_wake == 0 {
                0
            } else {
                wake.woke_ns - previous_wake
            },
            skipped: u32::try_from(wake.skipped).unwrap_or(u32::MAX),
            events,
            reference,
            drops,
        };
        previous_wake = wake.woke_ns;
        if rings.records.push(record).is_err() {
            drops.records += 1;
        }
        if let Some(result) = finished {
            break result;
        }
    };
    let allocations = crate::alloc_counter::thread_allocations() - allocations_before;
    let wall_seconds = started.elapsed().as_secs_f64();
    ControlResult {
        drops,
        settings: setup.settings.clone(),
        preempt_rt: setup.preempt_rt,
        stats: scheduler.stats(),
        drift_ticks: scheduler.drift_ticks(last_woke),
        allocations,
        stop_reason,
        final_velocity,
        last_arm_command,
        wall_seconds,
    }
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

/// What [`run_simulated`] did.
#[derive(Debug, Clone)]
pub struct SimulatedRun {
    /// Ticks the loop ran.
    pub ticks: u64,
    /// Events the loop pushed (and a drain thread received).
    pub events: u64,
    /// Arm commands pushed.
    pub arm_commands: u64,
    /// Ring drops.
    pub drops: Drops,
    /// Heap allocations on the loop's thread after start-up.
    pub allocations: u64,
    /// Why the loop ended.
    pub stop_reason: &'static str,
    /// The last command sent to the arm.
    pub last_arm_command: ArmCommand,
}

/// The control loop's own code (the same function [`run`] starts) on a
/// simulated clock, on this thread, as fast as it goes, with `script`
/// played by the synthetic sensor until it ends and the arm brakes to a
/// stop. No real-time settings are asked for. For RealtimeSanitizer and
/// allocation checks of the loop itself: under RTSan, any allocation,
/// lock or blocking call inside a tick aborts the process.
pub fn run_simulated(config: &Config, params: SignalParams, script: &[Step]) -> SimulatedRun {
    let (rings, mut arm_rx, mut record_rx, mut event_rx) = Rings::new();
    let options = RunOptions {
        seconds: None,
        sensor: SensorSource::Synthetic,
        rt: RtOptions {
            fifo_priority: None,
            cpu: None,
            lock_memory: false,
            timer_slack: false,
            cpu_dma_latency: false,
        },
        spin_margin_ns: None,
        stop: Arc::new(AtomicBool::new(false)),
        print_events: false,
        interleave: None,
    };
    let core: Core = Core::new(config);
    let sensor = LoopSensor::Synthetic {
        samples: SignalGenerator::new(params, script),
        again: None,
        rest_volts: config.detector().neutral_volts,
        ended: false,
    };
    // The loop's rings are drained on another thread, as in `run`.
    let (result, (ticks, events, arm_commands)) = thread::scope(|scope| {
        let drain = scope.spawn(move || {
            let (mut ticks, mut events, mut arm_commands) = (0u64, 0u64, 0u64);
            loop {
                let abandoned = record_rx.is_abandoned();
                let mut popped = false;
                while let Ok(_record) = record_rx.pop() {
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
                if abandoned {
                    break (ticks, events, arm_commands);
                }
                if !popped {
                    thread::yield_now();
                }
            }
        });
        let result = control_loop(SimClock::default(), core, sensor, rings, &options);
        (result, drain.join().expect("the drain thread"))
    });
    SimulatedRun {
        ticks: ticks + result.drops.records,
        events: events + result.drops.events,
        arm_commands: arm_commands + result.drops.arm_commands,
        drops: result.drops,
        allocations: result.allocations,
        stop_reason: result.stop_reason,
        last_arm_command: result.last_arm_command,
    }
}

/// Runs the control loop with its threads until it ends; this thread is
/// the telemetry thread. Events are printed as they happen if asked.
pub fn run(config: &Config, options: RunOptions) -> anyhow::Result<RunReport> {
    let (rings, mut arm_rx, mut record_rx, mut event_rx) = Rings::new();
    let core: Core = Core::new(config);

    // The sensor: the scripted user in the loop, or a CSV sensor thread.
    let mut sensor_thread = None;
    let (script, params) = match &options.sensor {
        SensorSource::Synthetic => match config.interface() {
            Interface::Asp => {
                let mut params = SignalParams::clean(config.detector(), 1);
                params.noise_volts = 0.02;
                params.hum_volts = 0.03;
                (run_script(config).0, Some(params))
            }
            // The scanning user reacts to the highlight: their breaths come
            // from a closed-loop session on a simulated core.
            Interface::Bsp => {
                let (params, script) =
                    crate::study::user::scripted_session(config, &crate::study::user::RUN_STEPS, 1);
                (script, Some(params))
            }
        },
        SensorSource::Csv(path) => {
            let mut input = CsvSignal::open(path)?;
            let (mut tx, rx) = RingBuffer::<f64>::new(SAMPLE_RING);
            let finished = Arc::new(AtomicBool::new(false));
            let done = finished.clone();
            let stop = options.stop.clone();
            sensor_thread = Some((
                rx,
                finished,
                thread::Builder::new().name("sensor".into()).spawn(
                    move || -> anyhow::Result<()> {
                        let mut clock = MonotonicClock;
                        let mut deadline = clock.now_ns();
                        let result = (|| {
                            while let Some(volts) = input.next_sample()? {
                                if stop.load(Ordering::Relaxed) {
                                    break;
                                }
                                deadline += PERIOD_NS;
                                clock.sleep_until_ns(deadline);
                                // Full: the loop is behind; the sample is lost
                                // and the loop counts what it discards.
                                let _ = tx.push(volts);
                            }
                            Ok(())
                        })();
                        done.store(true, Ordering::Release);
                        result
                    },
                )?,
            ));
            (Vec::<Step>::new(), None)
        }
    };

    let arm_config = config.clone();
    let arm_thread = thread::Builder::new().name("arm".into()).spawn(move || {
        let mut arm = SimulatedJaco::new(&arm_config);
        let mut received = 0u64;
        loop {
            match arm_rx.pop() {
                Ok(command) => {
                    let _ = arm.send(&command);
                    // The simulated arm executes the command's 10 ms cycle.
                    for _ in 0..crate::motion::stream::ARM_STREAM_PERIOD_TICKS {
                        arm.advance_ms();
                    }
                    received += 1;
                }
                Err(_) if arm_rx.is_abandoned() => break,
                Err(_) => thread::sleep(Duration::from_millis(2)),
            }
        }
        arm.stop(); // the stream has ended: the arm stands still
        (arm.state(), received)
    })?;

    let cpu_before = cpu_seconds();
    let wall = Instant::now();
    let loop_options = options.clone();
    let rest_volts = config.detector().neutral_volts;
    let (ring_sensor, csv_thread) = match sensor_thread {
        Some((rx, finished, handle)) => (Some((rx, finished)), Some(handle)),
        None => (None, None),
    };
    let control = thread::Builder::new()
        .name("control".into())
        .spawn(move || {
            let sensor = match (ring_sensor, params) {
                (Some((samples, finished)), _) => LoopSensor::Ring { samples, finished },
                (None, Some(params)) => LoopSensor::Synthetic {
                    samples: SignalGenerator::new(params, &script),
                    again: loop_options.interleave.map(|_| (params, script.as_slice())),
                    rest_volts,
                    ended: false,
                },
                (None, None) => unreachable!("a sensor is always chosen"),
            };
            control_loop(MonotonicClock, core, sensor, rings, &loop_options)
        })?;

    // Telemetry: this thread.
    let mut full = Latencies::default();
    let mut reference = Latencies::default();
    let mut events = 0u64;
    let mut drain = |record_rx: &mut rtrb::Consumer<TickRecord>,
                     event_rx: &mut rtrb::Consumer<TimedEvent>| {
        while let Ok((tick, event)) = event_rx.pop() {
            events += 1;
            if options.print_events {
                println!("{}", crate::replay::event_json(tick, &event));
            }
        }
        while let Ok(record) = record_rx.pop() {
            if record.reference {
                reference.record(&record);
            } else {
                full.record(&record);
            }
        }
    };
    while !control.is_finished() {
        drain(&mut record_rx, &mut event_rx);
        thread::sleep(Duration::from_millis(5));
    }
    let result = control
        .join()
        .map_err(|_| anyhow::anyhow!("the control thread panicked"))?;
    drain(&mut record_rx, &mut event_rx);
    let wall_seconds = wall.elapsed().as_secs_f64();
    let cpu_percent = 100.0 * (cpu_seconds() - cpu_before) / wall_seconds.max(1e-9);
    let (arm, arm_commands) = arm_thread
        .join()
        .map_err(|_| anyhow::anyhow!("the arm thread panicked"))?;
    if let Some(handle) = csv_thread {
        handle
            .join()
            .map_err(|_| anyhow::anyhow!("the sensor thread panicked"))??;
    }

    Ok(RunReport {
        settings: result.settings,
        preempt_rt: result.preempt_rt,
        stats: result.stats,
        drift_ticks: result.drift_ticks,
        full,
        reference,
        drops: result.drops,
        control_thread_allocations: result.allocations,
        events,
        stop_reason: result.stop_reason,
        arm,
        arm_commands,
        last_arm_command: result.last_arm_command,
        final_velocity: result.final_velocity,
        wall_seconds: result.wall_seconds,
        cpu_percent,
    })
}

impl RunReport {
    fn ratio(&self, quantile: f64) -> f64 {
        use crate::rt::telemetry::at;
        let reference = at(&self.reference.wake, quantile) as f64;
        let full = at(&self.full.wake, quantile) as f64;
        if reference > 0.0 {
            full / reference
        } else {
            0.0
        }
    }

    /// Whether the setting whose name starts with `prefix` was granted.
    pub fn granted(&self, prefix: &str) -> bool {
        self.settings
            .iter()
            .any(|s| s.name.starts_with(prefix) && s.granted)
    }

    /// The final report of `run`, for people.
    pub fn to_text(&self) -> String {
        use crate::rt::telemetry::percentile_line;
        let mut s = String::from("\n== sipnpuff run report\n");
        s += "real-time settings:\n";
        for setting in &self.settings {
            let state = if setting.granted { "granted" } else { "DENIED" };
            let detail = if setting.detail.is_empty() {
                String::new()
            } else {
                format!(" ({})", setting.detail)
            };
            s += &format!("  {:<36} {state}{detail}\n", setting.name);
        }
        let st = &self.stats;
        s += &format!(
            "ticks: {} run, {} skipped after {} missed deadlines, drift {} ticks, {:.2} s, stopped by: {}\n",
            st.ticks_run,
            st.skipped_ticks,
            st.missed_deadlines,
            self.drift_ticks,
            self.wall_seconds,
            self.stop_reason
        );
        s += "per tick, µs:\n";
        s += &(percentile_line("wake-up latency", &self.full.wake) + "\n");
        s += &(percentile_line("compute", &self.full.compute) + "\n");
        s += &(percentile_line("period", &self.full.period) + "\n");
        let d = &self.drops;
        s += &format!(
            "rings: dropped {} samples, {} arm commands, {} tick records, {} events\n",
            d.samples, d.arm_commands, d.records, d.events
        );
        s += &format!(
            "control thread heap allocations after start: {}\nevents: {}; process CPU: {:.1} %\n",
            self.control_thread_allocations, self.events, self.cpu_percent
        );
        let p = self.arm.pose.translation.vector;
        let r = self.arm.pose.rotation.scaled_axis();
        let v = self.final_velocity;
        s += &format!(
            "arm: {} commands at 100 Hz; final position ({:.4}, {:.4}, {:.4}) m, rotation vector ({:.4}, {:.4}, {:.4}) rad, fingers {:.0}\n",
            self.arm_commands, p.x, p.y, p.z, r.x, r.y, r.z, self.arm.fingers
        );
        s += &format!(
            "final commanded velocity: linear ({}, {}, {}) m/s, angular ({}, {}, {}) rad/s, fingers {} units/s; last arm command zero: {}\n",
            v[0],
            v[1],
            v[2],
            v[3],
            v[4],
            v[5],
            v[6],
            self.last_arm_command.is_zero()
        );
        s
    }

    /// The `bench latency --json` object (all times in ns).
    pub fn latency_json(&self, seconds: f64) -> serde_json::Value {
        let pct = crate::rt::telemetry::percentiles_json;
        serde_json::json!({
            "seconds": seconds,
            "ticks": self.stats.ticks_run,
            "reference_ticks": self.reference.wake.len(),
            "full_ticks": self.full.wake.len(),
            "missed_deadlines": self.stats.missed_deadlines,
            "skipped_ticks": self.stats.skipped_ticks,
            "drift_ticks": self.drift_ticks,
            "reference": { "wake_latency_ns": pct(&self.reference.wake) },
            "full": { "wake_latency_ns": pct(&self.full.wake), "compute_ns": pct(&self.full.compute) },
            "ratio": { "p50": self.ratio(0.5), "p99": self.ratio(0.99), "p999": self.ratio(0.999) },
            "control_thread_allocations": self.control_thread_allocations,
            "cpu_percent": self.cpu_percent,
            "drops": {
                "samples": self.drops.samples, "arm_commands": self.drops.arm_commands,
                "records": self.drops.records, "events": self.drops.events,
            },
            "rt": {
                "sched_fifo": self.granted("SCHED_FIFO"),
                "mlockall": self.granted("mlockall"),
                "affinity": self.granted("pinned"),
                "timer_slack": self.granted("timer slack"),
                "cpu_dma_latency": self.granted("/dev/cpu_dma_latency"),
                "preempt_rt": self.preempt_rt,
            },
        })
    }

    /// `bench latency` for people.
    pub fn latency_text(&self, seconds: f64) -> String {
        use crate::rt::telemetry::percentile_line;
        let mut s = format!(
            "bench latency: {seconds} s, blocks of reference ticks (bare deadline wait) and full ticks, same thread\n"
        );
        s += "wake-up latency, µs:\n";
        s += &(percentile_line("reference", &self.reference.wake) + "\n");
        s += &(percentile_line("full tick", &self.full.wake) + "\n");
        s += &(percentile_line("full tick compute", &self.full.compute) + "\n");
        s += &format!(
            "ratio full/reference: p50 {:.2}, p99 {:.2}, p99.9 {:.2}\n",
            self.ratio(0.5),
            self.ratio(0.99),
            self.ratio(0.999)
        );
        s += &format!(
            "ticks {} ({} missed deadlines, {} skipped, drift {}), control thread allocations {}, CPU {:.1} %\n",
            self.stats.ticks_run,
            self.stats.missed_deadlines,
            self.stats.skipped_ticks,
            self.drift_ticks,
            self.control_thread_allocations,
            self.cpu_percent
        );
        let denied: Vec<&str> = self
            .settings
            .iter()
            .filter(|s| !s.granted)
            .map(|s| s.name.as_str())
            .collect();
        if !denied.is_empty() {
            s += &format!("denied: {}\n", denied.join("; "));
        }
        s
    }

    /// Writes each histogram as `.hgrm` (µs) into `dir`.
    pub fn write_histograms(&self, dir: &std::path::Path) -> std::io::Result<Vec<PathBuf>> {
        std::fs::create_dir_all(dir)?;
        let mut written = Vec::new();
        for (name, h) in [
            ("wake_latency", &self.full.wake),
            ("compute", &self.full.compute),
            ("period", &self.full.period),
            ("reference_wake_latency", &self.reference.wake),
        ] {
            if h.is_empty() {
                continue;
            }
            let path = dir.join(format!("{name}.hgrm"));
            let mut file = std::io::BufWriter::new(std::fs::File::create(&path)?);
            crate::rt::telemetry::write_hgrm(&mut file, h)?;
            std::io::Write::flush(&mut file)?;
            written.push(path);
        }
        Ok(written)
    }
}
