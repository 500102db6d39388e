//! The lock-free path of a device IMU's samples: its reader thread pushes
//! each sample ([`ImuFeed`]); the control thread takes the newest each
//! tick ([`ImuRing`]; those it passes over are counted as discarded) and
//! is told `Lost` once the reader has ended (the device gone), so the
//! core faults at once and the run ends.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::control::imu::{ImuInput, ImuSample};
use crate::sensor::{Reading, Samples};

/// Samples the ring holds: 256 ms at 1 kHz, 2.5 s at 100 Hz; the control
/// thread takes them every tick.
pub const RING: usize = 256;

/// A new ring: the reader thread's side and the control thread's.
pub fn imu_ring() -> (ImuFeed, ImuRing) {
    let (producer, consumer) = rtrb::RingBuffer::new(RING);
    let lost = Arc::new(AtomicBool::new(false));
    (
        ImuFeed {
            producer,
            lost: lost.clone(),
        },
        ImuRing {
            consumer,
            lost,
            said_lost: false,
        },
    )
}

/// The reader thread's side. Dropping it (the reader ended: the device
/// is gone, or the run stops) tells the control thread the IMU is lost.
pub struct ImuFeed {
    producer: rtrb::Producer<ImuSample>,
    lost: Arc<AtomicBool>,
}

impl ImuFeed {
    /// Queues `sample`. A full ring drops it: the control thread is far
    /// behind and counts the gap as discarded samples when it catches up.
    pub fn push(&mut self, sample: ImuSample) {
        let _ = self.producer.push(sample);
    }
}

impl Drop for ImuFeed {
    fn drop(&mut self) {
        self.lost.store(true, Ordering::Release);
    }
}

/// The control thread's side: the newest sample queued, or `Lost` once
/// the reader has ended. RT-safe.
pub struct ImuRing {
    consumer: rtrb::Consumer<ImuSample>,
    lost: Arc<AtomicBool>,
    /// The core has been told the IMU is gone.
    said_lost: bool,
}

impl ImuRing {
    /// The newest sample queued and how many older ones were passed over.
    fn newest(&mut self) -> (Option<ImuSample>, u64) {
        let mut newest = None;
        let mut passed = 0;
        while let Ok(sample) = self.consumer.pop() {
            passed += u64::from(newest.is_some());
            newest = Some(sample);
        }
        (newest, passed)
    }
}

impl Samples for ImuRing {
    fn try_read(&mut self, _skipped: u64) -> Reading {
        let (newest, discarded) = self.newest();
        let imu = match newest {
            Some(sample) => ImuInput::Sample(sample),
            None if self.lost.load(Ordering::Acquire) => {
                self.said_lost = true;
                ImuInput::Lost
            }
            None => ImuInput::Missing,
        };
        Reading {
            imu,
            discarded,
            ..Reading::default()
        }
    }

    fn discard_backlog(&mut self, _skipped: u64) -> u64 {
        let (newest, passed) = self.newest();
        passed + u64::from(newest.is_some())
    }

    /// The device is gone and the core has been told (it faulted): the
    /// run ends, as with a breath sensor unplugged.
    fn ended(&self) -> bool {
        self.said_lost
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(v: f64) -> ImuSample {
        ImuSample {
            values: [v, 0.0, 9.8, 0.0, 0.0, 0.0],
        }
    }

    #[test]
    fn the_newest_sample_is_read_and_the_reader_ending_is_a_loss() {
        let (mut feed, mut ring) = imu_ring();
        assert_eq!(ring.try_read(0).imu, ImuInput::Missing);
        feed.push(sample(1.0));
        feed.push(sample(2.0));
        let reading = ring.try_read(0);
        assert_eq!(reading.imu, ImuInput::Sample(sample(2.0)));
        assert_eq!(reading.discarded, 1);
        feed.push(sample(3.0));
        drop(feed);
        // What was queued before the end is still given, then the loss.
        assert_eq!(ring.try_read(0).imu, ImuInput::Sample(sample(3.0)));
        assert!(!ring.ended());
        assert_eq!(ring.try_read(0).imu, ImuInput::Lost);
        assert!(ring.ended());
    }
}
