//! The `sipnpuff` command line: replay recordings, generate synthetic ones,
//! check a configuration.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use anyhow::Context;
use clap::{Parser, Subcommand};

use sipnpuff::alloc_counter::CountingAllocator;
use sipnpuff::config::{Config, Interface};
use sipnpuff::csv_signal::CsvSignal;
use sipnpuff::rt::run::{RunOptions, SensorSource};
use sipnpuff::signal::{self, SignalGenerator, SignalParams};

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

#[derive(Parser)]
#[command(
    version,
    about = "Sip-and-puff sequence-matching control for an assistive robot arm"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// The main job: run the 1 kHz control loop in real time, the built-in
    /// scripted user on the synthetic sensor driving the simulated arm (or
    /// a recording), printing events and a final report.
    Run {
        /// TOML configuration (default: built-in).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Run this long (default: until the scripted user or recording ends).
        #[arg(long)]
        seconds: Option<f64>,
        /// `synthetic` (the built-in scripted user) or `csv:PATH` (a
        /// recording played in real time).
        #[arg(long, default_value = "synthetic")]
        sensor: String,
        /// The arm: `sim` (the simulated JACO; the only one so far).
        #[arg(long, default_value = "sim")]
        arm: String,
        /// Selection interface: `asp` (sequences) or `bsp` (scanning);
        /// default: the config's `interface.kind` (`asp`).
        #[arg(long)]
        interface: Option<String>,
        /// Write each histogram in HdrHistogram's `.hgrm` text format here.
        #[arg(long)]
        histogram_dir: Option<PathBuf>,
        #[command(flatten)]
        rt: RtArgs,
    },
    /// Run the core over a recorded signal as fast as possible; print events
    /// as JSON Lines.
    Replay {
        /// CSV with a header row and a `volts` column, one row per 1 ms sample.
        signal: PathBuf,
        /// TOML configuration (default: built-in).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Write events here instead of standard output.
        #[arg(long)]
        events: Option<PathBuf>,
        /// Write a per-tick motion trace here (CSV: tick, mode, commanded
        /// twist in the base frame, simulated arm pose, fingers).
        #[arg(long)]
        trace: Option<PathBuf>,
        /// Selection interface: `asp` (sequences) or `bsp` (scanning);
        /// default: the config's `interface.kind` (`asp`).
        #[arg(long)]
        interface: Option<String>,
    },
    /// The paper's experiment in simulation: simulated participants do its
    /// three tasks with both interfaces (ASP and BSP) through the
    /// production core; completion times compared with the paper's.
    Study {
        /// Simulated participants.
        #[arg(long, default_value_t = 8)]
        users: usize,
        /// Seed: the same seed gives the same study.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// TOML configuration (default: built-in).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Print one JSON object.
        #[arg(long)]
        json: bool,
        /// Draw the completion times per task and interface to this SVG.
        #[arg(long)]
        plot: Option<PathBuf>,
        /// Instead, how the gap moves with one parameter: `bsp-dwell`,
        /// `asp-timeout`, `error-rate` or `library`.
        #[arg(long)]
        sweep: Option<String>,
    },
    /// Write a synthetic recording of a scripted user (seeded, repeatable).
    Generate {
        /// Output CSV file.
        #[arg(long)]
        out: PathBuf,
        /// TOML configuration (its thresholds shape the breaths and its
        /// library feeds the random user).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Length of a random session, in seconds (exact).
        #[arg(long, default_value_t = 60)]
        seconds: u64,
        /// Instead of a random session, the demo user: every kind of mode,
        /// save and go to a point, a finger end stop, the reach limit.
        #[arg(long, conflicts_with = "sequences")]
        demo: bool,
        /// Instead of a random session, enter these sequences in order, e.g.
        /// `--sequences "1,2,-1 1,2 2,1"` (codes: 1 short sip, 2 long sip,
        /// -1 short puff, -2 long puff).
        #[arg(long, allow_hyphen_values = true)]
        sequences: Option<String>,
        /// Random seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Gaussian noise, standard deviation in volts.
        #[arg(long, default_value_t = 0.0)]
        noise_volts: f64,
        /// 50 Hz hum amplitude in volts.
        #[arg(long, default_value_t = 0.0)]
        hum_volts: f64,
        /// Neutral drift amplitude in volts (one-minute period).
        #[arg(long, default_value_t = 0.0)]
        drift_volts: f64,
        /// A one-sample spike to a rail every this many ms (0 = none).
        #[arg(long, default_value_t = 0)]
        spike_every_ms: u64,
    },
    /// Measure the control path.
    Bench {
        #[command(subcommand)]
        what: BenchCommand,
    },
    /// Check a configuration and print it with its sequence table.
    Config {
        /// TOML configuration (default: built-in).
        #[arg(long)]
        config: Option<PathBuf>,
    },
}

