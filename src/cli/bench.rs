//! `sipnpuff bench latency | cpu | tick | replay | accuracy`: the project's own
//! measurements, each against a reference measured in the same run.

use std::path::PathBuf;

use anyhow::Context;

use crate::cli::args::{ConfigArg, RtArgs, parse_seconds, parse_volts, writable_dir};
use crate::cli::output::{self, Terminal};
use crate::rt::control_loop::StopReason;
use crate::sensor::SensorSpec;
use crate::session::cpu_bench::bench_cpu;
use crate::tools::accuracy::{GridOptions, GridReport, accuracy_grid, grid_table};
use crate::tools::bench_replay::bench_replay_dir;
use crate::tools::bench_tick::bench_tick;
use crate::tools::latency::{LatencyReport, bench_latency};

/// What to measure.
#[derive(clap::Subcommand, Debug)]
pub enum BenchCommand {
    /// Wake-up latency of the loop: blocks of bare deadline waits (the
    /// reference) interleaved with full ticks on the same thread.
    Latency {
        /// How long, s.
        #[arg(long, default_value_t = 20.0, value_parser = parse_seconds)]
        seconds: f64,
        /// Ticks per block.
        #[arg(long, default_value_t = 250, value_parser = clap::value_parser!(u64).range(1..))]
        block: u64,
        /// The configuration.
        #[command(flatten)]
        config: ConfigArg,
        /// Print one JSON object instead of a table.
        #[arg(long)]
        json: bool,
        /// Write each histogram in HdrHistogram's `.hgrm` text format here.
        #[arg(long, value_name = "DIR")]
        histogram_dir: Option<PathBuf>,
        /// Real-time settings.
        #[command(flatten)]
        rt: RtArgs,
    },
    /// The process's CPU at 1 kHz against cyclictest's: the main job
    /// (this sensor, the simulated arm, no display) and `cyclictest` at the
    /// control thread's priority on its CPU, side by side for the same
    /// seconds, in rounds; each round's CPU and ratio, and their median.
    Cpu {
        /// Seconds a round.
        #[arg(long, default_value_t = 10.0, value_parser = parse_seconds)]
        seconds: f64,
        /// Rounds.
        #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
        rounds: u32,
        /// Where samples come from, as `run --sensor` (e.g. `csv:PATH`: a
        /// recording read by its own thread at 1 kHz).
        #[arg(long, default_value = "synthetic", value_parser = SensorSpec::parse)]
        sensor: SensorSpec,
        /// The configuration.
        #[command(flatten)]
        config: ConfigArg,
        /// Print one JSON object instead of a table.
        #[arg(long)]
        json: bool,
        /// Real-time settings.
        #[command(flatten)]
        rt: RtArgs,
    },
    /// Cost of each full tick (core + simulated arm), as percentiles, against
    /// two clock reads measured in the same run.
    Tick {
        /// Seconds of signal to run (1000 ticks each; at most a day).
        #[arg(long, default_value_t = 60, value_parser = clap::value_parser!(u64).range(1..=86_400))]
        seconds: u64,
        /// The configuration.
        #[command(flatten)]
        config: ConfigArg,
        /// Print one JSON object instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// How fast a recording made by `run --record` replays, against the
    /// core alone stepped through the same inputs (the floor of any
    /// replay of it), in alternating rounds in one process.
    Replay {
        /// The recording's directory.
        recording: PathBuf,
        /// Rounds of each (after one of each not counted).
        #[arg(long, default_value_t = 11, value_parser = clap::value_parser!(u32).range(1..=1000))]
        rounds: u32,
        /// Print one JSON object instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Detection accuracy of the whole core against a seeded random user,
    /// at each level of noise and 50 Hz hum: breaths detected as the right
    /// action, mode selections matched, largest timing error.
    Accuracy {
        /// Length of each session, s (at most a day).
        #[arg(long, default_value_t = 600, value_parser = clap::value_parser!(u64).range(1..=86_400))]
        seconds: u64,
        /// Seed of the user and the sensor.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Noise levels (σ, volts), comma-separated.
        #[arg(
            long,
            value_delimiter = ',',
            default_value = "0,0.02,0.05,0.1,0.15,0.2",
            value_parser = parse_volts
        )]
        noise_volts: Vec<f64>,
        /// Hum amplitudes (volts), comma-separated.
        #[arg(long, value_delimiter = ',', default_value = "0,0.1,0.2,0.3", value_parser = parse_volts)]
        hum_volts: Vec<f64>,
        /// Neutral drift amplitude in volts.
        #[arg(long, default_value_t = 0.0, value_parser = parse_volts)]
        drift_volts: f64,
        /// Period of the drift (a sine), ms; its steepest slope is
        /// 2π·amplitude/period (0.5 V a minute: 0.5 V over 376991 ms).
        #[arg(long, default_value_t = 60_000.0, value_parser = parse_period_ms)]
        drift_period_ms: f64,
        /// A one-sample spike to a rail every this many ms (0 = none).
        #[arg(long, default_value_t = 0)]
        spike_every_ms: u64,
        /// A breath counts as correct within this many ms of its length.
        #[arg(long, default_value_t = 5)]
        tolerance_ms: u64,
        /// The configuration.
        #[command(flatten)]
        config: ConfigArg,
        /// Print one JSON object instead of a table.
        #[arg(long)]
        json: bool,
    },
}

