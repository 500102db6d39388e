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
use serde_json::{Value, json};

use crate::rt::telemetry::{PERCENTILES, at, histogram, percentiles_json};

use crate::arm::{ArmBackend, SimulatedJaco};
use crate::config::Config;
use crate::pipeline::Core;
use crate::signal::{SignalGenerator, SignalParams, Step, demo_script};

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
    let mut params = SignalParams::clean(config.detector(), 1);
    params.noise_volts = 0.03;
    params.hum_volts = 0.05;
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

    let mut core: Core = Core::new(config);
    let mut arm = SimulatedJaco::new(config);
    let mut bench = TickBench {
        ticks: samples.len() as u64,
        reference: histogram(),
        all: histogram(),
        steady: histogram(),
        new_target: histogram(),
        allocations: 0,
    };
    let before = crate::alloc_counter::thread_allocations();
    for (t, &volts) in samples.iter().enumerate() {
        let r0 = Instant::now();
        let r1 = Instant::now();
        let start = Instant::now();
        let out = core.step(t as u64, volts);
        if let Some(command) = &out.motion.arm_command {
            let _ = arm.send(command);
        }
        arm.advance_ms();
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
    bench.allocations = crate::alloc_counter::thread_allocations() - before;
    bench
}

impl TickBench {
    /// The figures as one JSON object (nanoseconds).
    pub fn to_json(&self) -> Value {
        json!({
            "ticks": self.ticks,
            "reference_ns": percentiles_json(&self.reference),
            "tick_ns": percentiles_json(&self.all),
            "steady_tick_ns": percentiles_json(&self.steady),
            "new_target_tick_ns": percentiles_json(&self.new_target),
            "allocations": self.allocations,
        })
    }

    /// A table for people.
    pub fn to_text(&self) -> String {
        let mut s = format!(
            "{} ticks of the demo user (core + simulated arm), ns per tick:\n{:<28}",
            self.ticks, ""
        );
        for (label, _) in PERCENTILES {
            s += &format!("{label:>9}");
        }
        s += "\n";
        for (name, h) in [
            ("reference (clock reads)", &self.reference),
            ("full tick", &self.all),
            ("  steady (same target)", &self.steady),
            ("  new target (Ruckig)", &self.new_target),
        ] {
            s += &format!("{:<28}", format!("{name} [{}]", h.len()));
            for (_, q) in PERCENTILES {
                s += &format!("{:>9}", at(h, q));
            }
            s += "\n";
        }
        let p50 = |h: &Histogram<u64>| at(h, 0.5) as f64;
        s += &format!(
            "full tick p50 / reference p50 = {:.1}; allocations during the run: {}\n",
            p50(&self.all) / p50(&self.reference).max(1.0),
            self.allocations
        );
        s
    }
}