/// Real-time settings.
#[derive(clap::Args, Clone)]
struct RtArgs {
    /// SCHED_FIFO priority of the control thread (1–99; 0: don't ask).
    #[arg(long, default_value_t = 80)]
    priority: i32,
    /// CPU to pin the control thread to (default: the last one).
    #[arg(long)]
    cpu: Option<usize>,
    /// Don't lock memory (mlockall).
    #[arg(long)]
    no_mlock: bool,
    /// Hybrid wait: sleep until this many µs before each deadline, then spin.
    #[arg(long)]
    spin_margin_us: Option<u64>,
}

impl RtArgs {
    fn options(&self) -> sipnpuff::rt::setup::RtOptions {
        let defaults = sipnpuff::rt::setup::RtOptions::default();
        sipnpuff::rt::setup::RtOptions {
            fifo_priority: (self.priority > 0).then_some(self.priority.min(99)),
            cpu: self.cpu.or(defaults.cpu),
            lock_memory: !self.no_mlock,
            ..defaults
        }
    }
}

#[derive(Subcommand)]
enum BenchCommand {
    /// Wake-up latency of the loop: blocks of bare deadline waits (the
    /// reference) interleaved with full ticks on the same thread.
    Latency {
        /// How long, s.
        #[arg(long, default_value_t = 20.0)]
        seconds: f64,
        /// Ticks per block.
        #[arg(long, default_value_t = 250)]
        block: u64,
        /// TOML configuration (default: built-in).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Print one JSON object.
        #[arg(long)]
        json: bool,
        /// Write the histograms in `.hgrm` format here.
        #[arg(long)]
        histogram_dir: Option<PathBuf>,
        #[command(flatten)]
        rt: RtArgs,
    },
    /// Cost of each full tick (core + simulated arm), as percentiles, against
    /// two clock reads measured in the same run.
    Tick {
        /// Seconds of signal to run (1000 ticks each).
        #[arg(long, default_value_t = 60)]
        seconds: u64,
        /// TOML configuration (default: built-in).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Print one JSON object instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Detection accuracy of the whole core against a seeded random user,
    /// at each level of noise and 50 Hz hum: breaths detected as the right
    /// action, mode selections matched, largest timing error.
    Accuracy {
        /// Length of each session, s.
        #[arg(long, default_value_t = 600)]
        seconds: u64,
        /// Seed of the user and the sensor.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Noise levels (σ, volts), comma-separated.
        #[arg(
            long,
            value_delimiter = ',',
            default_value = "0,0.02,0.05,0.1,0.15,0.2"
        )]
        noise_volts: Vec<f64>,
        /// Hum amplitudes (volts), comma-separated.
        #[arg(long, value_delimiter = ',', default_value = "0,0.1,0.2,0.3")]
        hum_volts: Vec<f64>,
        /// Neutral drift amplitude in volts.
        #[arg(long, default_value_t = 0.0)]
        drift_volts: f64,
        /// Period of the drift (a sine), ms; its steepest slope is
        /// 2π·amplitude/period (0.5 V a minute: 0.5 V over 376991 ms).
        #[arg(long, default_value_t = 60_000.0)]
        drift_period_ms: f64,
        /// A one-sample spike to a rail every this many ms (0 = none).
        #[arg(long, default_value_t = 0)]
        spike_every_ms: u64,
        /// A breath counts as correct within this many ms of its length.
        #[arg(long, default_value_t = 5)]
        tolerance_ms: u64,
        /// TOML configuration (default: built-in).
        #[arg(long)]
        config: Option<PathBuf>,
        /// Print one JSON object instead of a table.
        #[arg(long)]
        json: bool,
    },
}

