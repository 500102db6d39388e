//! sipnpuff: drive a six-axis assistive robot arm (Kinova JACO) with a
//! sip-and-puff sensor, using the sequence-matching interface of
//! Schweitzer & Campeau-Lecours.
//!
//! The crate is split into a deterministic core and thin edges:
//!
//! * [`detector`] turns one voltage sample per tick into bursts (short/long
//!   sip/puff) and reports what breath is held right now;
//! * [`matcher`] matches bursts against the user's sequence library with the
//!   paper's waiting rules for prefixes;
//! * [`modes`] is the detection/command mode machine of the paper's Fig. 1;
//! * [`pipeline`] wires the three together into one `step` per tick.
//!
//! The core never reads a clock, sleeps, locks, does I/O or allocates after
//! construction: time enters as a [`Tick`] argument (1 tick = 1 ms = one
//! sensor sample at 1 kHz). [`config`], [`signal`], [`csv_signal`] and
//! [`replay`] are set-up and tooling code and may allocate.

#![deny(missing_docs)]
#![deny(unsafe_op_in_unsafe_fn)]
#![deny(clippy::undocumented_unsafe_blocks)]

pub mod action;
pub mod alloc_counter;
pub mod config;
pub mod csv_signal;
pub mod detector;
pub mod event;
pub mod matcher;
pub mod modes;
pub mod pipeline;
pub mod replay;
pub mod signal;

/// Time in the core: one tick is one millisecond, one sensor sample at 1 kHz.
pub type Tick = u64;
