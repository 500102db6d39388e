//! The control loop: at each 1 ms deadline, one tick of work, measured and
//! recorded. Everything it needs is built before the first deadline;
//! inside the loop it neither allocates, locks nor blocks except in the
//! deadline sleep (RealtimeSanitizer checks this in CI).
//!
//! The loop is generic over its [`TickWork`]. The work a deployment runs is
//! [`ControlTick`]: read the sensor, step the pipeline, push the arm's
//! command and the events into their rings, and bring the arm to a safe
//! stop when asked. `bench latency` wraps the same `ControlTick` (see
//! `tools::latency`), so the loop measured is the loop deployed, and the
//! loop RealtimeSanitizer and the allocation tests check
//! ([`run_simulated`](super::simulated::run_simulated)) is the same code on a
//! simulated clock.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant, SystemTime};

use nalgebra::Isometry3;

use crate::clock::Clock;
use crate::control::detector::FaultReason;
use crate::control::event::{Event, TimedEvent};
use crate::control::motion::feedback::ArmFault;
use crate::control::motion::stream::ArmCommand;
use crate::control::pipeline::Pipeline;
use crate::control::tick::{ArmInput, ArmPose, TickInput, TickOutput};
use crate::control::view::CoreView;
use crate::rt::alloc_counter;
use crate::rt::arm_thread::ArmHandoff;
use crate::rt::output_thread::{OutputLane, TickZero};
use crate::rt::scheduler::{Scheduler, SchedulerStats, Wake};
use crate::rt::setup::{RtOptions, RtSetting, setup_current_thread};
pub use crate::rt::stop::StopReason;
use crate::rt::stop::StopRequest;
use crate::rt::telemetry::{Drops, TickRecord};
use crate::sensor::{Reading, Samples};
use crate::wakes::own_page_faults;

/// The control period: 1 ms.
pub const PERIOD_NS: u64 = 1_000_000;
/// Still ticks (zero command) after a stop before the stream ends: two
/// full 10 ms arm windows.
pub const STILL_TICKS: u64 = 20;
/// Longest a safe stop may take before the loop ends anyway, ticks.
pub const MAX_STOP_TICKS: u64 = 5000;

/// What one tick of work says to the loop. `Copy`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TickOutcome {
    /// Events the tick produced.
    pub events: u8,
    /// A bare reference tick (`bench latency`), recorded apart.
    pub reference: bool,
    /// Ring drops so far.
    pub drops: Drops,
    /// The work is done: the loop ends after this tick.
    pub finished: bool,
    /// What the core was given (not on a `reference` tick).
    pub input: TickInput,
    /// Where the user is after the tick (for the display).
    pub view: CoreView,
}

/// What the work reports when the loop ends.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct WorkSummary {
    /// Ring drops.
    pub drops: Drops,
    /// Why it stopped.
    pub stop_reason: StopReason,
    /// The last commanded twist `[v (3), ω (3), fingers]`.
    pub final_velocity: [f64; 7],
    /// The last command pushed to the arm.
    pub last_arm_command: ArmCommand,
    /// The commanded twist on the tick the stop began.
    pub velocity_at_stop: [f64; 7],
    /// Ticks from the start of the stop to the first still tick: the brake
    /// (0 if the arm was already still).
    pub braking_ticks: u64,
    /// The core's arm fault, if there was one.
    pub arm_fault: Option<ArmFault>,
    /// Measured poses the core took in.
    pub measured_poses: u64,
    /// The largest correction they made to the pose estimate, m.
    pub largest_correction_m: f64,
    /// Sensor faults the core reported: each stopped the arm.
    pub faults: SensorFaults,
}

/// Sensor faults counted on the control thread (RT-safe: counters).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct SensorFaults {
    /// Breaths held past `detector.max_hold_ms`.
    pub held_too_long: u64,
    /// The sensor's device went away.
    pub disconnected: u64,
    /// Disconnections the sensor came back from (`reconnect = true`), with
    /// detection resumed.
    pub reconnected: u64,
    /// Every other sensor fault (a bad or stale sample, a stall).
    pub other: u64,
}

impl SensorFaults {
    /// All of them.
    pub fn total(&self) -> u64 {
        self.held_too_long + self.disconnected + self.other
    }

    /// The faults that make the run a failure: all but the disconnections
    /// the sensor came back from, which `reconnect = true` asked for.
    pub fn failing(&self) -> u64 {
        self.total() - self.reconnected
    }

    /// Counts `event`; `away` keeps whether the fault in force is a
    /// disconnection, so that its recovery counts as a reconnection.
    fn count(&mut self, event: &Event, away: &mut bool) {
        match event {
            Event::Fault { reason } => {
                *away = matches!(reason, FaultReason::Disconnected);
                match reason {
                    FaultReason::Stuck { .. } => self.held_too_long += 1,
                    FaultReason::Disconnected => self.disconnected += 1,
                    _ => self.other += 1,
                }
            }
            Event::Recovered if *away => {
                *away = false;
                self.reconnected += 1;
            }
            _ => {}
        }
    }
}

