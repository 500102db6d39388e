//! A head-worn IMU, whichever backend reads it: one type for the run to
//! start, alone or beside a breath sensor ([`with_imu`](super::with_imu)).

use crate::control::imu::Channels;
use crate::sensor::evdev::imu::EvdevImu;
use crate::sensor::iio_imu::IioImu;
use crate::sensor::imu_playback::ImuPlayback;
use crate::sensor::imu_ring::ImuRing;
use crate::sensor::serial_imu::SerialImu;
use crate::sensor::{Prepared, Reading, Samples, Sensor, SensorError, Started};

/// An IMU opened, not yet started.
pub enum ImuSensor {
    /// A recording played live.
    Playback {
        /// The recording, read whole.
        playback: Prepared<ImuPlayback>,
        /// The channels it holds.
        channels: Channels,
    },
    /// A microcontroller's stream on a serial port.
    Serial(SerialImu),
    /// An input device with the accelerometer property.
    Evdev(Box<EvdevImu>),
    /// An IIO device's accel and anglvel channels.
    Iio(IioImu),
}

impl ImuSensor {
    /// The channels it gives (checked against the person's set).
    pub fn channels(&self) -> Channels {
        match self {
            ImuSensor::Playback { channels, .. } => *channels,
            ImuSensor::Serial(_) => Channels::ALL,
            ImuSensor::Evdev(device) => device.channels(),
            ImuSensor::Iio(device) => device.channels(),
        }
    }
}

impl Sensor for ImuSensor {
    type Samples = ImuSamples;

    fn describe(&self) -> String {
        match self {
            ImuSensor::Playback { playback, .. } => playback.describe(),
            ImuSensor::Serial(port) => port.describe(),
            ImuSensor::Evdev(device) => device.describe(),
            ImuSensor::Iio(device) => device.describe(),
        }
    }

    fn start(self) -> Result<Started<ImuSamples>, SensorError> {
        let device = |started: Started<ImuRing>| Started {
            samples: ImuSamples::Device(started.samples),
            producer: started.producer,
        };
        match self {
            ImuSensor::Playback { playback, .. } => {
                let started = playback.start()?;
                Ok(Started {
                    samples: ImuSamples::Playback(started.samples),
                    producer: started.producer,
                })
            }
            ImuSensor::Serial(port) => port.start().map(device),
            ImuSensor::Evdev(device_) => (*device_).start().map(device),
            ImuSensor::Iio(device_) => device_.start().map(device),
        }
    }
}

/// The control thread's side of an IMU: a device's ring or a
/// recording's samples. RT-safe.
pub enum ImuSamples {
    /// A device's reader thread fills it.
    Device(ImuRing),
    /// A recording, in memory.
    Playback(ImuPlayback),
}

impl Samples for ImuSamples {
    fn try_read(&mut self, skipped: u64) -> Reading {
        match self {
            ImuSamples::Device(ring) => ring.try_read(skipped),
            ImuSamples::Playback(playback) => playback.try_read(skipped),
        }
    }

    fn discard_backlog(&mut self, skipped: u64) -> u64 {
        match self {
            ImuSamples::Device(ring) => ring.discard_backlog(skipped),
            ImuSamples::Playback(playback) => playback.discard_backlog(skipped),
        }
    }

    fn ended(&self) -> bool {
        match self {
            ImuSamples::Device(ring) => ring.ended(),
            ImuSamples::Playback(playback) => playback.ended(),
        }
    }
}