fn load_config(path: Option<&Path>) -> anyhow::Result<Config> {
    match path {
        Some(path) => Config::from_file(path),
        None => Ok(Config::default()),
    }
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// SIGINT and SIGTERM request a safe stop; a second one exits at once.
fn stop_flag() -> anyhow::Result<Arc<AtomicBool>> {
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register_conditional_shutdown(signal, 130, stop.clone())?;
        signal_hook::flag::register(signal, stop.clone())?;
    }
    Ok(stop)
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Run {
            config,
            seconds,
            sensor,
            arm,
            interface,
            histogram_dir,
            rt,
        } => {
            let config = with_interface(load_config(config.as_deref())?, interface.as_deref())?;
            anyhow::ensure!(
                arm == "sim",
                "unknown arm {arm:?}: the only arm so far is `sim`"
            );
            let sensor = match sensor.as_str() {
                "synthetic" => SensorSource::Synthetic,
                other => match other.strip_prefix("csv:") {
                    Some(path) => SensorSource::Csv(PathBuf::from(path)),
                    None => {
                        anyhow::bail!("unknown sensor {other:?}: use `synthetic` or `csv:PATH`")
                    }
                },
            };
            if let Some(s) = seconds {
                anyhow::ensure!(s > 0.0 && s.is_finite(), "--seconds must be positive");
            }
            let options = RunOptions {
                seconds,
                sensor,
                rt: rt.options(),
                spin_margin_ns: rt.spin_margin_us.map(|us| us * 1000),
                stop: stop_flag()?,
                print_events: true,
                interleave: None,
            };
            let report = sipnpuff::rt::run::run(&config, options)?;
            print!("{}", report.to_text());
            if let Some(dir) = histogram_dir {
                for path in report.write_histograms(&dir)? {
                    println!("wrote {}", path.display());
                }
            }
            Ok(())
        }
        Command::Bench {
            what:
                BenchCommand::Latency {
                    seconds,
                    block,
                    config,
                    json,
                    histogram_dir,
                    rt,
                },
        } => {
            let config = load_config(config.as_deref())?;
            anyhow::ensure!(
                seconds > 0.0 && seconds.is_finite(),
                "--seconds must be positive"
            );
            let options = RunOptions {
                seconds: Some(seconds),
                // The built-in scripted user, repeated, in the full blocks.
                sensor: SensorSource::Synthetic,
                rt: rt.options(),
                spin_margin_ns: rt.spin_margin_us.map(|us| us * 1000),
                stop: stop_flag()?,
                print_events: false,
                interleave: Some(block.max(1)),
            };
            let report = sipnpuff::rt::run::run(&config, options)?;
            if json {
                println!("{}", report.latency_json(seconds));
            } else {
                print!("{}", report.latency_text(seconds));
            }
            if let Some(dir) = histogram_dir {
                for path in report.write_histograms(&dir)? {
                    eprintln!("wrote {}", path.display());
                }
            }
            Ok(())
        }
        Command::Replay {
            signal,
            config,
            events,
            trace,
            interface,
        } => replay(
            &signal,
            with_interface(load_config(config.as_deref())?, interface.as_deref())?,
            events.as_deref(),
            trace.as_deref(),
        ),
        Command::Study {
            users,
            seed,
            config,
            json,
            plot,
            sweep,
        } => study(
            load_config(config.as_deref())?,
            users,
            seed,
            json,
            plot.as_deref(),
            sweep.as_deref(),
        ),
        Command::Generate {
            out,
            config,
            seconds,
            demo,
            sequences,
            seed,
            noise_volts,
            hum_volts,
            drift_volts,
            spike_every_ms,
        } => {
            let config = load_config(config.as_deref())?;
            let mut params = SignalParams::clean(config.detector(), seed);
            params.noise_volts = noise_volts;
            params.hum_volts = hum_volts;
            params.drift_volts = drift_volts;
            params.spike_every_ms = spike_every_ms;
            let (script, length) = match sequences {
                None if demo => (signal::demo_script(&config).0, usize::MAX),
                Some(text) => {
                    let sequences = signal::parse_sequences(&text).map_err(anyhow::Error::msg)?;
                    (signal::sequences_script(&config, &sequences), usize::MAX)
                }
                None => (
                    signal::random_session(&config, seconds, seed).0,
                    usize::try_from(seconds * 1000)?,
                ),
            };
            let file =
                File::create(&out).with_context(|| format!("cannot create {}", out.display()))?;
            let mut writer = BufWriter::new(file);
            let n = signal::write_csv(
                &mut writer,
                SignalGenerator::new(params, &script).take(length),
            )?;
            writer.flush()?;
            eprintln!(
                "wrote {n} samples ({:.1} s) to {}",
                n as f64 / 1000.0,
                out.display()
            );
            Ok(())
        }
        Command::Bench {
            what:
                BenchCommand::Tick {
                    seconds,
                    config,
                    json,
                },
        } => {
            let config = load_config(config.as_deref())?;
            let bench = sipnpuff::bench::bench_tick(&config, seconds);
            if json {
                println!("{}", bench.to_json());
            } else {
                print!("{}", bench.to_text());
            }
            Ok(())
        }
        Command::Bench {
            what:
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
                },
        } => {
            let config = load_config(config.as_deref())?;
            let levels_ok = |v: &[f64]| v.iter().all(|x| x.is_finite() && *x >= 0.0);
            anyhow::ensure!(
                levels_ok(&noise_volts) && levels_ok(&hum_volts) && levels_ok(&[drift_volts]),
                "noise, hum and drift levels must be finite and non-negative"
            );
            anyhow::ensure!(
                drift_period_ms.is_finite() && drift_period_ms > 0.0,
                "--drift-period-ms must be positive"
            );
            let options = sipnpuff::accuracy::GridOptions {
                seconds,
                seed,
                drift_volts,
                drift_period_ms,
                spike_every_ms,
                tolerance_ms,
            };
            let cells = sipnpuff::accuracy::accuracy_grid(
                &config,
                &noise_volts,
                &hum_volts,
                options,
                |done, total| eprint!("\r{done}/{total} sessions"),
            );
            eprintln!();
            if json {
                let rows: Vec<serde_json::Value> = cells
                    .iter()
                    .map(|c| {
                        let t = &c.tally;
                        serde_json::json!({
                            "noise_volts": c.noise_volts,
                            "hum_volts": c.hum_volts,
                            "scripted": t.scripted,
                            "correct": t.correct,
                            "missed": t.missed,
                            "split_or_merged": t.split_or_merged,
                            "wrong_breath": t.wrong_breath,
                            "wrong_class": t.wrong_class,
                            "mistimed": t.mistimed,
                            "invented": t.invented,
                            "max_timing_error_ms": t.max_timing_error_ms,
                            "selections": t.selections,
                            "selections_matched": t.selections_matched,
                            "selections_extra": t.selections_extra,
                            "faults": t.faults,
                        })
                    })
                    .collect();
                println!("{}", serde_json::Value::Array(rows));
            } else {
                println!(
                    "breaths detected as the right action (mode selections matched) ±largest timing error [+bursts invented]; {seconds} s per session, seed {seed}, drift {drift_volts} V over a {drift_period_ms} ms period, spikes every {spike_every_ms} ms, tolerance {tolerance_ms} ms"
                );
                print!("{}", sipnpuff::accuracy::grid_table(&cells));
            }
            Ok(())
        }
        Command::Config { config } => {
            let config = load_config(config.as_deref())?;
            print_config(&config);
            Ok(())
        }
    }
}

