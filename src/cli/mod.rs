//! The `sipnpuff` command line: one file per command, each owning its
//! options and its output: it parses them, calls one function of the
//! module that does the work, and prints the result. Output goes through
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
pub mod design;
pub mod display;
pub mod doctor;
pub mod fit;
pub mod generate;
pub mod gestures;
pub mod output;
pub mod replay;
pub mod run;
pub mod run_report;
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
    /// The main job: run the 1 kHz control loop in real time, a sensor
    /// driving an arm (by default the built-in scripted user and the
    /// simulated arm), printing events and a final report.
    Run(run::RunArgs),
    /// Run the core over a recorded signal as fast as possible; print events
    /// as JSON Lines.
    Replay(replay::ReplayArgs),
    /// The paper's experiment in simulation: simulated participants do its
    /// three tasks with both interfaces (ASP and BSP) through the
    /// production core; completion times compared with the paper's.
    Study(study::StudyArgs),
    /// Designs the sequence library for a person, their breaths and their
    /// gestures: `--check` analyses one (time and errors per entry),
    /// without it the search for the library that costs them least, tried
    /// in the study.
    Design(design::DesignArgs),
    /// Write a synthetic recording of a scripted user (seeded, repeatable).
    Generate(generate::GenerateArgs),
    /// Fit the interface to a user: measure their breaths in a
    /// calibration session and propose their settings, each with its
    /// reason; write them as a profile (`--config` reads it).
    #[command(
        mut_arg("tui", |a| a.hide(true)),
        mut_arg("display", |a| a.help(
            "Serve the calibration page (the prompt, the count, the pressure, a tone per prompt) at this address: `HOST:PORT` or `PORT` (on 127.0.0.1)"
        ))
    )]
    Fit(fit::FitArgs),
    /// A person's own head gestures from an IMU: make a gesture set from
    /// their recording (`record`), check how well it works (`check`).
    Gestures {
        #[command(subcommand)]
        what: gestures::GesturesCommand,
    },
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
    /// `--config` reads back (with the sequence table as comments); with
    /// `--diff FILE`, only what FILE changes from the defaults, as a table.
    Config(config::ConfigArgs),
    /// Before the first start: what `run` with these options would get
    /// here and be denied (SCHED_FIFO, locked memory, the pinned CPU,
    /// each device, /dev/uinput, the broker, the page's address), each
    /// denial with its fix. Run it as the service's user; exit status 1
    /// when something needed is missing.
    Doctor(doctor::DoctorArgs),
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
        Command::Design(args) => design::design(args).map(|()| output::COMPLETED),
        Command::Generate(args) => generate::generate(args).map(|()| output::COMPLETED),
        Command::Fit(args) => fit::fit(args),
        Command::Gestures { what } => gestures::gestures(what),
        Command::Bench { what } => bench::bench(what),
        Command::Config(args) => config::config(args).map(|()| output::COMPLETED),
        Command::Sensors(args) => sensors::sensors(args).map(|()| output::COMPLETED),
        Command::Doctor(args) => doctor::doctor(args),
    };
    ExitCode::from(result.unwrap_or_else(|e| {
        let (status, say) = output::status_of(&e);
        if say {
            note!("error: {e:#}");
        }
        status
    }))
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    use super::Cli;

    /// A help text that starts over after its first sentence ("The arm.
    /// The arm: …"): two doc lines where one was meant.
    fn starts_over(help: &str) -> bool {
        help.split_once(". ")
            .is_some_and(|(first, rest)| rest.starts_with(first))
    }

    #[test]
    fn every_help_text_says_its_start_once() {
        assert!(starts_over("The arm. The arm: `sim`"));
        assert!(!starts_over("The arm: `sim`. Settings: `[arm]`"));
        let mut commands = vec![Cli::command()];
        let mut checked = 0;
        while let Some(command) = commands.pop() {
            let arguments = command
                .get_arguments()
                .flat_map(|a| a.get_help().into_iter().chain(a.get_long_help()));
            let texts = command
                .get_about()
                .into_iter()
                .chain(command.get_long_about())
                .chain(arguments);
            for text in texts {
                let text = text.to_string();
                assert!(!starts_over(&text), "{}: {text}", command.get_name());
                checked += 1;
            }
            commands.extend(command.get_subcommands().cloned());
        }
        assert!(checked > 50, "{checked}");
    }
}
