//! What the user sees and hears: the display of modes, sequences, the
//! pressure and the arm's state, for the wheelchair's screen, a tablet or
//! an engineer's terminal.
//!
//! * [`screen`] turns the loop's records and events into [`frame::Frame`]s
//!   (pure, tested with simulated ticks);
//! * [`hub`] runs the screen on the telemetry thread and publishes its
//!   frames and sounds;
//! * [`server`] serves the page and its event stream (`run --display`);
//! * [`tui`] draws the same frames in a terminal (`run --tui`).
//!
//! Fed from the telemetry side, never from the control thread: a slow or
//! absent viewer costs the loop nothing.

pub mod frame;
pub mod hub;
pub mod screen;
pub mod server;
pub mod tui;
pub mod words;
