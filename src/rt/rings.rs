//! The rings of a run, bounded and allocated before the loop: the control
//! thread's commands to the arm thread, its tick records and events to the
//! telemetry side and, when recording, a copy of each arm command for the
//! session recorder; and the arm's measured poses back to the control
//! thread. A full ring never blocks the control thread: the item is
//! dropped and counted ([`Drops`](super::telemetry::Drops)).

use rtrb::RingBuffer;

use crate::rt::arm_thread::{ArmHandoff, Handed};
use crate::rt::control_loop::OutputRings;
use crate::rt::telemetry::TickRecord;
use crate::rt::telemetry_thread::TelemetryRings;

/// Commands to the arm thread: 2.56 s of them at 100 Hz.
const ARM_RING: usize = 256;
/// Tick records to the telemetry side: 16 s at 1 kHz.
const RECORD_RING: usize = 16_384;
/// Events to the telemetry side.
const EVENT_RING: usize = 1024;
/// Copies of arm commands for the recorder: 10 s at 100 Hz.
const RECORDED_COMMAND_RING: usize = 1024;
/// Measured poses to the control thread: 64 ms at 1 kHz of feedback.
pub(super) const FEEDBACK_RING: usize = 64;

/// Both ends of the rings the control thread pushes into.
pub(super) struct Rings {
    /// The control tick's commands and events.
    pub outputs: OutputRings,
    /// The control loop's tick records.
    pub records: rtrb::Producer<TickRecord>,
    /// The arm thread's end of the command ring.
    pub arm: rtrb::Consumer<Handed>,
    /// The telemetry side's ends.
    pub telemetry: TelemetryRings,
}

impl Rings {
    /// The rings of one run; the recorder's command ring only if
    /// `recording`.
    pub fn new(recording: bool) -> Rings {
        let (arm, arm_rx) = RingBuffer::new(ARM_RING);
        let (events, event_rx) = RingBuffer::new(EVENT_RING);
        let (records, record_rx) = RingBuffer::new(RECORD_RING);
        let (recorded, recorded_rx) = if recording {
            let (tx, rx) = RingBuffer::new(RECORDED_COMMAND_RING);
            (Some(tx), Some(rx))
        } else {
            (None, None)
        };
        Rings {
            outputs: OutputRings {
                arm: ArmHandoff::new(arm),
                events,
                recorded,
                outputs: Vec::new(),
            },
            records,
            arm: arm_rx,
            telemetry: TelemetryRings {
                records: record_rx,
                events: event_rx,
                recorded_commands: recorded_rx,
            },
        }
    }
}
