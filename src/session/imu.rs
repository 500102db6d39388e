//! A head-worn IMU opened from its `--sensor` (or `--imu`) form, for
//! `run` and for a live `gestures record`.

use crate::config::Config;
use crate::sensor::SensorSpec;
use crate::sensor::evdev::imu::EvdevImu;
use crate::sensor::iio_imu::IioImu;
use crate::sensor::imu_playback::ImuPlayback;
use crate::sensor::imu_sensor::ImuSensor;
use crate::sensor::serial_imu::SerialImu;
use crate::tools::imu_csv::{FULL_HEADER, is_imu_csv, read_imu_csv};

/// Opens the IMU `spec` names and checks it gives every channel
/// `config`'s set was recorded with.
pub fn open_imu_for_set(spec: &SensorSpec, config: &Config) -> anyhow::Result<ImuSensor> {
    let sensor = open_imu(spec, config)?;
    crate::gestures::setup::check_channels(config.core(), &spec.to_string(), sensor.channels())
        .map_err(anyhow::Error::msg)?;
    Ok(sensor)
}

/// Opens the IMU `spec` names, with `config`'s `[sensor]` settings: a
/// recording read whole, a serial port opened and answering (read as
/// `ax,ay,az,gx,gy,gz` lines), an input device with the accelerometer
/// property, an IIO device's accel and anglvel channels.
pub fn open_imu(spec: &SensorSpec, config: &Config) -> anyhow::Result<ImuSensor> {
    let sensor = match spec {
        SensorSpec::Serial { path, baud } => ImuSensor::Serial(
            SerialImu::open(path, *baud, &config.sensor().serial).map_err(anyhow::Error::new)?,
        ),
        SensorSpec::Evdev(target) => ImuSensor::Evdev(Box::new(
            EvdevImu::open(target).map_err(anyhow::Error::new)?,
        )),
        SensorSpec::Iio(dir) => {
            ImuSensor::Iio(IioImu::open(dir, &config.sensor().iio).map_err(anyhow::Error::new)?)
        }
        SensorSpec::Csv(path) => {
            if !is_imu_csv(path) {
                anyhow::bail!(
                    "csv:{}: not an IMU recording (its header must be `tick` and IMU channels, e.g. `{FULL_HEADER}`)",
                    path.display()
                );
            }
            let recording = read_imu_csv(path).map_err(|e| anyhow::anyhow!("{e}"))?;
            ImuSensor::Playback {
                playback: ImuPlayback::prepared(
                    format!(
                        "IMU recording {} ({}, {} samples)",
                        path.display(),
                        recording.channels,
                        recording.samples.len()
                    ),
                    recording.samples,
                ),
                channels: recording.channels,
            }
        }
        SensorSpec::Synthetic(_) => anyhow::bail!(
            "{}: not an IMU: give evdev:name=NAME, iio:/sys/bus/iio/devices/iio:deviceN, serial:PORT or csv:IMU.csv",
            spec
        ),
    };
    Ok(sensor)
}
