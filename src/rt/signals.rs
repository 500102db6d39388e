//! Stop requests: from signals (set in their handlers) and from the
//! telemetry side (an output that failed). The control loop reads the
//! request at every tick and begins the safe stop.
//!
//! Which signals stop `run` safely ([`STOP_SIGNALS`]): every signal whose
//! default action would end or suspend the process, except
//!
//! * SIGKILL and SIGSTOP, which cannot be caught (the arm's own stream
//!   watchdog stops it: a JACO2 stops when its 100 Hz stream stops);
//! * the signals that report a fault of the process itself (SIGSEGV,
//!   SIGBUS, SIGILL, SIGFPE, SIGTRAP, SIGSYS, SIGABRT): it cannot go on
//!   safely, so it dies as they say, and the arm's watchdog stops it;
//! * SIGPIPE and SIGXFSZ, which are ignored (Rust's runtime ignores
//!   SIGPIPE; the command line ignores SIGXFSZ): a write to a closed pipe
//!   or past the file-size limit fails with an error instead, handled
//!   as a failed output;
//! * SIGTTIN and SIGTTOU (a background job touching the terminal): left as
//!   they are (the loop never reads the terminal; with `stty tostop` a
//!   background `run` is suspended when it prints, a stall).
//!
//! A repeated signal never cuts a safe stop short: it is bounded
//! ([`MAX_STOP_TICKS`](super::control_loop::MAX_STOP_TICKS)), and SIGKILL
//! ends the process at once.

use crate::rt::stop::StopRequest;

/// The signals that stop `run` safely (the real-time signals
/// SIGRTMIN..=SIGRTMAX as well: see [`stop_signals`]).
pub const STOP_SIGNALS: [i32; 14] = [
    libc::SIGHUP,
    libc::SIGINT,
    libc::SIGQUIT,
    libc::SIGUSR1,
    libc::SIGUSR2,
    libc::SIGALRM,
    libc::SIGTERM,
    libc::SIGSTKFLT,
    libc::SIGTSTP,
    libc::SIGXCPU,
    libc::SIGVTALRM,
    libc::SIGPROF,
    libc::SIGIO,
    libc::SIGPWR,
];

/// Every signal that stops `run` safely: [`STOP_SIGNALS`] and the
/// real-time signals.
pub fn stop_signals() -> Vec<i32> {
    let mut all = STOP_SIGNALS.to_vec();
    all.extend(libc::SIGRTMIN()..=libc::SIGRTMAX());
    all
}

/// From here on every signal of [`stop_signals`] requests a safe stop
/// through `stop` instead of ending the process. Not RT-safe: call at
/// set-up.
pub fn install(stop: &StopRequest) -> std::io::Result<()> {
    for signal in stop_signals() {
        let stop = stop.clone();
        // SAFETY: the action is async-signal-safe: one compare-and-exchange
        // on a lock-free `AtomicUsize` (no allocation, lock or I/O; the
        // `Arc` is only read, never dropped, in the handler).
        unsafe {
            signal_hook::low_level::register(signal, move || stop.signal(signal))?;
        }
    }
    Ok(())
}

/// A new stop request that every signal of [`stop_signals`] sets
/// ([`install`]): from here on they stop the run safely, and a repeated
/// signal does not cut the safe stop short. Not RT-safe: call at set-up.
pub fn stop_request() -> std::io::Result<StopRequest> {
    let stop = StopRequest::new();
    install(&stop)?;
    Ok(stop)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rt::stop::SignalName;

    #[test]
    fn crash_signals_and_the_ignored_ones_are_not_stop_signals() {
        let all = stop_signals();
        for s in [
            libc::SIGSEGV,
            libc::SIGBUS,
            libc::SIGILL,
            libc::SIGFPE,
            libc::SIGABRT,
            libc::SIGKILL,
            libc::SIGSTOP,
            libc::SIGPIPE,
            libc::SIGXFSZ,
            libc::SIGCHLD,
        ] {
            assert!(!all.contains(&s), "{}", SignalName(s));
        }
    }
}
