//! Sample-and-hold between a device's reader thread and the control
//! thread: the reader stores the latest value whenever the device reports
//! one; the control thread reads whatever is held at each tick.
//!
//! Devices report at their own pace: an evdev axis only when it changes
//! (silence is not staleness), a serial dialect every 50–100 ms, an ADC as
//! fast as it is polled. Holding the latest value turns each of them into
//! the 1 kHz stream the detector needs, with no queue to fall behind: the
//! control thread never waits and never reads an old value after a newer
//! one. What the reader knows about the device travels with the value: no
//! value yet, live, silent (a streaming source stopped sending: the core
//! sees missing samples and faults after `stale_ms`), lost (the device went
//! away: the core faults at once) or ended.

use std::sync::Arc;
use std::sync::atomic::{AtomicU8, AtomicU64, Ordering};

use crate::control::sample::Sample;
use crate::sensor::{Reading, Samples};

/// What the reader knows about the device.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Link {
    /// Opened, no value yet.
    Waiting = 0,
    /// Delivering: the held value is current.
    Live = 1,
    /// A streaming source stopped sending: the held value is stale.
    Silent = 2,
    /// The device went away (unplugged, unbound); the reader may be
    /// waiting for it to come back.
    Lost = 3,
    /// The reader ended for good (stopped, or lost without reconnecting).
    Ended = 4,
}

impl Link {
    fn from_u8(value: u8) -> Link {
        match value {
            0 => Link::Waiting,
            1 => Link::Live,
            2 => Link::Silent,
            3 => Link::Lost,
            _ => Link::Ended,
        }
    }
}

#[derive(Debug)]
struct Shared {
    /// The held value's `f64` bits.
    volts: AtomicU64,
    link: AtomicU8,
    /// Values stored so far (the reader's rate, for the report).
    updates: AtomicU64,
}

/// A hold: the reader's end and the control thread's end.
pub fn hold() -> (Holder, HeldSamples) {
    let shared = Arc::new(Shared {
        volts: AtomicU64::new(0),
        link: AtomicU8::new(Link::Waiting as u8),
        updates: AtomicU64::new(0),
    });
    (
        Holder {
            shared: shared.clone(),
        },
        HeldSamples { shared },
    )
}

/// The reader's end. Dropping it ends the sensor.
#[derive(Debug)]
pub struct Holder {
    shared: Arc<Shared>,
}

impl Holder {
    /// Holds a new value; the device is live.
    pub fn set(&self, volts: f64) {
        // Value first, then the link: a reader that sees `Live` sees a
        // value at least this new.
        self.shared.volts.store(volts.to_bits(), Ordering::Release);
        self.shared.updates.fetch_add(1, Ordering::Relaxed);
        self.shared.link.store(Link::Live as u8, Ordering::Release);
    }

    /// The device's state changed (silent, lost, live again with the held
    /// value).
    pub fn link(&self, link: Link) {
        self.shared.link.store(link as u8, Ordering::Release);
    }

    /// The value held now, if any (for the reader's own checks).
    pub fn current(&self) -> Option<f64> {
        match Link::from_u8(self.shared.link.load(Ordering::Acquire)) {
            Link::Waiting => None,
            _ => Some(f64::from_bits(self.shared.volts.load(Ordering::Acquire))),
        }
    }

    /// Values stored so far.
    pub fn updates(&self) -> u64 {
        self.shared.updates.load(Ordering::Relaxed)
    }
}

impl Drop for Holder {
    fn drop(&mut self) {
        self.link(Link::Ended);
    }
}

/// The control thread's end. RT-safe: two atomic loads per read.
#[derive(Debug)]
pub struct HeldSamples {
    shared: Arc<Shared>,
}

impl HeldSamples {
    /// What the reader says about the device now.
    pub fn link(&self) -> Link {
        Link::from_u8(self.shared.link.load(Ordering::Acquire))
    }

    /// Values the reader has stored so far.
    pub fn updates(&self) -> u64 {
        self.shared.updates.load(Ordering::Relaxed)
    }
}

impl Samples for HeldSamples {
    /// The held value while live; nothing while waiting or silent; `lost`
    /// once the device is gone (the core faults at once).
    fn try_read(&mut self, _skipped: u64) -> Reading {
        match self.link() {
            Link::Live => Reading {
                sample: Sample::Volts(f64::from_bits(self.shared.volts.load(Ordering::Acquire))),
                ..Reading::default()
            },
            Link::Waiting | Link::Silent => Reading::default(),
            Link::Lost | Link::Ended => Reading {
                sample: Sample::Lost,
                ..Reading::default()
            },
        }
    }

    /// Nothing is queued: the next read is the newest value.
    fn discard_backlog(&mut self, _skipped: u64) -> u64 {
        0
    }

    fn ended(&self) -> bool {
        self.link() == Link::Ended
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_latest_value_is_held_until_the_device_says_otherwise() {
        let (holder, mut samples) = hold();
        assert_eq!(samples.try_read(0), Reading::default(), "no value yet");
        holder.set(2.5);
        holder.set(2.75);
        for _ in 0..3 {
            assert_eq!(
                samples.try_read(0).sample,
                Sample::Volts(2.75),
                "held every tick"
            );
        }
        assert_eq!(samples.updates(), 2);
        holder.link(Link::Silent);
        assert_eq!(samples.try_read(0), Reading::default(), "stale: missing");
        holder.link(Link::Lost);
        let lost = samples.try_read(0);
        assert_eq!(lost.sample, Sample::Lost);
        assert!(!samples.ended(), "a lost device may come back");
        holder.set(2.5);
        assert_eq!(samples.try_read(0).sample, Sample::Volts(2.5), "back");
        drop(holder);
        assert!(samples.ended() && samples.try_read(0).sample == Sample::Lost);
    }
}
