//! A finished burst: the detector's word for one breath that counted.

use serde::{Serialize, Serializer};

use crate::control::Tick;
use crate::control::action::Action;

/// A finished burst.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Burst {
    /// Short/long sip/puff.
    pub action: Action,
    /// First tick past the threshold.
    pub start: Tick,
    /// First tick back past the threshold by the hysteresis.
    pub end: Tick,
}

impl Burst {
    /// Length in ticks (ms).
    pub fn duration_ms(&self) -> u64 {
        self.end.saturating_sub(self.start)
    }
}

/// A burst is written as its paper code, first tick and length (the event
/// log's `action`, `start_tick`, `duration_ms`).
impl Serialize for Burst {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        #[derive(Serialize)]
        struct Fields {
            action: Action,
            start_tick: Tick,
            duration_ms: u64,
        }
        Fields {
            action: self.action,
            start_tick: self.start,
            duration_ms: self.duration_ms(),
        }
        .serialize(serializer)
    }
}
