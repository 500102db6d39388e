//! The device's events, pure: whole `struct input_event`s parsed from the
//! bytes read, and mapped to volts (an axis linearly, switches as levels).

/// `EV_SYN`, `EV_KEY`, `EV_ABS` and `SYN_DROPPED` from linux/input.h.
pub(super) const EV_SYN: u16 = 0x00;
const EV_KEY: u16 = 0x01;
pub(super) const EV_ABS: u16 = 0x03;
/// `SYN_REPORT`: the end of a frame of events.
pub(super) const SYN_REPORT: u16 = 0;
pub(super) const SYN_DROPPED: u16 = 3;

/// Bytes of one `struct input_event` on 64-bit Linux (timeval, type,
/// code, value).
pub const EVENT_BYTES: usize = 24;

/// One input event: type, code, value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InputEvent {
    /// `EV_*`.
    pub kind: u16,
    /// Axis or key code.
    pub code: u16,
    /// New value (axis position; key 1 down, 0 up, 2 repeat).
    pub value: i32,
}

/// The events in `bytes`, as read from an event node (whole events only;
/// a trailing partial event is ignored).
pub fn parse_events(bytes: &[u8]) -> impl Iterator<Item = InputEvent> + '_ {
    bytes.chunks_exact(EVENT_BYTES).map(|e| InputEvent {
        kind: u16::from_ne_bytes([e[16], e[17]]),
        code: u16::from_ne_bytes([e[18], e[19]]),
        value: i32::from_ne_bytes([e[20], e[21], e[22], e[23]]),
    })
}

/// The time stamp of the first whole event in `bytes`, ns (its `timeval`,
/// on the clock the device was given).
pub fn first_event_ns(bytes: &[u8]) -> Option<u64> {
    let event = bytes.get(..EVENT_BYTES)?;
    let field = |at: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&event[at..at + 8]);
        i64::from_ne_bytes(b)
    };
    let (sec, usec) = (field(0), field(8));
    u64::try_from(
        sec.checked_mul(1_000_000_000)?
            .checked_add(usec.checked_mul(1000)?)?,
    )
    .ok()
}

/// How events become volts: the pure part of the backend.
#[derive(Debug, Clone, PartialEq)]
pub enum Mapping {
    /// One axis, linearly.
    Axis {
        /// The axis code.
        code: u16,
        /// Its reported minimum and maximum.
        range: (i32, i32),
        /// Volts at the minimum and at the maximum.
        volts: (f64, f64),
    },
    /// Keys held as levels.
    Switches {
        /// Codes meaning sip.
        sip: Vec<u16>,
        /// Codes meaning puff.
        puff: Vec<u16>,
        /// Levels at rest, sipping and puffing, volts.
        levels: SwitchLevels,
    },
}

/// The levels switches are held at.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwitchLevels {
    /// Nothing pressed (and both sip and puff pressed: ambiguous, so
    /// nothing moves).
    pub rest: f64,
    /// A sip key down.
    pub sip: f64,
    /// A puff key down.
    pub puff: f64,
}

impl SwitchLevels {
    /// Rest at the detector's neutral, puff at 5 V, sip at 0 V: beyond
    /// every valid threshold and hysteresis band, inside the valid range.
    pub fn around(neutral_volts: f64) -> SwitchLevels {
        SwitchLevels {
            rest: neutral_volts,
            sip: 0.0,
            puff: 5.0,
        }
    }
}

/// Turns a device's events into the level to hold.
#[derive(Debug, Clone)]
pub struct EventMapper {
    mapping: Mapping,
    sip_down: Vec<bool>,
    puff_down: Vec<bool>,
}

impl EventMapper {
    /// A mapper with nothing pressed.
    pub fn new(mapping: Mapping) -> EventMapper {
        let (sip, puff) = match &mapping {
            Mapping::Axis { .. } => (0, 0),
            Mapping::Switches { sip, puff, .. } => (sip.len(), puff.len()),
        };
        EventMapper {
            mapping,
            sip_down: vec![false; sip],
            puff_down: vec![false; puff],
        }
    }

    /// Volts for an axis position.
    pub fn axis_volts(&self, value: i32) -> Option<f64> {
        let Mapping::Axis {
            range: (min, max),
            volts: (at_min, at_max),
            ..
        } = self.mapping
        else {
            return None;
        };
        let span = f64::from(max) - f64::from(min);
        Some(at_min + (f64::from(value) - f64::from(min)) / span * (at_max - at_min))
    }

    /// The level the keys now down stand for (switches), if any.
    pub fn switch_volts(&self) -> Option<f64> {
        let Mapping::Switches { levels, .. } = &self.mapping else {
            return None;
        };
        let sip = self.sip_down.iter().any(|&d| d);
        let puff = self.puff_down.iter().any(|&d| d);
        Some(match (sip, puff) {
            (true, false) => levels.sip,
            (false, true) => levels.puff,
            _ => levels.rest,
        })
    }

