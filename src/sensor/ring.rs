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
    let reading = Arc::new(AtomicBool::new(false));
    (
        SampleFeed {
            tx,
            finished: finished.clone(),
            reading: reading.clone(),
        },
        RingSamples {
            rx,
            finished,
            reading,
        },
    )
}

/// How often a producer looks whether the control thread reads yet.
const READER_POLL: std::time::Duration = std::time::Duration::from_micros(100);

/// The producer's end. Dropping it marks the sensor as ended.
pub struct SampleFeed {
    tx: rtrb::Producer<f64>,
    finished: Arc<AtomicBool>,
    reading: Arc<AtomicBool>,
}

impl SampleFeed {
    /// Pushes a sample; `false` if the ring was full and it was dropped.
    pub fn push(&mut self, volts: f64) -> bool {
        self.tx.push(volts).is_ok()
    }

    /// Returns once the control thread reads the ring (its first tick),
    /// or `stop` is set: a recording played from then on starts with the
    /// loop, instead of piling up rows meanwhile that the first tick
    /// would throw away.
    pub fn wait_for_reader(&self, stop: &AtomicBool) {
        while !self.reading.load(Ordering::Acquire) && !stop.load(Ordering::Relaxed) {
            std::thread::sleep(READER_POLL);
        }
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
    /// Told to the producer on the first read.
    reading: Arc<AtomicBool>,
}

impl RingSamples {
    /// Tells the producer the control thread reads (once: later ticks
    /// only load the flag).
    fn mark_reading(&self) {
        if !self.reading.load(Ordering::Relaxed) {
            self.reading.store(true, Ordering::Release);
        }
    }
}

impl Samples for RingSamples {
    fn try_read(&mut self, skipped: u64) -> Reading {
        self.mark_reading();
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
        self.mark_reading();
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
    fn a_producer_waits_for_the_loops_first_read() {
        let (feed, mut samples) = ring(16);
        let stop = AtomicBool::new(false);
        let producer = std::thread::spawn(move || {
            feed.wait_for_reader(&stop);
            feed
        });
        // Only the first read lets the producer go on.
        assert_eq!(samples.try_read(0), Reading::default());
        let mut feed = producer.join().unwrap();
        feed.push(1.0);
        assert_eq!(samples.try_read(0).sample, Sample::Volts(1.0));
        // A stopped sensor does not wait.
        let (feed, _samples) = ring(16);
        feed.wait_for_reader(&AtomicBool::new(true));
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
