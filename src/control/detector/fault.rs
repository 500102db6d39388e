//! Why the sensor signal was rejected, in the event log's plain words.

use std::fmt;

use serde::{Serialize, Serializer};

use crate::control::Tick;

/// Why the sensor signal was rejected.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FaultReason {
    /// The sample is NaN (e.g. a dropped reading).
    NotANumber,
    /// The sample is ±infinity.
    Infinite,
    /// The sample is further outside 0–5 V than `fault_margin_volts`.
    OutOfRange {
        /// The offending sample.
        volts: f64,
    },
    /// No sample arrived for `stale_ms`.
    Stale {
        /// How long without a sample, ms.
        ms: u64,
    },
    /// A breath held longer than `max_hold_ms`: the sensor is stuck (at a
    /// level, grounded or saturated) or its offset shifted.
    Stuck {
        /// The sample on the tick the breath became too long.
        volts: f64,
        /// How long the breath had been held, ms.
        held_ms: u64,
    },
    /// The sensor's device went away (unplugged, unbound, its driver
    /// gone): no sample can come until it returns.
    Disconnected,
    /// The tick jumped by more than `stale_ms`: the process or the machine
    /// stalled (SIGSTOP, a VM pause). Whatever was held across the gap is
    /// dropped, never measured as a breath.
    Stalled {
        /// Time from the previous tick to this one, ms.
        ms: u64,
    },
    /// No IMU sample arrived for `[gestures] stale_ms`.
    ImuStale {
        /// How long without a sample, ms.
        ms: u64,
    },
    /// The IMU gave the same six values bit for bit for `frozen_ms`: a
    /// live sensor's noise always moves one of them, so it has stopped.
    ImuFrozen {
        /// How long the values stayed the same, ms.
        ms: u64,
    },
    /// An IMU value is NaN or infinite.
    ImuNotFinite,
    /// The IMU's device went away.
    ImuDisconnected,
    /// A tick no later than the previous one: time must increase, so the
    /// runtime feeding the core is broken. Everything stops.
    TickNotIncreasing {
        /// The tick given.
        tick: Tick,
        /// The tick before it.
        previous: Tick,
    },
}

/// The reason in plain words, as the event log and the report show it.
impl fmt::Display for FaultReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FaultReason::NotANumber => f.write_str("sensor sample is NaN"),
            FaultReason::Infinite => f.write_str("sensor sample is infinite"),
            FaultReason::OutOfRange { volts } => {
                write!(f, "sensor sample {volts:.3} V is outside the 0–5 V range")
            }
            FaultReason::Stale { ms } => write!(f, "no sensor sample for {ms} ms"),
            FaultReason::Disconnected => f.write_str("sensor disconnected — arm stopped"),
            FaultReason::Stuck { volts, held_ms } => write!(
                f,
                "breath held {held_ms} ms at {volts:.2} V, the limit detector.max_hold_ms sets — arm stopped: a breath as long as the settings allow (raise detector.max_hold_ms if it was meant), or the sensor stuck or its offset shifted"
            ),
            FaultReason::Stalled { ms } => write!(
                f,
                "the control loop stalled for {ms} ms (process stopped or machine paused): samples of the gap discarded — arm stopped"
            ),
            FaultReason::ImuStale { ms } => write!(f, "no IMU sample for {ms} ms — arm stopped"),
            FaultReason::ImuFrozen { ms } => write!(
                f,
                "the IMU's six values have not changed for {ms} ms: it has stopped — arm stopped"
            ),
            FaultReason::ImuNotFinite => f.write_str("IMU sample is NaN or infinite — arm stopped"),
            FaultReason::ImuDisconnected => f.write_str("IMU disconnected — arm stopped"),
            FaultReason::TickNotIncreasing { tick, previous } => write!(
                f,
                "tick {tick} is not after the previous tick {previous}: the runtime's clock is broken"
            ),
        }
    }
}

/// Serialized as its plain words.
impl Serialize for FaultReason {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_str(self)
    }
}