fn create(path: &Path) -> anyhow::Result<BufWriter<File>> {
    let file = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    Ok(BufWriter::new(file))
}

/// The config with the `--interface` choice, if given.
fn with_interface(config: Config, interface: Option<&str>) -> anyhow::Result<Config> {
    match interface {
        None => Ok(config),
        Some(name) => {
            let interface = Interface::from_name(name).ok_or_else(|| {
                anyhow::anyhow!(
                    "unknown interface {name:?}: use `asp` (sequences) or `bsp` (scanning)"
                )
            })?;
            Ok(config.with_interface(interface))
        }
    }
}

fn study(
    config: Config,
    users: usize,
    seed: u64,
    json: bool,
    plot: Option<&Path>,
    sweep: Option<&str>,
) -> anyhow::Result<()> {
    use sipnpuff::study;
    anyhow::ensure!(
        users >= 2,
        "--users must be at least 2 (the test pairs them)"
    );
    let options = study::StudyOptions {
        users,
        seed,
        ..study::StudyOptions::default()
    };
    if let Some(name) = sweep {
        let param = study::SweepParam::from_name(name).ok_or_else(|| {
            anyhow::anyhow!(
                "unknown sweep {name:?}: use bsp-dwell, asp-timeout, error-rate or library"
            )
        })?;
        let rows = study::sweep(&config, &options, param, |label, done, total| {
            eprint!("\r{label}: {done}/{total} runs   ");
        })?;
        eprintln!();
        print!("{}", study::sweep_text(name, &rows));
        return Ok(());
    }
    let results = study::run_study(&config, &options, |done, total| {
        eprint!("\r{done}/{total} runs");
    });
    eprintln!();
    if json {
        println!("{}", study::study_json(&results));
    } else {
        print!("{}", study::study_text(&results, &options));
    }
    if let Some(path) = plot {
        std::fs::write(path, study::plot::completion_svg(&results))
            .with_context(|| format!("cannot write {}", path.display()))?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

fn replay(
    signal: &Path,
    config: Config,
    events: Option<&Path>,
    trace: Option<&Path>,
) -> anyhow::Result<()> {
    let mut input = CsvSignal::open(signal)?;
    let mut out: Box<dyn Write> = match events {
        Some(path) => Box::new(create(path)?),
        None => Box::new(BufWriter::new(std::io::stdout().lock())),
    };
    let mut trace_file = trace.map(create).transpose()?;
    let started = Instant::now();
    let result = sipnpuff::replay::replay(
        &config,
        &mut input,
        &mut out,
        trace_file.as_mut().map(|t| t as &mut dyn Write),
    );
    let seconds = started.elapsed().as_secs_f64();
    let summary = result.with_context(|| signal.display().to_string())?;
    let signal_seconds = summary.samples as f64 / 1000.0;
    eprintln!(
        "replayed {} samples ({signal_seconds:.1} s of signal) in {seconds:.3} s: {:.0}x real time, {} events",
        summary.samples,
        signal_seconds / seconds.max(1e-9),
        summary.events
    );
    let [x, y, z] = summary.final_position;
    let [rx, ry, rz] = summary.final_rotation_vector;
    eprintln!(
        "simulated arm: {} commands at 100 Hz, final position ({x:.4}, {y:.4}, {z:.4}) m, rotation vector ({rx:.4}, {ry:.4}, {rz:.4}) rad, fingers {:.0}, ticks outside the workspace: {}",
        summary.arm_commands, summary.final_fingers, summary.ticks_outside_workspace
    );
    Ok(())
}

fn print_config(config: &Config) {
    let d = config.detector();
    println!("[detector]");
    println!("neutral_volts = {:?}", d.neutral_volts);
    println!("puff_threshold_volts = {:?}", d.puff_threshold_volts);
    println!("sip_threshold_volts = {:?}", d.sip_threshold_volts);
    println!("hysteresis_volts = {:?}", d.hysteresis_volts);
    println!("min_burst_ms = {}", d.min_burst_ms);
    println!("long_burst_ms = {}", d.long_burst_ms);
    println!("glitch_ms = {}", d.glitch_ms);
    println!("neutral_tracking_ms = {}", d.neutral_tracking_ms);
    println!("fault_margin_volts = {:?}", d.fault_margin_volts);
    println!("fault_recovery_ms = {}", d.fault_recovery_ms);
    println!(
        "\n[matcher]\nsequence_timeout_ms = {}",
        config.matcher().sequence_timeout_ms
    );
    println!(
        "\n[command]\ninactivity_timeout_ms = {}",
        config.command().inactivity_timeout_ms
    );
    println!("\n[interface]\nkind = {:?}", config.interface().name());
    let scan = config.scanning();
    let order: Vec<&str> = scan.modes().iter().map(|m| m.name()).collect();
    println!(
        "\n[scanning]\ndwell_ms = {}\nfirst_dwell_ms = {}\norder = {order:?}",
        scan.dwell_ms, scan.first_dwell_ms
    );
    for entry in config.sequences() {
        let words: Vec<String> = entry
            .actions
            .as_slice()
            .iter()
            .map(|a| a.to_string())
            .collect();
        println!(
            "\n[[sequence]]  # {}: {}\nactions = {:?}\nmode = {:?}",
            words.join(", "),
            entry.mode.description(),
            entry.actions.codes().collect::<Vec<_>>(),
            entry.mode.name()
        );
    }
}
