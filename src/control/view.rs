//! What the user can see of the core on one tick: the display's source of
//! truth. The events say what happened; this says where the user is now
//! (the breath being held and since when, the sequence entered so far,
//! when the matcher decides, the mode, when it returns to selection), so a
//! page opened mid-session, or one that missed an event, shows the truth.
//! `Copy` and small: the control thread puts one in every tick's record.

use crate::control::Tick;
use crate::control::action::Breath;
use crate::control::head::HeadView;
use crate::control::mode::{Direction, Mode, ModeState};
use crate::control::sequence::Sequence;
use crate::control::target::Target;

/// The core's state as the user sees it. `Copy`, RT-safe to build.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CoreView {
    /// The neutral the thresholds are measured from, volts (tracked; moved
    /// by a re-zero).
    pub neutral_volts: f64,
    /// The breath held (confirmed) and the tick it began.
    pub held: Option<(Breath, Tick)>,
    /// The sensor is in fault: nothing is detected, nothing moves.
    pub sensor_faulted: bool,
    /// The sequence entered so far (ASP; empty with scanning).
    pub sequence: Sequence,
    /// When the matcher decides if nothing more is breathed (ASP, with a
    /// sequence entered; a breath held delays it).
    pub decides_at: Option<Tick>,
    /// What that decision selects: the sequence is complete and only
    /// a longer one could still change it (the paper's waiting rule).
    /// `None` with a sequence entered: the decision is a reset.
    pub pending: Option<Target>,
    /// The mode the scan highlights (BSP, in detection mode).
    pub highlighted: Option<Mode>,
    /// Detection mode, or the mode puff and sip move the arm in.
    pub state: ModeState,
    /// The direction commanded this tick.
    pub direction: Direction,
    /// In command mode: the tick it returns to selection if the user
    /// breathes nothing more (a breath held postpones it).
    pub returns_at: Option<Tick>,
    /// A pose is saved for `goto_point`.
    pub saved_point: bool,
    /// The arm has faulted (link lost, pose silent or off the path): the
    /// interface stays in detection mode for good.
    pub arm_faulted: bool,
    /// For a person with gestures, the head (none before the IMU's first
    /// sample, or in its fault).
    pub head: Option<HeadView>,
}

impl CoreView {
    /// The user is in command mode for `mode`.
    pub fn in_mode(&self, mode: Mode) -> bool {
        self.state == ModeState::Command(mode)
    }
}
