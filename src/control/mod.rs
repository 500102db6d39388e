//! The deterministic core: one voltage sample (and, for a person with
//! gestures, one IMU sample) per tick in, events and a jerk-limited
//! Cartesian velocity out.
//!
//! ```text
//! volts ─► detector ─┐
//!          (bursts)  ├► selection ─► modes ─► motion ─► twist (1 kHz) ─► ArmCommand (100 Hz)
//! IMU ───► head ─────┘  (ASP: matcher,  (Fig. 1)  (Ruckig,
//!          (gestures,    BSP: scanning)            limits)
//!           tilt)
//! ```
//!
//! * [`detector`] turns samples into bursts (short/long sip/puff) and says
//!   what breath is held right now;
//! * [`selection`] picks a mode: the paper's sequence matcher (ASP) or the
//!   scanning baseline (BSP);
//! * [`modes`] is the detection/command mode machine of the paper's Fig. 1;
//! * [`motion`] makes the smooth, limited velocity and the arm's stream;
//! * [`pointer`](mod@pointer) moves the computer's pointer in its modes, and
//!   [`target`] says what a match selects or fires (a key chord, a click,
//!   a home event): [`output_command`] carries them to the outputs;
//! * [`tick`] is what goes into the core on one tick (the sample, the
//!   arm's news, the start of a safe stop) and what comes out;
//! * [`pipeline`] wires the stages into one [`Pipeline::step`] per tick,
//!   the only call that changes the core;
//! * [`view`] is where the user is, for the display;
//! * [`imu`] is a head-worn IMU's sample, the gesture front end's input;
//! * [`gesture`] turns those samples into recognised or rejected gestures,
//!   and [`head`] is the IMU's stage in the pipeline: its faults, its
//!   gestures, and in a command mode the tilt that moves;
//! * [`token`] is a sequence's element (a breath's action or a gesture),
//!   [`sequence`] the sequences of them, each an [`inline_seq`] as the
//!   breath tools' sequences of actions are.
//!
//! Everything here is pure: time enters as a [`Tick`] argument; nothing
//! reads a clock, sleeps, locks, does I/O or allocates after construction.
//! This module imports nothing else of the crate (each stage's settings
//! live with the stage; `crate::config` reads them from TOML), and no
//! code path may panic: unwraps, `expect`, `panic!` and unchecked
//! indexing are denied below.
//!
//! [`Pipeline::step`]: pipeline::Pipeline::step

#![deny(clippy::unwrap_used)]
#![deny(clippy::expect_used)]
#![deny(clippy::panic)]
#![deny(clippy::indexing_slicing)]

pub mod action;
pub mod core_config;
pub mod detector;
pub mod event;
pub mod gesture;
pub mod head;
pub mod imu;
pub mod inline_seq;
pub mod keys;
pub mod mode;
pub mod modes;
pub mod motion;
pub mod output_command;
pub mod pipeline;
pub mod pointer;
pub mod sample;
pub mod selection;
pub mod sequence;
pub mod skip_count;
pub mod target;
pub mod tick;
pub mod token;
pub mod view;

/// Time in the core: one tick is one millisecond, one sensor sample at 1 kHz.
pub type Tick = u64;