/// One tick of work at each deadline. RT-safe: implementations must not
/// allocate, lock or block.
pub trait TickWork: Send {
    /// Runs the tick the scheduler woke for. `stop` is set on every tick
    /// the run should end (a signal arrived, the time is up): the work
    /// begins a safe stop and runs on until [`TickOutcome::finished`].
    fn tick(&mut self, wake: &Wake, stop: Option<StopReason>) -> TickOutcome;

    /// Stopping has begun.
    fn stopping(&self) -> bool;

    /// The work's figures at the end.
    fn summary(&self) -> WorkSummary;
}

/// The rings the control tick pushes into, allocated before the loop. A
/// full ring never blocks: the item is dropped and counted.
pub struct OutputRings {
    /// The 100 Hz commands, to the arm thread (woken for each).
    pub arm: ArmHandoff,
    /// Events, to the telemetry side.
    pub events: rtrb::Producer<TimedEvent>,
    /// `run --record`: a copy of each arm command, to the telemetry side
    /// for the session recorder (the 100 Hz stream the core produced,
    /// whatever the arm ring drops).
    pub recorded: Option<rtrb::Producer<ArmCommand>>,
    /// The outputs beyond the arm (`run --output`), each offered the
    /// commands it serves.
    pub outputs: Vec<OutputLane>,
}

/// The production tick: sensor → pipeline → rings, with the safe stop.
pub struct ControlTick<S: Samples> {
    core: Pipeline,
    sensor: S,
    rings: OutputRings,
    /// End the run when the sensor ends (no time limit given).
    stop_when_sensor_ends: bool,
    /// Number the pipeline's ticks consecutively, ignoring the scheduler's
    /// skips (`bench latency`, where reference ticks are not the core's).
    own_ticks: Option<u64>,
    drops: Drops,
    stop_reason: StopReason,
    stopping_since: Option<u64>,
    still_ticks: u64,
    final_velocity: [f64; 7],
    last_arm_command: ArmCommand,
    velocity_at_stop: [f64; 7],
    braking_ticks: Option<u64>,
    /// The arm's measured poses, when it reports them.
    measured: Option<rtrb::Consumer<Isometry3<f64>>>,
    /// Where a measuring arm starts, given to the core on the first tick.
    start_pose: Option<Isometry3<f64>>,
    /// The core was told the arm's link is lost.
    told_link_lost: bool,
    /// The safe stop was decided on the last tick: it begins on this one.
    stop_next: bool,
    /// The core's output, written in place each tick (no copy of it).
    out: TickOutput,
    faults: SensorFaults,
    /// The sensor fault in force is a disconnection.
    sensor_away: bool,
}

impl<S: Samples> ControlTick<S> {
    /// The tick for `core` fed by `sensor`. With `stop_when_sensor_ends`
    /// the run stops safely when the sensor's samples end.
    pub fn new(core: Pipeline, sensor: S, rings: OutputRings, stop_when_sensor_ends: bool) -> Self {
        ControlTick {
            core,
            sensor,
            rings,
            stop_when_sensor_ends,
            own_ticks: None,
            drops: Drops::default(),
            stop_reason: StopReason::Running,
            stopping_since: None,
            still_ticks: 0,
            final_velocity: [0.0; 7],
            last_arm_command: ArmCommand::default(),
            velocity_at_stop: [0.0; 7],
            braking_ticks: None,
            measured: None,
            start_pose: None,
            told_link_lost: false,
            stop_next: false,
            out: TickOutput::default(),
            faults: SensorFaults::default(),
            sensor_away: false,
        }
    }

    /// Each command handed to the arm wakes `arm_thread`.
    pub fn wakes_arm(&mut self, arm_thread: std::thread::Thread) {
        self.rings.arm.wakes(arm_thread);
    }

    /// The arm measures its pose: the motion starts at `start` (the first
    /// tick's [`ArmPose::Start`]), then each tick gives the core the newest
    /// measurement from `measured`.
    pub fn with_measured_poses(
        mut self,
        start: Isometry3<f64>,
        measured: rtrb::Consumer<Isometry3<f64>>,
    ) -> Self {
        self.start_pose = Some(start);
        self.measured = Some(measured);
        self
    }

    /// Numbers the pipeline's ticks 0, 1, 2, … whatever the scheduler's
    /// tick, and reads no skipped samples: for a wrapper that runs this
    /// work only on some of the scheduler's ticks.
    pub fn with_own_tick_count(mut self) -> Self {
        self.own_ticks = Some(0);
        self
    }
}

