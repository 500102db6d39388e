//! Why a run stops, and the request for a safe stop that signal handlers
//! ([`signals`](super::signals)) and the telemetry side (a failed output)
//! set and the control loop reads at every tick.

use std::fmt;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use serde::{Serialize, Serializer};

/// Why a run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StopReason {
    /// Not stopped (yet).
    #[default]
    Running,
    /// A signal (its number): SIGINT, SIGTERM, SIGHUP, SIGQUIT… (see
    /// [`signals`](super::signals)).
    Signal(i32),
    /// An output failed (stdout closed, a full disk): nothing could be
    /// logged any more.
    OutputFailed,
    /// The arm failed (its stream was ended at once).
    ArmFault,
    /// The requested run time passed.
    Time,
    /// The sensor's recording or script ended.
    SensorEnded,
    /// Whoever watched the run on the telemetry side finished its work
    /// (`fit`: the guided session is over).
    Finished,
}

impl fmt::Display for StopReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            StopReason::Running => "running",
            StopReason::Signal(n) => return write!(f, "signal {}", SignalName(*n)),
            StopReason::OutputFailed => "output failed",
            StopReason::ArmFault => "arm fault",
            StopReason::Time => "time",
            StopReason::SensorEnded => "sensor ended",
            StopReason::Finished => "finished",
        })
    }
}

/// Written as its words.
impl Serialize for StopReason {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_str(self)
    }
}

/// The value of a stop request from a failed output (signals are their
/// numbers, all below it).
const OUTPUT_FAILED: usize = 1 << 16;
/// The value of a stop request from a watcher whose work is done.
const FINISHED: usize = OUTPUT_FAILED + 1;

/// A request for a safe stop, shared by the signal handlers, the telemetry
/// side and the control loop. The first request wins; later ones change
/// nothing. Lock-free and async-signal-safe (one atomic
/// compare-and-exchange).
#[derive(Debug, Clone, Default)]
pub struct StopRequest(Arc<AtomicUsize>);

impl StopRequest {
    /// No stop requested yet.
    pub fn new() -> StopRequest {
        StopRequest::default()
    }

    /// Requests a stop by `signal`. Async-signal-safe: called from the
    /// signal handler.
    pub fn signal(&self, signal: i32) {
        if let Ok(n) = usize::try_from(signal)
            && n > 0
            && n < OUTPUT_FAILED
        {
            let _ = self
                .0
                .compare_exchange(0, n, Ordering::SeqCst, Ordering::SeqCst);
        }
    }

    /// Requests a stop because an output failed (stdout closed, a full
    /// disk).
    pub fn output_failed(&self) {
        let _ = self
            .0
            .compare_exchange(0, OUTPUT_FAILED, Ordering::SeqCst, Ordering::SeqCst);
    }

    /// Requests a stop because the run's watcher on the telemetry side
    /// finished its work (`fit`: the guided session is over).
    pub fn finished(&self) {
        let _ = self
            .0
            .compare_exchange(0, FINISHED, Ordering::SeqCst, Ordering::SeqCst);
    }

    /// The request, if any. RT-safe (one atomic load).
    pub fn reason(&self) -> Option<StopReason> {
        match self.0.load(Ordering::Relaxed) {
            0 => None,
            OUTPUT_FAILED => Some(StopReason::OutputFailed),
            FINISHED => Some(StopReason::Finished),
            // Below OUTPUT_FAILED: a signal number (see `signal`).
            n => Some(StopReason::Signal(n as i32)),
        }
    }
}

/// Names of the Linux signals that `signal_hook` does not name.
const NAMES: [(i32, &str); 2] = [(libc::SIGSTKFLT, "SIGSTKFLT"), (libc::SIGPWR, "SIGPWR")];

/// A signal's name, for reports: `SIGHUP`, `SIGRTMIN+3`, or its number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SignalName(pub i32);

impl fmt::Display for SignalName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let n = self.0;
        if let Some((_, name)) = NAMES.iter().find(|&&(s, _)| s == n) {
            f.write_str(name)
        } else if let Some(name) = signal_hook::low_level::signal_name(n) {
            f.write_str(name)
        } else if (libc::SIGRTMIN()..=libc::SIGRTMAX()).contains(&n) {
            write!(f, "SIGRTMIN+{}", n - libc::SIGRTMIN())
        } else {
            write!(f, "{n}")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_request_wins() {
        let stop = StopRequest::new();
        assert_eq!(stop.reason(), None);
        stop.signal(libc::SIGHUP);
        stop.signal(libc::SIGTERM);
        stop.output_failed();
        assert_eq!(stop.reason(), Some(StopReason::Signal(libc::SIGHUP)));
        let stop = StopRequest::new();
        stop.output_failed();
        stop.signal(libc::SIGINT);
        assert_eq!(stop.reason(), Some(StopReason::OutputFailed));
        let stop = StopRequest::new();
        stop.finished();
        stop.signal(libc::SIGINT);
        assert_eq!(stop.reason(), Some(StopReason::Finished));
        assert_eq!(StopReason::Finished.to_string(), "finished");
    }

    #[test]
    fn signals_are_named() {
        assert_eq!(SignalName(libc::SIGQUIT).to_string(), "SIGQUIT");
        assert_eq!(SignalName(libc::SIGPWR).to_string(), "SIGPWR");
        assert_eq!(SignalName(libc::SIGKILL).to_string(), "SIGKILL");
        assert_eq!(SignalName(libc::SIGRTMIN() + 2).to_string(), "SIGRTMIN+2");
        assert_eq!(
            StopReason::Signal(libc::SIGHUP).to_string(),
            "signal SIGHUP"
        );
    }
}
