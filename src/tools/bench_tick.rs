//! `sipnpuff bench tick`: what one control tick costs, tick by tick, as
//! percentiles (criterion's medians cannot give a p99).
//!
//! The demo user (with sensor noise) runs through the full tick: core
//! (detector → matcher → modes → motion) and the simulated arm, as fast as
//! possible. Every tick is timed between two clock reads and recorded in an
//! HdrHistogram; so is, interleaved on the same thread, an empty interval
//! between the same two clock reads: the reference, measured in the same
//! run, that the tick's figures are read against. Not part of the core: it
//! reads clocks.

use std::time::Instant;

use hdrhistogram::Histogram;
use serde::Serialize;

use crate::arm::sim::SimulatedJaco;
use crate::config::Config;
use crate::control::pipeline::Pipeline;
use crate::control::tick::{TickInput, TickOutput};
use crate::rt::alloc_counter;
use crate::rt::telemetry::{PERCENTILES, Percentiles, histogram};
use crate::sim::script::demo_script;
use crate::sim::sensor_model::{SignalGenerator, SignalParams, Step};

/// Histograms of one `bench tick` run, in nanoseconds.
pub struct TickBench {
    /// Ticks run.
    pub ticks: u64,
    /// Two back-to-back clock reads.
    pub reference: Histogram<u64>,
    /// Every full tick.
    pub all: Histogram<u64>,
    /// Ticks on which Ruckig kept its trajectory.
    pub steady: Histogram<u64>,
    /// Ticks on which Ruckig computed a new trajectory.
    pub new_target: Histogram<u64>,
    /// Allocations on the measuring thread during the run.
    pub allocations: u64,
}

/// Runs `seconds` of the demo user (repeated) through the full tick.
pub fn bench_tick(config: &Config, seconds: u64) -> TickBench {
    let params = SignalParams::clean(config.core().detector(), 1)
        .with_noise(0.03)
        .with_hum(0.05);
    let (demo, _) = demo_script(config);
    let ticks = seconds * 1000;
    // Each step plays at least its `ms`: repeat until that covers `ticks`.
    let demo_ms: u64 = demo
        .iter()
        .map(|s| match *s {
            Step::Breath { ms, .. } | Step::Rest { ms } | Step::Dropout { ms } => u64::from(ms),
        })
        .sum();
    let mut script = Vec::new();
    for _ in 0..ticks.div_ceil(demo_ms.max(1)) {
        script.extend_from_slice(&demo);
    }
    let samples: Vec<f64> = SignalGenerator::new(params, &script)
        .take(ticks as usize)
        .collect();

    let mut core = Pipeline::new(config.core());
    let mut out = TickOutput::default();
    let mut arm = SimulatedJaco::new(config.core());
    let mut bench = TickBench {
        ticks: samples.len() as u64,
        reference: histogram(),
        all: histogram(),
        steady: histogram(),
        new_target: histogram(),
        allocations: 0,
    };
    let before = alloc_counter::thread_allocations();
    for (t, &volts) in samples.iter().enumerate() {
        let r0 = Instant::now();
        let r1 = Instant::now();
        let start = Instant::now();
        core.step(&TickInput::volts(t as u64, volts), &mut out);
        arm.tick(out.motion.arm_command.as_ref());
        let end = Instant::now();
        let tick_ns = (end - start).as_nanos() as u64;
        bench
            .reference
            .saturating_record((r1 - r0).as_nanos() as u64);
        bench.all.saturating_record(tick_ns);
        if out.motion.recalculated {
            bench.new_target.saturating_record(tick_ns);
        } else {
            bench.steady.saturating_record(tick_ns);
        }
    }
    bench.allocations = alloc_counter::thread_allocations() - before;
    bench
}

/// `bench tick`'s figures (ns), as `--json` prints them.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TickBenchReport {
    /// Ticks run.
    pub ticks: u64,
    /// Two back-to-back clock reads: the in-run reference.
    pub reference_ns: Percentiles,
    /// Every full tick.
    pub tick_ns: Percentiles,
    /// Ticks on which Ruckig kept its trajectory.
    pub steady_tick_ns: Percentiles,
    /// Ticks on which Ruckig computed a new trajectory.
    pub new_target_tick_ns: Percentiles,
    /// Allocations on the measuring thread during the run.
    pub allocations: u64,
}

impl TickBench {
    /// The figures.
    pub fn report(&self) -> TickBenchReport {
        TickBenchReport {
            ticks: self.ticks,
            reference_ns: Percentiles::of(&self.reference),
            tick_ns: Percentiles::of(&self.all),
            steady_tick_ns: Percentiles::of(&self.steady),
            new_target_tick_ns: Percentiles::of(&self.new_target),
            allocations: self.allocations,
        }
    }
}

impl TickBenchReport {
    /// A table for people.
    pub fn to_text(&self) -> String {
        let mut s = format!(
            "{} ticks of the demo user (core + simulated arm), ns per tick:\n{:<28}",
            self.ticks, ""
        );
        for (_, label, _) in PERCENTILES {
            s += &format!("{label:>9}");
        }
        s += "\n";
        for (name, p) in [
            ("reference (clock reads)", &self.reference_ns),
            ("full tick", &self.tick_ns),
            ("  steady (same target)", &self.steady_tick_ns),
            ("  new target (Ruckig)", &self.new_target_tick_ns),
        ] {
            s += &format!("{:<28}", format!("{name} [{}]", p.count));
            for value in p.values {
                s += &format!("{value:>9}");
            }
            s += "\n";
        }
        s += &format!(
            "full tick p50 / reference p50 = {:.1}; allocations during the run: {}\n",
            self.tick_ns.median() as f64 / (self.reference_ns.median() as f64).max(1.0),
            self.allocations
        );
        s
    }
}