impl<S: Samples> TickWork for ControlTick<S> {
    fn tick(&mut self, wake: &Wake, stop: Option<StopReason>) -> TickOutcome {
        // In `run` the core's ticks are the scheduler's, skips included, so
        // its timers stay true to the wall clock.
        let (tick, skipped) = match &mut self.own_ticks {
            Some(count) => {
                *count += 1;
                (*count, 0)
            }
            None => (wake.tick, wake.skipped),
        };
        // A gap longer than the core's `stale_ms` is a stall (the process
        // was stopped, the machine paused): the core faults on this tick,
        // seeing the tick jump, and nothing queued meanwhile may be
        // replayed as a breath: the backlog goes, counted.
        let reading = if skipped >= self.core.detector().stale_ms() {
            self.drops.samples += self.sensor.discard_backlog(skipped);
            Reading::default()
        } else {
            self.sensor.try_read(skipped)
        };
        self.drops.samples += reading.discarded;
        // What the arm said, before the sample: on the first tick where a
        // measuring arm starts; then a lost link (the arm thread ended its
        // stream) and the newest measured pose.
        let mut arm = ArmInput::default();
        if stop == Some(StopReason::ArmFault) && !self.told_link_lost {
            self.told_link_lost = true;
            arm.link_lost = true;
        }
        if let Some(start) = self.start_pose.take() {
            arm.pose = Some((ArmPose::Start, start));
        } else if let Some(measured) = &mut self.measured {
            let mut newest = None;
            while let Ok(pose) = measured.pop() {
                newest = Some(pose);
            }
            arm.pose = newest.map(|pose| (ArmPose::Measured, pose));
        }
        // The core's whole input on this tick, as recorded and replayed.
        let input = TickInput {
            tick,
            sample: reading.sample,
            imu: reading.imu,
            arm,
            stop: std::mem::take(&mut self.stop_next),
        };
        self.core.step(&input, &mut self.out);
        let out = &self.out;
        // The core found the arm untrustworthy (its measured pose silent
        // or off the commanded path): the run ends once it is still.
        let stop = stop.or(self.core.arm_fault().map(|_| StopReason::ArmFault));
        if let Some(command) = out.motion.arm_command {
            self.last_arm_command = command;
            if self.rings.arm.hand(command, wake.woke_ns).is_err() {
                self.drops.arm_commands += 1;
            }
            if let Some(recorded) = &mut self.rings.recorded
                && recorded.push(command).is_err()
            {
                self.drops.recorded_commands += 1;
            }
        }
        for command in out.outputs.iter() {
            for lane in &mut self.rings.outputs {
                lane.offer(command);
            }
        }
        let mut events = 0u8;
        for event in out.events.iter() {
            events = events.saturating_add(1);
            self.faults.count(event, &mut self.sensor_away);
            let timed = TimedEvent {
                tick: out.tick,
                event: *event,
            };
            if self.rings.events.push(timed).is_err() {
                self.drops.events += 1;
            }
        }
        if self.stopping_since.is_none() {
            let sensor_ended = self.stop_when_sensor_ends && self.sensor.ended();
            if let Some(reason) = stop.or(sensor_ended.then_some(StopReason::SensorEnded)) {
                // The core's next input begins the safe stop: from then on
                // it is in detection mode for good, every target is zero
                // and the arm brakes through Ruckig under the usual limits.
                self.stop_reason = reason;
                self.stopping_since = Some(wake.tick);
                self.velocity_at_stop = out.motion.velocity();
                self.stop_next = true;
            }
        }
        let mut finished = false;
        if let Some(since) = self.stopping_since {
            // The run ends only while stopping: its last velocity is here.
            self.final_velocity = out.motion.velocity();
            self.still_ticks = if out.motion.is_still() {
                self.still_ticks + 1
            } else {
                0
            };
            if self.braking_ticks.is_none() && out.motion.is_still() {
                self.braking_ticks = Some(wake.tick.saturating_sub(since));
            }
            let quiet = self.still_ticks >= STILL_TICKS && self.last_arm_command.is_zero();
            finished = quiet || wake.tick.saturating_sub(since) >= MAX_STOP_TICKS;
        }
        TickOutcome {
            events,
            reference: false,
            drops: self.drops,
            finished,
            input,
            view: self.core.view(),
        }
    }

    fn stopping(&self) -> bool {
        self.stopping_since.is_some()
    }

    fn summary(&self) -> WorkSummary {
        WorkSummary {
            drops: self.drops,
            stop_reason: self.stop_reason,
            final_velocity: self.final_velocity,
            last_arm_command: self.last_arm_command,
            velocity_at_stop: self.velocity_at_stop,
            braking_ticks: self.braking_ticks.unwrap_or(0),
            arm_fault: self.core.arm_fault(),
            measured_poses: self.core.motion().feedback().measurements(),
            largest_correction_m: self.core.motion().feedback().largest_correction_m(),
            faults: self.faults,
        }
    }
}

