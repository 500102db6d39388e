//! The real-time runtime: the thin shell around the core that runs it at
//! 1 kHz on a Linux controller. Threads, clocks, priorities, affinity,
//! rings: everything the core must not do lives here. It knows the core
//! (`control`) and the sensor and arm seams, never a concrete backend,
//! the simulator, the tools or the command line.
//!
//! * [`scheduler`]: absolute deadlines on the [`crate::clock`], skip
//!   accounting;
//! * [`setup`]: SCHED_FIFO, affinity, mlockall, each step reported;
//! * [`stop`], [`signals`]: why a run stops; stop requests, from signals
//!   (which ones, and their handlers) and failed outputs;
//! * [`control_loop`]: the 1 kHz loop and the production tick;
//! * [`serving`]: what each thread the loop waits on reports of its
//!   wake-ups and page faults;
//! * [`arm_thread`]: the 100 Hz arm stream; [`output_thread`]: the
//!   outputs beyond the arm (keyboard and pointer, home), each on its own
//!   thread;
//! * [`threads`]: `run`, one run's options and its threads; [`rings`]:
//!   the rings between them;
//! * [`telemetry_thread`]: the thread that empties the rings for the
//!   event sink, the recorder and the display;
//! * [`telemetry`], [`report`]: histograms and the run report;
//! * [`simulated`]: the same loop on a simulated clock, for RTSan and the
//!   allocation checks;
//! * [`recorder`]: the session recorder's seam (`run --record`);
//! * [`alloc_counter`]: the counting allocator that proves the control
//!   thread allocates nothing.

pub mod alloc_counter;
pub mod arm_thread;
pub mod control_loop;
pub mod output_thread;
pub mod recorder;
pub mod report;
pub mod rings;
pub mod scheduler;
pub mod service_watchdog;
pub mod serving;
pub mod setup;
pub mod signals;
pub mod simulated;
pub mod stop;
pub mod telemetry;
pub mod telemetry_thread;
pub mod threads;