/// A positive, finite period in ms.
fn parse_period_ms(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(ms) if ms.is_finite() && ms > 0.0 => Ok(ms),
        _ => Err(format!("{text:?}: must be a positive number of ms")),
    }
}

/// Runs one bench and prints its figures; returns the exit status
/// (`bench latency` stopped by signal N: 128 + N).
pub fn bench(what: BenchCommand) -> anyhow::Result<u8> {
    match what {
        BenchCommand::Latency {
            seconds,
            block,
            config,
            json,
            histogram_dir,
            rt,
        } => {
            let config = config.load()?;
            if let Some(dir) = &histogram_dir {
                writable_dir(dir)?;
            }
            let settings = rt.loop_settings(Some(seconds), config.rt())?;
            let run = bench_latency(&config, block, settings)?;
            let report = LatencyReport::of(&run, seconds);
            if json {
                output::stdout_line(&serde_json::to_string(&report)?)
            } else {
                output::stdout(&report.to_text())
            }
            .context("stdout")?;
            if let Some(dir) = histogram_dir {
                for path in run.write_histograms(&dir)? {
                    note!("wrote {}", path.display());
                }
            }
            anyhow::ensure!(
                report.errors.is_empty(),
                "the bench failed: {}",
                report.errors.join("; ")
            );
            Ok(match run.stop_reason {
                StopReason::Signal(n) => output::interrupted(n),
                _ => output::COMPLETED,
            })
        }
        BenchCommand::Cpu {
            seconds,
            rounds,
            sensor,
            config,
            json,
            rt,
        } => {
            let config = config.load()?;
            let settings = rt.loop_settings(Some(seconds), config.rt())?;
            let report = bench_cpu(&config, &sensor, &settings, rounds, &Terminal)?;
            if json {
                output::stdout_line(&serde_json::to_string(&report)?)
            } else {
                output::stdout(&report.to_text())
            }
            .context("stdout")?;
            Ok(output::COMPLETED)
        }
        BenchCommand::Tick {
            seconds,
            config,
            json,
        } => {
            let report = bench_tick(&config.load()?, seconds).report();
            if json {
                output::stdout_line(&serde_json::to_string(&report)?)
            } else {
                output::stdout(&report.to_text())
            }
            .context("stdout")?;
            Ok(output::COMPLETED)
        }
        BenchCommand::Replay {
            recording,
            rounds,
            json,
        } => {
            let report = bench_replay_dir(&recording, rounds)?.report();
            if json {
                output::stdout_line(&serde_json::to_string(&report)?)
            } else {
                output::stdout(&format!("{}: {}", recording.display(), report.to_text()))
            }
            .context("stdout")?;
            Ok(output::COMPLETED)
        }
        BenchCommand::Accuracy {
            seconds,
            seed,
            noise_volts,
            hum_volts,
            drift_volts,
            drift_period_ms,
            spike_every_ms,
            tolerance_ms,
            config,
            json,
        } => {
            let config = config.load()?;
            let options = GridOptions {
                seconds,
                seed,
                drift_volts,
                drift_period_ms,
                spike_every_ms,
                tolerance_ms,
            };
            let cells = accuracy_grid(&config, &noise_volts, &hum_volts, options, |done, total| {
                progress!("\r{done}/{total} sessions")
            });
            note!();
            if json {
                let report = GridReport { options, cells };
                output::stdout_line(&serde_json::to_string(&report)?)
            } else {
                output::stdout(&format!(
                    "breaths detected as the right action (mode selections matched) ±largest timing error [+bursts invented]; {seconds} s per session, seed {seed}, drift {drift_volts} V over a {drift_period_ms} ms period, spikes every {spike_every_ms} ms, tolerance {tolerance_ms} ms\n{}",
                    grid_table(&cells)
                ))
            }
            .context("stdout")?;
            Ok(output::COMPLETED)
        }
    }
}
