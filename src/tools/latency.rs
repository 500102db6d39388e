//! `sipnpuff bench latency`: the production control loop with blocks of
//! bare reference ticks (the deadline wait alone) interleaved on the same
//! thread, so the full tick's wake-up latency is read against a reference
//! measured in the same run. The interleaving is a wrapper around the
//! production tick ([`Interleaved`]); the loop itself is the one `run`
//! deploys.

use serde::Serialize;

use crate::arm::Arm;
use crate::arm::sim::SimArm;
use crate::config::Config;
use crate::rt::control_loop::{ControlTick, StopReason, TickOutcome, TickWork, WorkSummary};
use crate::rt::report::RunReport;
use crate::rt::scheduler::Wake;
use crate::rt::telemetry::{Drops, Percentiles};
use crate::rt::telemetry_thread::Watchers;
use crate::rt::threads::{LoopSettings, RunError, RunOptions, Work, run};
use crate::sensor::Samples;
use crate::sim::synthetic_sensor::SyntheticSensor;

/// Alternates blocks of `block` reference ticks (nothing but the wait) and
/// `block` ticks of the wrapped work; once the work is stopping, every
/// tick is the work's.
pub struct Interleaved<W> {
    inner: W,
    block: u64,
}

impl<W: TickWork> Interleaved<W> {
    /// Wraps `inner` (which should number its own ticks: it runs on half
    /// of the scheduler's).
    pub fn new(inner: W, block: u64) -> Self {
        Interleaved {
            inner,
            block: block.max(1),
        }
    }
}

impl<W: TickWork> TickWork for Interleaved<W> {
    fn tick(&mut self, wake: &Wake, stop: Option<StopReason>) -> TickOutcome {
        let reference = !self.inner.stopping() && (wake.tick / self.block).is_multiple_of(2);
        if reference {
            // A stop asked for now is still asked for at the next full
            // tick (the signal stays set, the time stays up).
            return TickOutcome {
                events: 0,
                reference: true,
                drops: self.inner.summary().drops,
                finished: false,
                ..TickOutcome::default()
            };
        }
        self.inner.tick(wake, stop)
    }

    fn stopping(&self) -> bool {
        self.inner.stopping()
    }

    fn summary(&self) -> WorkSummary {
        self.inner.summary()
    }
}

/// The work of `bench latency`: the production tick, numbering its own
/// ticks, in blocks of `block` ticks between blocks of reference ticks.
#[derive(Debug, Clone, Copy)]
pub struct Interleave {
    /// Ticks per block.
    pub block: u64,
}

impl<S: Samples + 'static> Work<S> for Interleave {
    type Tick = Interleaved<ControlTick<S>>;

    fn around(self, tick: ControlTick<S>) -> Self::Tick {
        Interleaved::new(tick.with_own_tick_count(), self.block)
    }
}

/// Runs the built-in user, repeated (a sensor that does not end), for
/// `settings.seconds` through the production loop to the simulated arm,
/// interleaved with reference ticks in blocks of `block`.
pub fn bench_latency(
    config: &Config,
    block: u64,
    settings: LoopSettings,
) -> Result<RunReport, RunError> {
    let sensor = SyntheticSensor::built_in_user(config).repeating();
    let arm: Box<dyn Arm> = Box::new(SimArm::new(config.core()));
    let options = RunOptions {
        sensor,
        arm,
        settings,
        work: Interleave { block },
        watchers: Watchers::default(),
        outputs: Vec::new(),
    };
    run(config.core(), options)
}

/// `bench latency`'s figures (ns), as `--json` prints them.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LatencyReport {
    /// Run length asked for, s.
    pub seconds: f64,
    /// Ticks run.
    pub ticks: u64,
    /// Reference ticks.
    pub reference_ticks: u64,
    /// Full ticks.
    pub full_ticks: u64,
    /// Wake-ups a whole period late or more.
    pub missed_deadlines: u64,
    /// Ticks skipped over those.
    pub skipped_ticks: u64,
    /// Periods elapsed minus ticks run and skipped.
    pub drift_ticks: i64,
    /// The reference ticks.
    pub reference: ReferenceLatency,
    /// The full ticks.
    pub full: FullLatency,
    /// Full over reference wake-up latency.
    pub ratio: Ratios,
    /// Heap allocations on the control thread after start-up.
    pub control_thread_allocations: u64,
    /// Process CPU time over wall time, %.
    pub cpu_percent: f64,
    /// Ring drops.
    pub drops: Drops,
    /// Real-time settings granted.
    pub rt: Granted,
    /// Settings asked for and denied.
    pub denied: Vec<String>,
    /// Why the run ended (`time`, or `signal`).
    pub stop_reason: StopReason,
    /// Wall time of the loop, s.
    pub wall_seconds: f64,
    /// What went wrong at the edges (a bench with errors has failed).
    pub errors: Vec<String>,
}

