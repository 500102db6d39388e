//! A breath sensor and a head-worn IMU read side by side (`run --sensor
//! BREATH --imu IMU`), so one library can mix breaths and gestures: each
//! tick's reading takes the breath sample from the one and the IMU's
//! input from the other. Either sensor ending ends the run (its fault has
//! stopped the arm already); both producers stop together.

use crate::sensor::imu_sensor::{ImuSamples, ImuSensor};
use crate::sensor::{Reading, Samples, Sensor, SensorError, Started};

/// A breath sensor with an IMU beside it. The IMU starts after the
/// breath sensor (whose neutral may be measured first), so its samples
/// are not queued through the measurement.
pub struct WithImu<B> {
    breath: B,
    imu: ImuSensor,
}

impl<B: Sensor> WithImu<B> {
    /// `breath` with `imu` beside it.
    pub fn new(breath: B, imu: ImuSensor) -> Self {
        WithImu { breath, imu }
    }
}

impl<B: Sensor> Sensor for WithImu<B> {
    type Samples = BothSamples<B::Samples>;

    fn describe(&self) -> String {
        format!(
            "{}; beside it the IMU {}",
            self.breath.describe(),
            self.imu.describe()
        )
    }

    fn start(self) -> Result<Started<Self::Samples>, SensorError> {
        let breath = self.breath.start()?;
        match self.imu.start() {
            Ok(imu) => Ok(Started {
                samples: BothSamples {
                    breath: breath.samples,
                    imu: imu.samples,
                },
                producer: breath.producer.and(imu.producer),
            }),
            Err(e) => {
                // The breath sensor's reader ends before the error is said.
                let _ = breath.producer.stop();
                Err(e)
            }
        }
    }
}

/// The control thread's side of both sensors. RT-safe.
pub struct BothSamples<B> {
    breath: B,
    imu: ImuSamples,
}

impl<B: Samples> Samples for BothSamples<B> {
    /// The breath sample and the IMU's input due on this tick; what each
    /// threw away to catch up, counted together.
    fn try_read(&mut self, skipped: u64) -> Reading {
        let breath = self.breath.try_read(skipped);
        let imu = self.imu.try_read(skipped);
        Reading {
            sample: breath.sample,
            imu: imu.imu,
            discarded: breath.discarded.saturating_add(imu.discarded),
        }
    }

    fn discard_backlog(&mut self, skipped: u64) -> u64 {
        let breath = self.breath.discard_backlog(skipped);
        breath.saturating_add(self.imu.discard_backlog(skipped))
    }

    /// Either sensor ended: a recording ran out or a device is gone.
    fn ended(&self) -> bool {
        self.breath.ended() || self.imu.ended()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::imu::{Channels, ImuInput, ImuSample};
    use crate::control::sample::Sample;
    use crate::sensor::imu_playback::ImuPlayback;
    use crate::sensor::{Prepared, Producer};

    /// A breath sensor giving `volts` on tick `i`, ended after them.
    struct Volts(Vec<f64>, usize);

    impl Samples for Volts {
        fn try_read(&mut self, skipped: u64) -> Reading {
            self.1 += skipped as usize;
            let sample = self
                .0
                .get(self.1)
                .map_or(Sample::Missing, |v| Sample::Volts(*v));
            self.1 += 1;
            Reading {
                sample,
                discarded: skipped,
                ..Reading::default()
            }
        }

        fn discard_backlog(&mut self, skipped: u64) -> u64 {
            self.1 += skipped as usize;
            skipped
        }

        fn ended(&self) -> bool {
            self.1 >= self.0.len()
        }
    }

    fn both(volts: &[f64], imu: &[(u64, f64)]) -> BothSamples<Volts> {
        let samples = imu
            .iter()
            .map(|(t, x)| {
                let values = [*x, 0.0, 9.8, 0.0, 0.0, 0.0];
                (*t, ImuSample { values })
            })
            .collect();
        let imu = ImuSensor::Playback {
            playback: ImuPlayback::prepared("imu".into(), samples),
            channels: Channels::ALL,
        };
        let breath = Prepared {
            description: "breath".into(),
            started: Started {
                samples: Volts(volts.to_vec(), 0),
                producer: Producer::none(),
            },
        };
        WithImu::new(breath, imu).start().unwrap().samples
    }

    #[test]
    fn each_tick_gives_the_breath_sample_and_the_imus_input_together() {
        let mut s = both(&[2.5, 2.6, 2.7, 2.8], &[(10, 1.0), (12, 2.0), (13, 3.0)]);
        let read = |s: &mut BothSamples<Volts>, skipped| {
            let r = s.try_read(skipped);
            let x = match r.imu {
                ImuInput::Sample(sample) => Some(sample.values[0]),
                _ => None,
            };
            (r.sample, x, r.discarded)
        };
        assert_eq!(read(&mut s, 0), (Sample::Volts(2.5), Some(1.0), 0));
        assert_eq!(read(&mut s, 0), (Sample::Volts(2.6), None, 0));
        // A tick skipped: the breath's sample of it and the IMU's older
        // sample are both thrown away, counted together.
        assert_eq!(read(&mut s, 1), (Sample::Volts(2.8), Some(3.0), 2));
        assert!(s.ended(), "the breath sensor ran out, so the pair ends");
    }

    #[test]
    fn the_pair_ends_when_the_imu_runs_out_first() {
        let mut s = both(&[2.5; 10], &[(0, 1.0)]);
        assert!(!s.ended());
        let _ = s.try_read(0);
        assert!(s.ended());
        assert!(!s.breath.ended());
    }
}
