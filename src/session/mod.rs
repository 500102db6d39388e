//! Sessions end to end: the runtime run on the backends chosen from their
//! specs ([`crate::wiring`]), watched by the display ([`showing`]) and
//! recorded — `run`'s session ([`run`]) and the guided calibration
//! ([`calibration`], its [`guide`] on the telemetry side) — and the fit
//! of what a calibration leaves ([`fitting`]). Everything a session says
//! goes to the command line's [`Console`].

pub mod calibration;
pub mod cpu_bench;
pub mod doctor;
pub mod fitting;
pub mod gesture_session;
pub mod gestures;
pub mod guide;
pub mod imu;
pub mod run;
pub mod showing;

/// Where a session's words go: the command line's terminal, which never
/// panics on a closed stream.
pub trait Console {
    /// A note for the person at the terminal (stderr); a failure is
    /// ignored (there is nowhere left to say it).
    fn note(&self, line: &str);
    /// Output (stdout), flushed.
    fn print(&self, text: &str) -> std::io::Result<()>;
    /// A line of output and its newline (stdout), flushed.
    fn print_line(&self, line: &str) -> std::io::Result<()>;
}
