//! A person's own head gestures, fitted from their recording as the
//! breath interface is fitted from their breaths: the recording cut along
//! the gesture protocol ([`protocol`]), each example a template, each
//! gesture's rejection threshold from their own examples and ordinary
//! movement, and the check a clinician reads before using the set.
//! Samples and settings in, results out: files are read and written
//! above this module.

pub mod check;
pub mod distances;
pub mod front_end;
pub mod guided;
pub mod protocol;
pub mod record;
pub mod report;
pub mod set;
pub mod setup;
pub mod thresholds;
