//! What the sensor gave the core on one tick: a sample, or the fact that
//! none came, or that the sensor's device is gone. Part of every
//! [`TickInput`](crate::control::tick::TickInput), and the one input of the
//! detector.

/// One tick's input from the sensor. `Copy`, RT-safe.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Sample {
    /// A sample, volts. Any `f64`: NaN, ±∞ and values off the 0–5 V range
    /// are sensor faults the detector reports.
    Volts(f64),
    /// No sample arrived on this tick: after `stale_ms` without one the
    /// sensor is in fault.
    #[default]
    Missing,
    /// The sensor's device is gone (unplugged, unbound, its reader ended):
    /// the sensor is in fault at once, without waiting `stale_ms`.
    Lost,
}

impl Sample {
    /// The volts, if this is a sample.
    pub fn volts(self) -> Option<f64> {
        match self {
            Sample::Volts(volts) => Some(volts),
            Sample::Missing | Sample::Lost => None,
        }
    }
}
