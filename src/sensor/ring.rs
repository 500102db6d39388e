//! The bounded ring between a sensor's producer thread and the control
//! thread. The producer never blocks either: when the ring is full the
//! sample is dropped (the loop is behind; it would discard old samples
//! anyway). Each tick the control thread takes one sample (after skipped
//! ticks, the last of theirs and its own: the others are stale), then
//! discards what piled up beyond two, counted: a producer running ahead
//! adds at most 2 ms of latency. After a stall the whole backlog is
//! discarded, counted.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use rtrb::RingBuffer;

use crate::control::sample::Sample;
use crate::sensor::{Reading, Samples};

/// Samples the ring holds: one second at 1 kHz.
pub const SAMPLE_RING: usize = 1024;

/// Samples left queued after a read; more are discarded (a sensor running
/// ahead of the loop must not add latency).
const MAX_QUEUED: usize = 2;

/// A ring of `capacity` samples: the producer's end and the control
/// thread's end.
pub fn ring(capacity: usize) -> (SampleFeed, RingSamples) {
    let (tx, rx) = RingBuffer::new(capacity);
    let finished = Arc::new(AtomicBool::new(false));
    (
        SampleFeed {
            tx,
            finished: finished.clone(),
        },
        RingSamples { rx, finished },
    )
}

/// The producer's end. Dropping it marks the sensor as ended.
pub struct SampleFeed {
    tx: rtrb::Producer<f64>,
    finished: Arc<AtomicBool>,
}

impl SampleFeed {
    /// Pushes a sample; `false` if the ring was full and it was dropped.
    pub fn push(&mut self, volts: f64) -> bool {
        self.tx.push(volts).is_ok()
    }
}

impl Drop for SampleFeed {
    fn drop(&mut self) {
        self.finished.store(true, Ordering::Release);
    }
}

/// The control thread's end.
pub struct RingSamples {
    rx: rtrb::Consumer<f64>,
    finished: Arc<AtomicBool>,
}

impl Samples for RingSamples {
    fn try_read(&mut self, skipped: u64) -> Reading {
        // One sample per tick; after skipped ticks, their samples are
        // stale: keep the last of those taken.
        let mut reading = Reading::default();
        for _ in 0..=skipped {
            match self.rx.pop() {
                Ok(v) => reading.sample = Sample::Volts(v),
                Err(_) => break,
            }
        }
        // A sensor running ahead: drop what piled up, counted.
        while self.rx.slots() > MAX_QUEUED {
            if self.rx.pop().is_ok() {
                reading.discarded += 1;
            }
        }
        reading
    }

    fn discard_backlog(&mut self, _skipped: u64) -> u64 {
        let mut discarded = 0;
        while self.rx.pop().is_ok() {
            discarded += 1;
        }
        discarded
    }

    fn ended(&self) -> bool {
        self.finished.load(Ordering::Acquire) && self.rx.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn skipped_samples_are_stale_and_a_backlog_is_counted() {
        let (mut feed, mut samples) = ring(16);
        assert_eq!(samples.try_read(0), Reading::default());
        for v in [1.0, 2.0, 3.0] {
            assert!(feed.push(v));
        }
        // Two ticks were skipped: their samples and this one's, the last wins.
        assert_eq!(samples.try_read(2).sample, Sample::Volts(3.0));
        for v in 0..8 {
            feed.push(f64::from(v));
        }
        let r = samples.try_read(0);
        assert_eq!((r.sample, r.discarded), (Sample::Volts(0.0), 5));
        assert!(!samples.ended());
        drop(feed);
        assert!(!samples.ended(), "two samples still queued");
        samples.try_read(1);
        assert!(samples.ended());
    }

    #[test]
    fn a_stall_discards_the_whole_backlog_counted() {
        let (mut feed, mut samples) = ring(16);
        for v in 0..10 {
            feed.push(f64::from(v));
        }
        assert_eq!(samples.discard_backlog(2000), 10);
        assert_eq!(samples.try_read(0), Reading::default());
        feed.push(7.0);
        assert_eq!(
            samples.try_read(0).sample,
            Sample::Volts(7.0),
            "fresh samples after"
        );
    }
}
