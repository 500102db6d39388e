//! An IMU recording played live (`run --sensor csv:IMU.csv`): its samples
//! given to the control loop on their ticks, counted from the loop's first
//! tick, as the IMU would have given them. The samples are in memory
//! before the loop starts, so a read is a step through an array: no
//! thread, no I/O, no allocation on the control thread.

use crate::control::Tick;
use crate::control::imu::{ImuInput, ImuSample};
use crate::sensor::{Prepared, Producer, Reading, Samples, Started};

/// The recording's samples, handed out tick by tick.
#[derive(Debug, Clone)]
pub struct ImuPlayback {
    samples: Vec<(Tick, ImuSample)>,
    /// The next sample to give.
    next: usize,
    /// The recording's tick the loop is at (its first sample's tick on the
    /// first read).
    now: Option<Tick>,
}

impl ImuPlayback {
    /// Plays `samples` (ticks increasing), described as `description`.
    pub fn prepared(description: String, samples: Vec<(Tick, ImuSample)>) -> Prepared<ImuPlayback> {
        Prepared {
            description,
            started: Started {
                samples: ImuPlayback {
                    samples,
                    next: 0,
                    now: None,
                },
                producer: Producer::none(),
            },
        }
    }

    /// Moves to the tick `skipped + 1` on; the newest sample due by then
    /// and how many older ones were passed over.
    fn advance(&mut self, skipped: u64) -> (Option<ImuSample>, u64) {
        let first = self.samples.first().map_or(0, |(t, _)| *t);
        let now = match self.now {
            None => first.saturating_add(skipped),
            Some(t) => t.saturating_add(skipped).saturating_add(1),
        };
        self.now = Some(now);
        let mut newest = None;
        let mut passed = 0;
        while let Some(&(t, sample)) = self.samples.get(self.next) {
            if t > now {
                break;
            }
            passed += u64::from(newest.is_some());
            newest = Some(sample);
            self.next += 1;
        }
        (newest, passed)
    }
}

impl Samples for ImuPlayback {
    /// The sample due on this tick, if one is: the IMU's rate is its own.
    fn try_read(&mut self, skipped: u64) -> Reading {
        let (newest, discarded) = self.advance(skipped);
        Reading {
            imu: newest.map_or(ImuInput::Missing, ImuInput::Sample),
            discarded,
            ..Reading::default()
        }
    }

    /// After a stall: every sample of the gap passed over.
    fn discard_backlog(&mut self, skipped: u64) -> u64 {
        let (newest, passed) = self.advance(skipped);
        passed + u64::from(newest.is_some())
    }

    /// Every sample given.
    fn ended(&self) -> bool {
        self.next >= self.samples.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(x: f64) -> ImuSample {
        ImuSample {
            values: [x, 0.0, 9.8, 0.0, 0.0, 0.0],
        }
    }

    #[test]
    fn samples_come_on_their_ticks_and_a_skip_passes_over_the_older() {
        let recording: Vec<(Tick, ImuSample)> =
            (0..5).map(|i| (100 + i * 10, sample(i as f64))).collect();
        let mut p = ImuPlayback::prepared("test".into(), recording)
            .started
            .samples;
        let read = |p: &mut ImuPlayback, skipped| {
            let r = p.try_read(skipped);
            (r.imu, r.discarded)
        };
        assert_eq!(read(&mut p, 0), (ImuInput::Sample(sample(0.0)), 0));
        for _ in 0..9 {
            assert_eq!(read(&mut p, 0), (ImuInput::Missing, 0));
        }
        assert_eq!(read(&mut p, 0), (ImuInput::Sample(sample(1.0)), 0));
        // 20 ticks skipped: at tick 131, samples 2 (120) and 3 (130) due.
        assert_eq!(read(&mut p, 20), (ImuInput::Sample(sample(3.0)), 1));
        assert!(!p.ended());
        assert_eq!(p.discard_backlog(20), 1);
        assert!(p.ended());
    }
}
