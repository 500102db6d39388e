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
//! use sipnpuff::control::pipeline::{Pipeline, TickOutput};
//! use sipnpuff::control::sample::Sample;
//!
//! // Built-in library: two short puffs select forward/backward.
//! let mut core = Pipeline::new(Config::default().core());
//! let mut out = TickOutput::default();
//! let mut tick = 0;
//! let mut breathe = |core: &mut Pipeline, out: &mut TickOutput, volts: f64, ms: u64| {
//!     let mut events = Vec::new();
//!     for _ in 0..ms {
//!         core.step(tick, Sample::Volts(volts), out);
//!         events.extend(out.events.iter().copied());
//!         tick += 1;
//!     }
//!     events
//! };
//! breathe(&mut core, &mut out, 2.5, 500);
//! breathe(&mut core, &mut out, 4.0, 150); // short puff
//! breathe(&mut core, &mut out, 2.5, 300);
//! breathe(&mut core, &mut out, 4.0, 150); // short puff
//! let events = breathe(&mut core, &mut out, 2.5, 10);
//! assert!(events.iter().any(|e| matches!(e, Event::Match { mode: Mode::TranslateX, .. })));
//!
//! // Hold-to-run: a puff now means "forward" for as long as it is held.
//! breathe(&mut core, &mut out, 3.8, 20);
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
