//! Events the core reports, and the fixed-capacity list one tick carries.
//!
//! The event log (`replay`, `run`) is derived from these types through
//! serde: one JSON object per event, `{"tick":N,"event":"<name>",…}` (see
//! [`TimedEvent`]).

use serde::Serialize;

use crate::control::Tick;
use crate::control::detector::{Burst, FaultReason};
use crate::control::gesture::name::GestureName;
use crate::control::gesture::recognizer::RejectReason;
use crate::control::mode::Mode;
use crate::control::modes::DetectionReason;
use crate::control::motion::MotionEvent;
use crate::control::motion::feedback::ArmFault;
use crate::control::selection::matcher::ResetReason;
use crate::control::sequence::Sequence;
use crate::control::target::Target;

/// Something worth telling the user, the clinician or the log. `Copy`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum Event {
    /// A burst was detected.
    Burst(Burst),
    /// A sequence matched: command mode for its mode starts, or its
    /// action fires.
    Match {
        /// The matched sequence.
        sequence: Sequence,
        /// What it selects or fires (`"mode":…`, `"key":…`, `"click":…`,
        /// `"home_event":…`).
        #[serde(flatten)]
        target: Target,
    },
    /// A head gesture was recognised: the sequence's next token.
    Gesture {
        /// Its name in the person's gesture set.
        name: GestureName,
        /// The movement's first tick.
        start_tick: Tick,
    },
    /// A movement matched none of the person's gestures (never guessed).
    GestureRejected {
        /// The nearest gesture compared, if any.
        nearest: Option<GestureName>,
        /// Why.
        why: RejectReason,
    },
    /// The current sequence was dropped.
    Reset {
        /// The dropped sequence.
        sequence: Sequence,
        /// Why.
        reason: ResetReason,
    },
    /// The scanning interface (BSP) highlights this mode.
    Highlight {
        /// The mode highlighted.
        mode: Mode,
    },
    /// Back to detection mode.
    Detection {
        /// Why.
        reason: DetectionReason,
    },
    /// The sensor signal became invalid; motion stops.
    Fault {
        /// Why, in plain words in the log.
        reason: FaultReason,
    },
    /// The sensor signal is valid again; detection resumes.
    Recovered,
    /// After a stuck fault, the level the sensor settled at was steady for
    /// `rezero_ms`: it is the new neutral (the thresholds moved with it)
    /// and detection resumes.
    Rezeroed {
        /// The new neutral, volts.
        neutral_volts: f64,
        /// The neutral before, volts.
        previous_volts: f64,
    },
    /// The arm cannot be trusted or reached (its link lost, its measured
    /// pose silent or off the commanded path): the arm brakes to rest and
    /// the interface stays in detection mode for good.
    ArmFault {
        /// Why, in plain words in the log.
        #[serde(serialize_with = "plain_words")]
        reason: ArmFault,
    },
    /// From the motion layer (save, go to, workspace limits), logged under
    /// its own event name.
    #[serde(untagged)]
    Motion(MotionEvent),
}

/// A reason written as the sentence a person reads.
fn plain_words<S: serde::Serializer>(reason: &ArmFault, serializer: S) -> Result<S::Ok, S::Error> {
    serializer.collect_str(reason)
}

/// An event and the tick it happened on: one line of the event log.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TimedEvent {
    /// The tick.
    pub tick: Tick,
    /// What happened.
    #[serde(flatten)]
    pub event: Event,
}

/// Most events one tick can produce: a fault also resets the sequence and
/// leaves command mode (3); a burst, a match and two motion events (4);
/// with scanning, a burst, a selection, a highlight and two motion events
/// (5); an arm fault or a pose correction adds one.
pub const MAX_EVENTS_PER_TICK: usize = 8;

/// The events of one tick, inline. `Copy`, RT-safe.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Events {
    items: [Option<Event>; MAX_EVENTS_PER_TICK],
    len: u8,
}

impl Default for Events {
    fn default() -> Self {
        Events {
            items: [None; MAX_EVENTS_PER_TICK],
            len: 0,
        }
    }
}

impl Events {
    /// Adds an event; returns it back if the list is full (cannot happen
    /// with the core's event sources, see [`MAX_EVENTS_PER_TICK`]).
    #[allow(
        clippy::result_large_err,
        reason = "the event handed back is the inline value itself"
    )]
    pub fn push(&mut self, event: Event) -> Result<(), Event> {
        let slot = self.items.get_mut(usize::from(self.len)).ok_or(event)?;
        *slot = Some(event);
        self.len += 1;
        Ok(())
    }

    /// Empties the list (only the slots in use are written). RT-safe.
    pub fn clear(&mut self) {
        for slot in self.items.iter_mut().take(usize::from(self.len)) {
            *slot = None;
        }
        self.len = 0;
    }

    /// The events, in the order they happened.
    pub fn iter(&self) -> impl Iterator<Item = &Event> {
        self.items.iter().flatten()
    }

    /// Number of events.
    pub fn len(&self) -> usize {
        usize::from(self.len)
    }

    /// Whether nothing happened.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}
