//! sipnpuff: drive a six-axis assistive robot arm (Kinova JACO) with a
//! sip-and-puff sensor, using the sequence-matching interface of
//! Schweitzer & Campeau-Lecours.
//!
//! The crate is split into a deterministic core and thin edges:
//!
//! * [`detector`] turns one voltage sample per tick into bursts (short/long
//!   sip/puff) and reports what breath is held right now;
//! * [`matcher`] matches bursts against the user's sequence library with the
//!   paper's waiting rules for prefixes (ASP); [`scanning`] is the paper's
//!   baseline instead (BSP): the modes scroll and a puff enters one;
//! * [`modes`] is the detection/command mode machine of the paper's Fig. 1;
//! * [`motion`] turns the mode and breath into a jerk-limited Cartesian
//!   velocity (Ruckig), keeps the tool inside its workspace, saves and goes
//!   to points, and decimates the result to the arm's 100 Hz stream;
//! * [`pipeline`] wires them together into one `step` per tick.
//!
//! [`arm`] is the edge towards the robot: the backend trait and the
//! simulated JACO.
//!
//! The core never reads a clock, sleeps, locks, does I/O or allocates after
//! construction: time enters as a [`Tick`] argument (1 tick = 1 ms = one
//! sensor sample at 1 kHz). [`config`], [`signal`], [`csv_signal`] and
//! [`replay`] are set-up and tooling code and may allocate.
//!
//! ```
//! use sipnpuff::config::Config;
//! use sipnpuff::event::Event;
//! use sipnpuff::modes::{Mode, ModeState};
//! use sipnpuff::pipeline::Core;
//!
//! // Built-in library: two short puffs select forward/backward.
//! let config = Config::default();
//! let mut core: Core = Core::new(&config);
//! let mut tick = 0;
//! let mut feed = |core: &mut Core, volts: f64, ms: u64| {
//!     let mut events = Vec::new();
//!     for _ in 0..ms {
//!         events.extend(core.step(tick, volts).events.iter().copied());
//!         tick += 1;
//!     }
//!     events
//! };
//! feed(&mut core, 2.5, 500);
//! feed(&mut core, 4.0, 150); // short puff
//! feed(&mut core, 2.5, 300);
//! feed(&mut core, 4.0, 150); // short puff
//! let events = feed(&mut core, 2.5, 10);
//! assert!(events.iter().any(|e| matches!(e, Event::Match { mode: Mode::TranslateX, .. })));
//!
//! // Hold-to-run: a puff now means "forward" for as long as it is held.
//! let out = (0..20).map(|_| { tick += 1; core.step(tick, 3.8) }).last().unwrap();
//! assert_eq!(out.command.state, ModeState::Command(Mode::TranslateX));
//! assert_eq!(out.command.direction, 1);
//! ```

#![deny(missing_docs)]
#![deny(unsafe_op_in_unsafe_fn)]
#![deny(clippy::undocumented_unsafe_blocks)]

pub mod accuracy;
pub mod action;
pub mod alloc_counter;
pub mod arm;
pub mod bench;
pub mod config;
pub mod csv_signal;
pub mod detector;
pub mod event;
pub mod matcher;
pub mod modes;
pub mod motion;
pub mod pipeline;
pub mod replay;
pub mod rt;
pub mod scanning;
pub mod signal;
pub mod study;

/// Time in the core: one tick is one millisecond, one sensor sample at 1 kHz.
pub type Tick = u64;