/// When and how the loop runs.
#[derive(Debug, Clone)]
pub struct LoopOptions {
    /// End after this many scheduler ticks (`None`: when the work ends).
    pub limit_ticks: Option<u64>,
    /// Real-time settings to ask for.
    pub rt: RtOptions,
    /// Hybrid wait: sleep until this long before each deadline, then spin.
    pub spin_margin_ns: Option<u64>,
    /// A safe stop requested (by a signal handler, a failed output).
    pub stop: StopRequest,
    /// Set by the arm thread when the arm failed.
    pub arm_fault: Arc<AtomicBool>,
    /// Told the wall-clock time of tick 0 (the outputs stamp commands
    /// with it), if anyone needs it.
    pub tick_zero: Option<TickZero>,
}

/// What the loop did.
#[derive(Debug, Clone)]
pub struct LoopResult {
    /// The work's figures.
    pub work: WorkSummary,
    /// Ring drops, tick records included.
    pub drops: Drops,
    /// Real-time settings, granted or denied.
    pub settings: Vec<RtSetting>,
    /// The kernel is PREEMPT_RT.
    pub preempt_rt: bool,
    /// Scheduler counts.
    pub stats: SchedulerStats,
    /// Periods elapsed by the clock minus ticks run and skipped.
    pub drift_ticks: i64,
    /// Heap allocations on the loop's thread after start-up.
    pub allocations: u64,
    /// Page faults the loop's thread took after start-up.
    pub page_faults: u64,
    /// Wall time of the loop, s.
    pub wall_seconds: f64,
}

/// Runs `work` at each deadline of `clock` until it finishes, pushing one
/// [`TickRecord`] per tick into `records`. Sets up the calling thread
/// first (priority, affinity, memory locking) as `options.rt` asks.
pub fn control_loop<C: Clock, W: TickWork>(
    mut clock: C,
    work: &mut W,
    records: &mut rtrb::Producer<TickRecord>,
    options: &LoopOptions,
) -> LoopResult {
    let setup = setup_current_thread(&options.rt);
    let started = Instant::now();
    let allocations_before = alloc_counter::thread_allocations();
    let faults_before = own_page_faults();
    let mut record_drops = 0u64;

    let start = clock.now_ns() + PERIOD_NS;
    if let Some(zero) = &options.tick_zero {
        let until_start = Duration::from_nanos(start.saturating_sub(clock.now_ns()));
        zero.set(SystemTime::now() + until_start);
    }
    let mut scheduler = Scheduler::new(start, PERIOD_NS, options.spin_margin_ns);
    let mut previous_wake = 0u64;
    let last_woke = loop {
        let wake = scheduler.wait(&mut clock);
        // From the wake-up to the end of the iteration the thread must
        // neither allocate, lock nor block: RealtimeSanitizer checks it
        // when built in (`.ci/run`), and the guard ends the region before
        // the next deadline sleep.
        let _realtime = rtsan_standalone::ScopedSanitizeRealtime::default();
        let stop = if let Some(reason) = options.stop.reason() {
            Some(reason)
        } else if options.arm_fault.load(Ordering::Relaxed) {
            Some(StopReason::ArmFault)
        } else if options.limit_ticks.is_some_and(|n| wake.tick + 1 >= n) {
            Some(StopReason::Time)
        } else {
            None
        };
        let outcome = work.tick(&wake, stop);
        let end = clock.now_ns();
        let mut drops = outcome.drops;
        drops.records = record_drops;
        let record = TickRecord {
            tick: wake.tick,
            woke_ns: wake.woke_ns,
            wake_latency_ns: wake.latency_ns,
            compute_ns: end.saturating_sub(wake.woke_ns),
            period_ns: if previous_wake == 0 {
                0
            } else {
                wake.woke_ns - previous_wake
            },
            skipped: u32::try_from(wake.skipped).unwrap_or(u32::MAX),
            events: outcome.events,
            reference: outcome.reference,
            drops,
            input: outcome.input,
            view: outcome.view,
        };
        previous_wake = wake.woke_ns;
        if records.push(record).is_err() {
            record_drops += 1;
        }
        if outcome.finished {
            break wake.woke_ns;
        }
    };
    let allocations = alloc_counter::thread_allocations() - allocations_before;
    let page_faults = own_page_faults().saturating_sub(faults_before);
    let summary = work.summary();
    LoopResult {
        drops: Drops {
            records: record_drops,
            ..summary.drops
        },
        work: summary,
        settings: setup.settings.clone(),
        preempt_rt: setup.preempt_rt,
        stats: scheduler.stats(),
        drift_ticks: scheduler.drift_ticks(last_woke),
        allocations,
        page_faults,
        wall_seconds: started.elapsed().as_secs_f64(),
    }
}
