//! Output that never panics, and the exit statuses.
//!
//! `print!` and `eprint!` panic when their stream fails (`sipnpuff config
//! | head`: stdout's reader is gone; a full disk). Here every write to
//! stdout returns its error to the command, which stops (`run`: safely,
//! the arm braked first) and exits with the status below; writes to
//! stderr ignore their errors (there is nowhere left to say anything).
//! The crate denies `clippy::print_stdout` and `clippy::print_stderr`, so
//! no `print!` comes back.
//!
//! | status | meaning |
//! |---|---|
//! | 0 | completed |
//! | 1 | failed: a setup error, a fault that stopped the run, an output that failed |
//! | 2 | invalid command line or configuration: nothing was started |
//! | 128 + N | `run`: interrupted by signal N, after the safe stop |
//! | 141 | stdout's reader went away (EPIPE; as a SIGPIPE death would say) |

use std::fmt;
use std::io::{self, Write};

pub use crate::config::invalid::{Invalid, invalid};
use crate::control::event::TimedEvent;
use crate::rt::telemetry_thread::EventSink;
use crate::session::Console;

/// Completed.
pub const COMPLETED: u8 = 0;
/// Failed.
pub const FAILED: u8 = 1;
/// Invalid command line or configuration.
pub const INVALID: u8 = 2;
/// Stdout's reader went away: 128 + SIGPIPE.
pub const BROKEN_PIPE: u8 = 128 + libc::SIGPIPE as u8;

/// The status of a run interrupted by `signal`: 128 + its number.
pub fn interrupted(signal: i32) -> u8 {
    u8::try_from(128 + signal).unwrap_or(FAILED)
}

/// Writes a line to stderr, ignoring failure (stderr may be closed too).
pub fn note(args: fmt::Arguments<'_>) {
    let _ = writeln!(io::stderr(), "{args}");
}

/// Writes to stderr without a newline (progress), ignoring failure.
pub fn progress(args: fmt::Arguments<'_>) {
    let _ = write!(io::stderr(), "{args}");
}

/// Writes `text` to stdout and flushes it.
pub fn stdout(text: &str) -> io::Result<()> {
    let mut out = io::stdout().lock();
    out.write_all(text.as_bytes())?;
    out.flush()
}

/// Writes `text` and a newline to stdout and flushes it.
pub fn stdout_line(text: &str) -> io::Result<()> {
    let mut out = io::stdout().lock();
    out.write_all(text.as_bytes())?;
    out.write_all(b"\n")?;
    out.flush()
}

/// Whether stdout's reader is known to be gone (a pipe or socket whose
/// other end was closed, a terminal hung up), without writing to it.
pub fn stdout_gone() -> Option<io::Error> {
    let mut fd = libc::pollfd {
        fd: libc::STDOUT_FILENO,
        events: 0,
        revents: 0,
    };
    // SAFETY: `fd` is one valid pollfd; a zero timeout never blocks.
    let n = unsafe { libc::poll(&mut fd, 1, 0) };
    if n == 1 && fd.revents & (libc::POLLERR | libc::POLLHUP) != 0 {
        Some(io::Error::new(
            io::ErrorKind::BrokenPipe,
            "its reader has gone (closed pipe or hung-up terminal)",
        ))
    } else {
        None
    }
}

/// The terminal, as a session's [`Console`]: notes on stderr, output on
/// stdout.
pub struct Terminal;

impl Console for Terminal {
    fn note(&self, line: &str) {
        note(format_args!("{line}"));
    }

    fn print(&self, text: &str) -> io::Result<()> {
        stdout(text)
    }

    fn print_line(&self, line: &str) -> io::Result<()> {
        stdout_line(line)
    }
}

/// `run`'s events as JSON lines on stdout. Remembers its first failure.
#[derive(Debug, Default)]
pub struct StdoutEvents {
    /// The first failure (the run stopped on it).
    pub failed: Option<io::ErrorKind>,
    /// Print nothing: the terminal view (`run --tui`) owns stdout.
    pub quiet: bool,
}

impl StdoutEvents {
    fn fail(&mut self, e: io::Error) -> io::Error {
        self.failed.get_or_insert(e.kind());
        io::Error::new(e.kind(), format!("stdout: {e}"))
    }
}

impl EventSink for StdoutEvents {
    fn event(&mut self, event: &TimedEvent) -> io::Result<()> {
        if self.quiet {
            return Ok(());
        }
        let line = serde_json::to_string(event).map_err(io::Error::from)?;
        stdout_line(&line).map_err(|e| self.fail(e))
    }

    fn check(&mut self) -> io::Result<()> {
        if self.quiet {
            return Ok(());
        }
        match stdout_gone() {
            Some(e) => Err(self.fail(e)),
            None => Ok(()),
        }
    }
}

/// The exit status of a command that failed with `e`, and whether to say
/// why (a reader that went away is no news to it).
pub fn status_of(e: &anyhow::Error) -> (u8, bool) {
    let broken_pipe = e.chain().any(|c| {
        c.downcast_ref::<io::Error>()
            .is_some_and(|io| io.kind() == io::ErrorKind::BrokenPipe)
    });
    if broken_pipe {
        (BROKEN_PIPE, false)
    } else if e.chain().any(|c| c.is::<Invalid>()) {
        (INVALID, true)
    } else {
        (FAILED, true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use anyhow::Context;

    #[test]
    fn statuses() {
        let pipe: anyhow::Error = io::Error::from(io::ErrorKind::BrokenPipe).into();
        assert_eq!(status_of(&pipe.context("stdout")), (141, false));
        let full: anyhow::Error = io::Error::from(io::ErrorKind::StorageFull).into();
        assert_eq!(status_of(&full), (1, true));
        let bad = invalid::<()>(Err(anyhow::anyhow!("bad key"))).context("x.toml");
        assert_eq!(status_of(&bad.unwrap_err()), (2, true));
        assert_eq!(interrupted(libc::SIGHUP), 129);
        assert_eq!(interrupted(libc::SIGTERM), 143);
    }
}
