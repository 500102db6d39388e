//! `bench cpu`: what the running controller costs in CPU at 1 kHz, beside
//! the floor of any 1 kHz real-time loop, `cyclictest` (one thread that
//! sleeps to each millisecond's deadline and wakes). Each round runs the
//! main job (the given sensor, the simulated arm, no display) and
//! cyclictest at the control thread's priority on its CPU for the same
//! seconds, side by side; the CPU each used (user + system) and their
//! ratio. The ratios' median is the figure.

use std::process::{Command, Stdio};

use anyhow::Context;
use serde::Serialize;

use crate::arm::ArmSpec;
use crate::config::Config;
use crate::control::event::TimedEvent;
use crate::rt::threads::LoopSettings;
use crate::sensor::SensorSpec;
use crate::session::Console;
use crate::session::run::{self as session, RunPlan};
use crate::session::showing::DisplayChoice;

/// One round: both for the same seconds, side by side.
#[derive(Debug, Clone, Serialize)]
pub struct CpuRound {
    /// CPU the whole `run` took (every thread, start to end), s.
    pub sipnpuff_s: f64,
    /// CPU cyclictest took, s.
    pub cyclictest_s: f64,
    /// `sipnpuff_s / cyclictest_s`.
    pub ratio: f64,
    /// The run's missed deadlines (its loop ran beside cyclictest).
    pub missed_deadlines: u64,
}

/// Every round and the median ratio.
#[derive(Debug, Clone, Serialize)]
pub struct CpuBenchReport {
    /// Seconds a round.
    pub seconds: f64,
    /// The sensor the run read.
    pub sensor: String,
    /// The reference's command line.
    pub cyclictest: String,
    /// Each round, in order.
    pub rounds: Vec<CpuRound>,
    /// The median of the rounds' ratios.
    pub median_ratio: f64,
}

impl CpuBenchReport {
    /// The report as a table.
    pub fn to_text(&self) -> String {
        let mut s = format!(
            "process CPU at 1 kHz, {} s a round, sensor {}, beside `{}`:\n",
            self.seconds, self.sensor, self.cyclictest
        );
        for (i, r) in self.rounds.iter().enumerate() {
            s += &format!(
                "  round {}: sipnpuff {:.3} s, cyclictest {:.3} s, ratio {:.2} ({} missed deadlines)\n",
                i + 1,
                r.sipnpuff_s,
                r.cyclictest_s,
                r.ratio,
                r.missed_deadlines
            );
        }
        s += &format!(
            "median ratio {:.2} (sipnpuff's CPU over cyclictest's)\n",
            self.median_ratio
        );
        s
    }
}

/// The cyclictest beside a run of `seconds` with `settings`' control
/// thread: its priority (none: SCHED_OTHER, as the run) and CPU.
pub fn cyclictest_args(settings: &LoopSettings, seconds: f64) -> Vec<String> {
    let mut args = vec!["--mlockall".to_string()];
    if let Some(priority) = settings.rt.fifo_priority {
        args.push(format!("--priority={priority}"));
    }
    if let Some(cpu) = settings.rt.cpu {
        args.push(format!("--affinity={cpu}"));
    }
    args.push("--interval=1000".into());
    args.push(format!("--duration={}", seconds.ceil() as u64));
    args.push("--quiet".into());
    args
}

/// Runs `rounds` rounds of `settings.seconds` (which must be set).
pub fn bench_cpu(
    config: &Config,
    sensor: &SensorSpec,
    settings: &LoopSettings,
    rounds: u32,
    console: &dyn Console,
) -> anyhow::Result<CpuBenchReport> {
    let seconds = settings
        .seconds
        .context("bench cpu needs a length of run")?;
    let args = cyclictest_args(settings, seconds);
    let plan = RunPlan {
        sensor,
        imu: None,
        arm: &ArmSpec::Sim,
        outputs: &[],
        settings,
        record: None,
        display: DisplayChoice {
            page: None,
            tui: false,
        },
        max_hold_set_in: None,
    };
    let mut all = Vec::new();
    for _ in 0..rounds {
        let children_before = cpu_seconds(libc::RUSAGE_CHILDREN);
        let cyclictest = Command::new("cyclictest")
            .args(&args)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| {
                anyhow::anyhow!(
                    "cannot start cyclictest ({e}): it is the reference; install rt-tests (apt-get install rt-tests)"
                )
            })?;
        let before = cpu_seconds(libc::RUSAGE_SELF);
        let ran = session::run(config, &plan, &mut |_: &TimedEvent| {}, console);
        let sipnpuff_s = cpu_seconds(libc::RUSAGE_SELF) - before;
        let ended = cyclictest.wait_with_output().context("cyclictest")?;
        let report = ran?;
        anyhow::ensure!(
            ended.status.success(),
            "cyclictest {}: {}",
            ended.status,
            String::from_utf8_lossy(&ended.stderr).trim()
        );
        let cyclictest_s = cpu_seconds(libc::RUSAGE_CHILDREN) - children_before;
        all.push(CpuRound {
            sipnpuff_s,
            cyclictest_s,
            ratio: sipnpuff_s / cyclictest_s.max(1e-6),
            missed_deadlines: report.stats.missed_deadlines,
        });
    }
    let mut ratios: Vec<f64> = all.iter().map(|r| r.ratio).collect();
    ratios.sort_by(f64::total_cmp);
    let median_ratio = match ratios.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => ratios[n / 2],
        n => (ratios[n / 2 - 1] + ratios[n / 2]) / 2.0,
    };
    Ok(CpuBenchReport {
        seconds,
        sensor: sensor.to_string(),
        cyclictest: format!("cyclictest {}", args.join(" ")),
        rounds: all,
        median_ratio,
    })
}

/// User and system CPU of `who` (`RUSAGE_SELF`: this process's threads;
/// `RUSAGE_CHILDREN`: its children waited for), s.
fn cpu_seconds(who: libc::c_int) -> f64 {
    // SAFETY: `usage` is a valid, writable rusage for getrusage to fill.
    let usage = unsafe {
        let mut usage: libc::rusage = std::mem::zeroed();
        libc::getrusage(who, &mut usage);
        usage
    };
    let t = |tv: libc::timeval| tv.tv_sec as f64 + tv.tv_usec as f64 / 1e6;
    t(usage.ru_utime) + t(usage.ru_stime)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rt::setup::RtOptions;
    use crate::rt::stop::StopRequest;

    #[test]
    fn cyclictest_runs_as_the_control_thread_does_for_as_long() {
        let mut settings = LoopSettings {
            seconds: Some(2.5),
            rt: RtOptions {
                fifo_priority: Some(80),
                cpu: Some(1),
                ..RtOptions::NONE
            },
            spin_margin_ns: None,
            stop: StopRequest::new(),
        };
        assert_eq!(
            cyclictest_args(&settings, 2.5).join(" "),
            "--mlockall --priority=80 --affinity=1 --interval=1000 --duration=3 --quiet"
        );
        settings.rt = RtOptions::NONE;
        assert_eq!(
            cyclictest_args(&settings, 10.0).join(" "),
            "--mlockall --interval=1000 --duration=10 --quiet"
        );
    }
}
