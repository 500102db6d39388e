//! Fitting the interface to the person: a calibration session's breaths
//! measured, and the settings that read them best proposed.
//!
//! * [`protocol`]: what the user is asked to breathe, in a fixed order.

pub mod protocol;