/// Reference-tick figures.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ReferenceLatency {
    /// Wake-up latency.
    pub wake_latency_ns: Percentiles,
}

/// Full-tick figures.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FullLatency {
    /// Wake-up latency.
    pub wake_latency_ns: Percentiles,
    /// Wake-up to end of the tick's work.
    pub compute_ns: Percentiles,
}

/// Full over reference, at three percentiles.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Ratios {
    /// Medians.
    pub p50: f64,
    /// 99th percentiles.
    pub p99: f64,
    /// 99.9th percentiles.
    pub p999: f64,
}

/// Which real-time settings were granted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Granted {
    /// SCHED_FIFO.
    pub sched_fifo: bool,
    /// Memory locked.
    pub mlockall: bool,
    /// Pinned to a CPU.
    pub affinity: bool,
    /// 1 ns timer slack.
    pub timer_slack: bool,
    /// `/dev/cpu_dma_latency` held at 0.
    pub cpu_dma_latency: bool,
    /// A PREEMPT_RT kernel.
    pub preempt_rt: bool,
}

impl LatencyReport {
    /// The figures of a `bench latency` run of `seconds`.
    pub fn of(run: &RunReport, seconds: f64) -> LatencyReport {
        LatencyReport {
            seconds,
            ticks: run.stats.ticks_run,
            reference_ticks: run.reference.wake.len(),
            full_ticks: run.full.wake.len(),
            missed_deadlines: run.stats.missed_deadlines,
            skipped_ticks: run.stats.skipped_ticks,
            drift_ticks: run.drift_ticks,
            reference: ReferenceLatency {
                wake_latency_ns: Percentiles::of(&run.reference.wake),
            },
            full: FullLatency {
                wake_latency_ns: Percentiles::of(&run.full.wake),
                compute_ns: Percentiles::of(&run.full.compute),
            },
            ratio: Ratios {
                p50: run.ratio(0.5),
                p99: run.ratio(0.99),
                p999: run.ratio(0.999),
            },
            control_thread_allocations: run.control_thread_allocations,
            cpu_percent: run.cpu_percent,
            drops: run.drops,
            rt: Granted {
                sched_fifo: run.granted("SCHED_FIFO"),
                mlockall: run.granted("mlockall"),
                affinity: run.granted("pinned"),
                timer_slack: run.granted("timer slack"),
                cpu_dma_latency: run.granted("/dev/cpu_dma_latency"),
                preempt_rt: run.preempt_rt,
            },
            denied: run
                .settings
                .iter()
                .filter(|s| !s.granted)
                .map(|s| s.name.clone())
                .collect(),
            stop_reason: run.stop_reason,
            wall_seconds: run.wall_seconds,
            errors: run.errors.clone(),
        }
    }

    /// For people.
    pub fn to_text(&self) -> String {
        let mut s = format!(
            "bench latency: {} s, blocks of reference ticks (bare deadline wait) and full ticks, same thread\n",
            self.seconds
        );
        s += "wake-up latency, µs:\n";
        s += &(self.reference.wake_latency_ns.line("reference") + "\n");
        s += &(self.full.wake_latency_ns.line("full tick") + "\n");
        s += &(self.full.compute_ns.line("full tick compute") + "\n");
        s += &format!(
            "ratio full/reference: p50 {:.2}, p99 {:.2}, p99.9 {:.2}\n",
            self.ratio.p50, self.ratio.p99, self.ratio.p999
        );
        s += &format!(
            "ticks {} ({} missed deadlines, {} skipped, drift {}), control thread allocations {}, CPU {:.1} %\n",
            self.ticks,
            self.missed_deadlines,
            self.skipped_ticks,
            self.drift_ticks,
            self.control_thread_allocations,
            self.cpu_percent
        );
        if !self.denied.is_empty() {
            s += &format!("denied: {}\n", self.denied.join("; "));
        }
        for error in &self.errors {
            s += &format!("ERROR: {error}\n");
        }
        s
    }
}