    /// Applies one event; the new level if it changed what is held.
    pub fn apply(&mut self, event: InputEvent) -> Option<f64> {
        match (&self.mapping, event.kind) {
            (Mapping::Axis { code, .. }, EV_ABS) if event.code == *code => {
                self.axis_volts(event.value)
            }
            (Mapping::Switches { sip, puff, .. }, EV_KEY) if event.value != 2 => {
                let down = event.value != 0;
                let mut hit = false;
                for (slot, _) in self
                    .sip_down
                    .iter_mut()
                    .zip(sip)
                    .filter(|(_, c)| **c == event.code)
                {
                    *slot = down;
                    hit = true;
                }
                for (slot, _) in self
                    .puff_down
                    .iter_mut()
                    .zip(puff)
                    .filter(|(_, c)| **c == event.code)
                {
                    *slot = down;
                    hit = true;
                }
                if hit { self.switch_volts() } else { None }
            }
            _ => None,
        }
    }

    /// How its events become volts.
    pub fn mapping(&self) -> &Mapping {
        &self.mapping
    }

    /// Sets which keys are down from the device's key state (after
    /// opening, and after the kernel dropped events).
    pub(super) fn set_keys(&mut self, is_down: impl Fn(u16) -> bool) {
        if let Mapping::Switches { sip, puff, .. } = &self.mapping {
            for (slot, code) in self.sip_down.iter_mut().zip(sip) {
                *slot = is_down(*code);
            }
            for (slot, code) in self.puff_down.iter_mut().zip(puff) {
                *slot = is_down(*code);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use evdev::KeyCode;

    use super::*;

    /// An event as the kernel writes it (timestamp, type, code, value).
    fn event_bytes(sec: i64, kind: u16, code: u16, value: i32) -> Vec<u8> {
        let mut b = Vec::new();
        b.extend(sec.to_ne_bytes());
        b.extend(0i64.to_ne_bytes());
        b.extend(kind.to_ne_bytes());
        b.extend(code.to_ne_bytes());
        b.extend(value.to_ne_bytes());
        b
    }

    #[test]
    fn recorded_event_bytes_parse_whole_events_only() {
        let mut bytes = event_bytes(1, EV_ABS, 0, 700);
        bytes.extend(event_bytes(1, EV_SYN, 0, 0));
        bytes.extend([1, 2, 3]); // a partial event
        let events: Vec<_> = parse_events(&bytes).collect();
        assert_eq!(
            events,
            [
                InputEvent {
                    kind: EV_ABS,
                    code: 0,
                    value: 700
                },
                InputEvent {
                    kind: EV_SYN,
                    code: 0,
                    value: 0
                }
            ]
        );
    }

    #[test]
    fn a_batch_is_stamped_with_its_first_events_time() {
        let mut bytes = event_bytes(12, EV_ABS, 0, 700);
        bytes[8..16].copy_from_slice(&345_678i64.to_ne_bytes());
        bytes.extend(event_bytes(13, EV_SYN, 0, 0));
        assert_eq!(first_event_ns(&bytes), Some(12_345_678_000));
        assert_eq!(first_event_ns(&bytes[..EVENT_BYTES - 1]), None);
    }

    #[test]
    fn a_ten_bit_axis_maps_linearly_to_volts() {
        let mut m = EventMapper::new(Mapping::Axis {
            code: 0,
            range: (0, 1023),
            volts: (0.0, 5.0),
        });
        let at = |m: &mut EventMapper, value| {
            m.apply(InputEvent {
                kind: EV_ABS,
                code: 0,
                value,
            })
        };
        assert_eq!(at(&mut m, 0), Some(0.0));
        assert_eq!(at(&mut m, 1023), Some(5.0));
        assert_eq!(at(&mut m, 512), Some(512.0 / 1023.0 * 5.0)); // ≈ 2.502 V
        assert_eq!(
            m.apply(InputEvent {
                kind: EV_ABS,
                code: 1,
                value: 9
            }),
            None,
            "another axis"
        );
        // A signed axis (±4 kPa as -512..511) onto 0.5–4.5 V.
        let m = EventMapper::new(Mapping::Axis {
            code: 0,
            range: (-512, 511),
            volts: (0.5, 4.5),
        });
        assert_eq!(m.axis_volts(-512), Some(0.5));
        assert_eq!(m.axis_volts(511), Some(4.5));
    }

    #[test]
    fn switches_are_levels_and_soft_hard_pairs_both_count() {
        let trigger = KeyCode::BTN_TRIGGER.0;
        let thumb = KeyCode::BTN_THUMB.0;
        let thumb2 = KeyCode::BTN_THUMB2.0;
        let mut m = EventMapper::new(Mapping::Switches {
            sip: vec![trigger],
            puff: vec![thumb, thumb2],
            levels: SwitchLevels::around(2.5),
        });
        let key = |code, value| InputEvent {
            kind: EV_KEY,
            code,
            value,
        };
        assert_eq!(m.apply(key(thumb, 1)), Some(5.0), "soft puff");
        assert_eq!(m.apply(key(thumb2, 1)), Some(5.0), "hard puff too");
        assert_eq!(m.apply(key(thumb, 0)), Some(5.0), "hard still down");
        assert_eq!(m.apply(key(thumb2, 2)), None, "auto-repeat changes nothing");
        assert_eq!(m.apply(key(thumb2, 0)), Some(2.5), "released");
        assert_eq!(m.apply(key(trigger, 1)), Some(0.0), "sip");
        assert_eq!(m.apply(key(thumb, 1)), Some(2.5), "both: ambiguous, rest");
        assert_eq!(m.apply(key(trigger, 0)), Some(5.0));
        assert_eq!(m.apply(key(KeyCode::KEY_A.0, 1)), None, "another key");
    }
}
