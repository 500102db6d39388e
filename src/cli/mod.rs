//! The `sipnpuff` command line: one file per command, each owning its
//! options and its output. Concrete sensors and arms are chosen here (and
//! only here) from `--sensor` and `--arm`. Output goes through
//! [`output`]: nothing panics on a closed stdout or stderr; the exit
//! statuses are listed there.

/// `eprintln!` that never panics (stderr may be closed too).
macro_rules! note {
    () => {
        $crate::cli::output::note(format_args!(""))
    };
    ($($arg:tt)*) => {
        $crate::cli::output::note(format_args!($($arg)*))
    };
}

/// `eprint!` that never panics, for progress counters.
macro_rules! progress {
    ($($arg:tt)*) => {
        $crate::cli::output::progress(format_args!($($arg)*))
    };
}

pub mod args;
pub mod bench;
pub mod config;
pub mod display;
pub mod generate;
pub mod output;
pub mod replay;
pub mod run;
pub mod sensors;
pub mod study;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// The command line.
#[derive(Parser, Debug)]
#[command(
    name = "sipnpuff",
    version,
    about = "Sip-and-puff sequence-matching control for an assistive robot arm"
)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// The main job: run the 1 kHz control loop in real time, the built-in
    /// scripted user on the synthetic sensor driving the simulated arm (or
    /// a recording), printing events and a final report.
    Run(run::RunArgs),
    /// Run the core over a recorded signal as fast as possible; print events
    /// as JSON Lines.
    Replay(replay::ReplayArgs),
    /// The paper's experiment in simulation: simulated participants do its
    /// three tasks with both interfaces (ASP and BSP) through the
    /// production core; completion times compared with the paper's.
    Study(study::StudyArgs),
    /// Write a synthetic recording of a scripted user (seeded, repeatable).
    Generate(generate::GenerateArgs),
    /// Measure the control path.
    Bench {
        #[command(subcommand)]
        what: bench::BenchCommand,
    },
    /// List the sip-and-puff sensors this machine has (input devices with
    /// axes or keys, IIO voltage channels, serial ports) with the
    /// `--sensor` line for each.
    Sensors(sensors::SensorsArgs),
    /// Check a configuration and print it, complete, as TOML that
    /// `--config` reads back (with the sequence table as comments).
    Config(config::ConfigArgs),
}

/// Parses the arguments and runs the command; errors are printed. The
/// exit status is one of [`output`]'s.
pub fn main() -> ExitCode {
    // A write past the file-size limit fails with EFBIG, handled as a
    // failed output, instead of killing the process (as Rust's runtime
    // already does for SIGPIPE and EPIPE).
    // SAFETY: setting a signal's disposition to SIG_IGN has no memory
    // effects; no handler of ours is replaced (none is installed yet).
    unsafe { libc::signal(libc::SIGXFSZ, libc::SIG_IGN) };
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run(args) => run::run(args),
        Command::Replay(args) => replay::replay(args),
        Command::Study(args) => study::study(args).map(|()| output::COMPLETED),
        Command::Generate(args) => generate::generate(args).map(|()| output::COMPLETED),
        Command::Bench { what } => bench::bench(what),
        Command::Config(args) => config::config(args).map(|()| output::COMPLETED),
        Command::Sensors(args) => sensors::sensors(args).map(|()| output::COMPLETED),
    };
    ExitCode::from(result.unwrap_or_else(|e| {
        let (status, say) = output::status_of(&e);
        if say {
            note!("error: {e:#}");
        }
        status
    }))
}
