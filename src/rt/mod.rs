//! The real-time runtime: the thin shell around the core that runs it at
//! 1 kHz on a Linux controller. Threads, clocks, priorities, affinity,
//! files: everything the core must not do lives here.

pub mod clock;
pub mod run;
pub mod scheduler;
pub mod setup;
pub mod telemetry;
