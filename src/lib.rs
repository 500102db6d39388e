//! sipnpuff: drive a six-axis assistive robot arm (Kinova JACO) with a
//! sip-and-puff sensor, using the sequence-matching interface of
//! Schweitzer & Campeau-Lecours.
//!
//! The folders show the architecture:
//!
//! * [`control`]: the pure, deterministic core (detector → selection →
//!   modes → motion), one [`control::pipeline::Pipeline::step`] per 1 ms
//!   tick on one [`control::tick::TickInput`]; no clock, no I/O, no
//!   allocation after start-up;
//! * [`config`]: TOML into a validated [`config::Config`], every problem
//!   named with its key and line;
//! * [`sensor`]: the [`sensor::Sensor`] seam and its backends: CSV
//!   recordings and the devices — evdev (USB HID sip-and-puff devices),
//!   serial (LipSync, FLipMouse, plain volts) and IIO (an ADC through the
//!   kernel);
//! * [`arm`]: the [`arm::Arm`] seam and its backends: the simulated JACO,
//!   ROS 2 (DDS), ROS 1 (a rosmaster) and Kinova's SDK;
//! * [`output`]: the [`output::Output`] seam beyond the arm and its
//!   backends: the computer's keyboard and pointer through uinput, the
//!   home through MQTT (Home Assistant);
//! * [`clock`]: `CLOCK_MONOTONIC` and absolute sleeps, or simulated time:
//!   what the runtime's loop and the sensors' timers wait on;
//! * [`wakes`]: a thread's record of how late it woke and the page faults
//!   it took, kept by the threads the loop waits on;
//! * [`rt`]: the 1 kHz runtime around the core: the scheduler, real-time
//!   set-up, the threads and rings, telemetry and the run report;
//! * [`display`]: what the user sees and hears, served to a browser or
//!   drawn in a terminal, fed from the telemetry side;
//! * [`fit`]: fitting the interface to a person: a calibration's breaths
//!   measured, their settings proposed with reasons, checked by replay,
//!   written as a profile;
//! * [`gestures`]: a person's own head gestures: a recording cut along
//!   the gesture protocol, templates and thresholds from their data,
//!   leave-one-out accuracy and false activations per hour;
//! * [`sim`]: the sensor model, simulated users (and breathers with known
//!   breathing), the synthetic sensor that plays one live, and the
//!   paper's study;
//! * [`tools`]: replay, session recordings and their loaders, benchmarks,
//!   the accuracy scorer, the safety monitor and synthetic recordings
//!   written;
//! * [`wiring`]: the backends chosen from their specs (`--sensor`,
//!   `--arm`, `--output`), the one place that maps a spec to a backend;
//! * [`design`]: designing the sequence library for a person;
//! * [`session`]: sessions end to end: `run`'s, the live calibration and
//!   the fit of a recording, wiring the runtime, the backends, the
//!   display and the recorder;
//! * [`cli`]: the `sipnpuff` command line, one file per command: its
//!   options parsed, one call, the result printed.
//!
//! One sample's way from a serial sensor to a ROS 2 arm, file by file,
//! is in `docs/architecture.md`: the sensor's reader thread holds the
//! newest value ([`sensor::Reading`]); the control loop
//! (`rt/control_loop.rs`) makes the tick's [`control::tick::TickInput`];
//! [`control::pipeline::Pipeline::step`] runs the detector, the matcher,
//! the mode machine and the motion layer, whose decimator makes the 100 Hz
//! [`control::motion::stream::ArmCommand`]; the arm thread
//! (`rt/arm_thread.rs`) sends it through the [`arm::Arm`] seam.
//!
//! Import rules (checked by `tests/it/architecture.rs`): the modules stand
//! on floors — `control`; `sensor`, `arm`, `output`; `config`, `rt`;
//! `fit`, `gestures`, `wiring`; `sim`, `display`; `tools`; `design`, `session`; `cli` —
//! and each imports only from the floors below its own (`rt` only the
//! seams' roots); the backends the specs name are opened in `wiring`; no
//! import cycle between files.
//!
//! ```
//! use sipnpuff::config::Config;
//! use sipnpuff::control::event::Event;
//! use sipnpuff::control::mode::{Direction, Mode, ModeState};
//! use sipnpuff::control::pipeline::Pipeline;
//! use sipnpuff::control::target::Target;
//! use sipnpuff::control::tick::{TickInput, TickOutput};
//!
//! // Built-in library: two short puffs select forward/backward.
//! let mut core = Pipeline::new(Config::default().core());
//! let mut out = TickOutput::default();
//! let mut tick = 0;
//! let mut breathe = |core: &mut Pipeline, out: &mut TickOutput, volts: f64, ms: u64| {
//!     let mut events = Vec::new();
//!     for _ in 0..ms {
//!         core.step(&TickInput::volts(tick, volts), out);
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
//! assert!(events.iter().any(|e| matches!(e, Event::Match { target: Target::Mode(Mode::TranslateX), .. })));
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
pub mod clock;
pub mod config;
pub mod control;
pub mod design;
#[cfg(feature = "display")]
pub mod display;
pub mod fit;
pub mod gestures;
pub mod output;
pub mod rt;
pub mod sensor;
pub mod session;
pub mod sim;
pub mod tools;
pub mod wakes;
pub mod wiring;
