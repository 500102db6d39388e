//! sipnpuff: drive a six-axis assistive robot arm (Kinova JACO) with a
//! sip-and-puff sensor, using the sequence-matching interface of
//! Schweitzer & Campeau-Lecours.
//!
//! The folders show the architecture:
//!
//! * [`control`]: the pure, deterministic core (detector → selection →
//!   modes → motion), one step per 1 ms tick, no clock, no I/O, no
//!   allocation after start-up;
//! * [`config`]: TOML into a validated [`config::Config`];
//! * [`sensor`]: the [`sensor::Sensor`] seam and its backends (the
//!   synthetic scripted user, CSV recordings);
//! * [`arm`]: the [`arm::Arm`] seam and its backends (the simulated JACO);
//! * [`rt`]: the 1 kHz runtime around the core (scheduler, RT set-up,
//!   threads, telemetry, the run report);
//! * [`sim`]: the sensor model, simulated users and the paper's study;
//! * [`tools`]: replay, session recordings, benchmarks and the accuracy
//!   scorer;
//! * [`cli`]: the `sipnpuff` command line, one file per command.
//!
//! Import rules (checked by `tests/it/architecture.rs`): `control` imports
//! nothing else of the crate; `rt` imports `control` and the sensor and
//! arm traits only; concrete backends are chosen in `cli`; no import cycle
//! between files.
//!
//! ```
//! use sipnpuff::config::Config;
//! use sipnpuff::control::event::Event;
//! use sipnpuff::control::mode::{Direction, Mode, ModeState};
//! use sipnpuff::control::pipeline::Pipeline;
//!
//! // Built-in library: two short puffs select forward/backward.
//! let config = Config::default();
//! let mut core: Pipeline = Pipeline::new(config.core());
//! let mut tick = 0;
//! let mut feed = |core: &mut Pipeline, volts: f64, ms: u64| {
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
//! assert_eq!(out.command.direction, Direction::Positive);
//! ```

#![deny(missing_docs)]
#![deny(unsafe_op_in_unsafe_fn)]
#![deny(clippy::undocumented_unsafe_blocks)]
// `print!` and `eprint!` panic when their stream fails: output goes
// through `cli::output`, whose writes return their errors.
#![deny(clippy::print_stdout, clippy::print_stderr)]

pub mod arm;
pub mod cli;
pub mod config;
pub mod control;
#[cfg(feature = "display")]
pub mod display;
pub mod rt;
pub mod sensor;
pub mod sim;
pub mod tools;
