//! `--sensor iio:/sys/bus/iio/devices/iio:deviceN` (the device's
//! directory) for a head-worn IMU the kernel drives through its IIO
//! subsystem (an MPU-6050, a BMI160, an LSM6DS3 on I2C or SPI).
//!
//! The channels are `in_accel_{x,y,z}_raw` and `in_anglvel_{x,y,z}_raw`;
//! each value is (raw + `_offset`) × `_scale`, from the channel's own
//! files or its type's shared ones (`in_accel_scale`), in the IIO ABI's
//! units: m/s² and rad/s, the units of the IMU CSV. A reader thread
//! queues each sample on the IMU ring
//! ([`imu_ring`](crate::sensor::imu_ring)), read one of two ways:
//!
//! - sysfs (the default): every channel `[sensor.iio] rate_hz` times a
//!   second with `pread` on files kept open, on absolute deadlines. Each
//!   read is a bus transfer: six of them keep about 1 kHz on a fast bus,
//!   a few hundred a second on a 100 kHz I2C one.
//! - `buffered = true`: the device's buffer
//!   ([`iio_buffer`](crate::sensor::iio_buffer)), which the kernel fills
//!   at each firing of its trigger (its data-ready interrupt), at the
//!   device's own rate.
//!
//! A read failing (the device unbound) ends the reader: the IMU lost, a
//! fault at once.

use std::fs::File;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;

use crate::clock::MonotonicClock;
use crate::control::imu::{CHANNELS, Channel, Channels, ImuSample};
use crate::sensor::iio::{PERMISSION_FIX, channel_attribute, read_raw};
use crate::sensor::iio_buffer::IioBuffer;
use crate::sensor::imu_ring::{ImuRing, imu_ring};
use crate::sensor::pacer::Pacer;
use crate::sensor::settings::IioSettings;
use crate::sensor::{Producer, Sensor, SensorError, Started};

/// The sysfs name of a channel's value: `in_accel_x` … `in_anglvel_z`.
fn channel_name(channel: Channel) -> &'static str {
    match channel {
        Channel::Ax => "in_accel_x",
        Channel::Ay => "in_accel_y",
        Channel::Az => "in_accel_z",
        Channel::Gx => "in_anglvel_x",
        Channel::Gy => "in_anglvel_y",
        Channel::Gz => "in_anglvel_z",
    }
}

/// The shared attributes' prefix of a channel's type: `in_accel` or
/// `in_anglvel`.
fn type_name(channel: Channel) -> &'static str {
    if channel.is_acceleration() {
        "in_accel"
    } else {
        "in_anglvel"
    }
}

/// One channel's conversion: value = (raw + offset) × scale.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChannelScale {
    /// SI units per count (`_scale`).
    pub scale: f64,
    /// Counts added before scaling (`_offset`, usually 0).
    pub offset: f64,
}

impl ChannelScale {
    /// The value of a raw reading.
    pub fn value(&self, raw: i64) -> f64 {
        (raw as f64 + self.offset) * self.scale
    }
}

/// The IMU channels an IIO device's directory has, each with its scale
/// and offset; an error if it has none, or a channel without a usable
/// scale.
pub fn imu_channels(dir: &Path) -> Result<Vec<(Channel, ChannelScale)>, String> {
    let mut found = Vec::new();
    for channel in Channel::ALL {
        let name = channel_name(channel);
        if !dir.join(format!("{name}_raw")).exists() {
            continue;
        }
        let attribute = |what: &str| {
            channel_attribute(dir, name, type_name(channel), what)
                .transpose()
                .map_err(|e| format!("{name}: cannot read its {what}: {e}"))
        };
        let Some(scale) = attribute("scale")? else {
            return Err(format!(
                "no {name}_scale or {}_scale: its units are unknown",
                type_name(channel)
            ));
        };
        if !(scale.is_finite() && scale > 0.0) {
            return Err(format!("{name}: its scale is {scale}"));
        }
        let offset = attribute("offset")?.unwrap_or(0.0);
        found.push((channel, ChannelScale { scale, offset }));
    }
    if found.is_empty() {
        return Err(
            "it has no in_accel_*_raw or in_anglvel_*_raw: not an IMU (an ADC channel is given by its in_voltageN_raw file)"
                .to_string(),
        );
    }
    Ok(found)
}

/// Whether an IIO device's directory holds IMU channels.
pub fn is_imu(dir: &Path) -> bool {
    Channel::ALL
        .into_iter()
        .any(|c| dir.join(format!("{}_raw", channel_name(c))).exists())
}

/// An opened IIO IMU: each channel's file, kept open, and its scale;
/// its buffer set up and enabled when it is read buffered.
pub struct IioImu {
    dir: PathBuf,
    rate_hz: u32,
    channels: Vec<(Channel, ChannelScale, File)>,
    buffer: Option<IioBuffer>,
    first: ImuSample,
}

/// How long the first scan of a buffer may take: a trigger that has not
/// fired by then is not firing.
const FIRST_SCAN_MS: i32 = 1000;

/// The sample of one scan's raw values, in the order of `scales`.
fn scan_sample(scales: &[(Channel, ChannelScale)], raws: &[i64]) -> ImuSample {
    let mut values = [0.0; CHANNELS];
    for ((channel, scale), raw) in scales.iter().zip(raws) {
        if let Some(v) = values.get_mut(channel.index()) {
            *v = scale.value(*raw);
        }
    }
    ImuSample { values }
}

impl IioImu {
    /// Opens the device's IMU channels and reads one sample.
    pub fn open(dir: &Path, settings: &IioSettings) -> Result<IioImu, SensorError> {
        let wrong = |message: String| SensorError::WrongDevice {
            device: format!("iio:{}", dir.display()),
            message,
        };
        if !dir.is_dir() {
            return Err(SensorError::NotFound {
                path: dir.to_path_buf(),
            });
        }
        let mut channels = Vec::new();
        for (channel, scale) in imu_channels(dir).map_err(wrong)? {
            let path = dir.join(format!("{}_raw", channel_name(channel)));
            let file = File::open(&path)
                .map_err(|e| SensorError::opening_device(&path, e, PERMISSION_FIX))?;
            channels.push((channel, scale, file));
        }
        let mut imu = IioImu {
            dir: dir.to_path_buf(),
            rate_hz: settings.rate_hz.max(1),
            channels,
            buffer: None,
            first: ImuSample::default(),
        };
        if settings.buffered {
            let node = Path::new("/dev").join(dir.file_name().unwrap_or_default());
            let names: Vec<&str> = imu
                .channels
                .iter()
                .map(|(c, _, _)| channel_name(*c))
                .collect();
            let mut buffer =
                IioBuffer::open(dir, &node, &names, &settings.trigger).map_err(wrong)?;
            let scales = imu.scales();
            let mut first = None;
            let mut waited = 0;
            while first.is_none() && waited < FIRST_SCAN_MS {
                buffer
                    .read(50, |raws| first = Some(scan_sample(&scales, raws)))
                    .map_err(|e| wrong(format!("cannot read its buffer: {e}")))?;
                waited += 50;
            }
            imu.first = first.ok_or_else(|| {
                wrong(format!(
                    "its buffer gave no sample in {} s: is its trigger ({}) firing?",
                    FIRST_SCAN_MS / 1000,
                    buffer.trigger().unwrap_or("none")
                ))
            })?;
            imu.buffer = Some(buffer);
        } else {
            imu.first = imu
                .read()
                .map_err(|e| wrong(format!("cannot read a sample: {e}")))?;
        }
        Ok(imu)
    }

    /// Each channel it gives and its scale.
    fn scales(&self) -> Vec<(Channel, ChannelScale)> {
        self.channels.iter().map(|(c, s, _)| (*c, *s)).collect()
    }

    /// The channels it gives.
    pub fn channels(&self) -> Channels {
        self.channels
            .iter()
            .fold(Channels::NONE, |set, (c, _, _)| set.with(*c))
    }

    /// One sample: every channel read once (a channel it lacks reads 0).
    fn read(&self) -> io::Result<ImuSample> {
        let mut values = [0.0; CHANNELS];
        for (channel, scale, file) in &self.channels {
            if let Some(v) = values.get_mut(channel.index()) {
                *v = scale.value(read_raw(file)?);
            }
        }
        Ok(ImuSample { values })
    }
}

impl Sensor for IioImu {
    type Samples = ImuRing;

    fn describe(&self) -> String {
        match &self.buffer {
            Some(buffer) => format!(
                "iio:{} (IMU {}; its buffer, {}-byte scans, trigger {})",
                self.dir.display(),
                self.channels(),
                buffer.scan_bytes(),
                buffer.trigger().unwrap_or("none: its own FIFO")
            ),
            None => format!(
                "iio:{} (IMU {}; read {} times a second)",
                self.dir.display(),
                self.channels(),
                self.rate_hz
            ),
        }
    }

    fn start(mut self) -> Result<Started<ImuRing>, SensorError> {
        let (mut feed, samples) = imu_ring();
        feed.push(self.first);
        if let Some(mut buffer) = self.buffer.take() {
            let scales = self.scales();
            let producer = Producer::spawn("sensor-iio-imu", move |stop, _log| {
                while !stop.load(Ordering::Relaxed) {
                    // A read failing (the device unbound) ends the reader:
                    // `feed` dropped tells the control thread the IMU is
                    // lost; `buffer` dropped disables the buffer.
                    if buffer
                        .read(100, |raws| feed.push(scan_sample(&scales, raws)))
                        .is_err()
                    {
                        break;
                    }
                }
                Ok(())
            })?;
            return Ok(Started { samples, producer });
        }
        let producer = Producer::spawn("sensor-iio-imu", move |stop, log| {
            // Behind (a slow read): from now, no burst of catch-up reads.
            let mut pacer = Pacer::new(
                MonotonicClock,
                1_000_000_000 / u64::from(self.rate_hz),
                false,
            );
            log.due_on("its read's deadline");
            while !stop.load(Ordering::Relaxed) {
                log.woke(pacer.wait());
                // A read failing (the device unbound) ends the reader:
                // `feed` dropped tells the control thread the IMU is lost.
                let Ok(sample) = self.read() else {
                    break;
                };
                feed.push(sample);
            }
            Ok(())
        })?;
        Ok(Started { samples, producer })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::imu::ImuInput;
    use crate::sensor::Samples;

    /// A directory laid out as sysfs lays out an MPU-6050's.
    fn device(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("sipnpuff-iio-imu-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn an_iio_imu_is_read_in_si_units_with_its_scales_and_offsets() {
        let dir = device("mpu");
        // ±2 g: 0.000598 m/s² a count; ±250 °/s: 0.000133 rad/s a count.
        for (file, value) in [
            ("in_accel_x_raw", "-100\n"),
            ("in_accel_y_raw", "0\n"),
            ("in_accel_z_raw", "16384\n"),
            ("in_accel_scale", "0.000598\n"),
            ("in_anglvel_x_raw", "250\n"),
            ("in_anglvel_y_raw", "-7\n"),
            ("in_anglvel_z_raw", "0\n"),
            ("in_anglvel_scale", "0.000133090\n"),
            ("in_anglvel_z_offset", "10\n"),
            ("in_temp_raw", "1\n"),
        ] {
            std::fs::write(dir.join(file), value).unwrap();
        }
        assert!(is_imu(&dir));
        let imu = IioImu::open(&dir, &IioSettings::default()).unwrap();
        assert_eq!(imu.channels(), Channels::ALL);
        assert_eq!(
            imu.first.values,
            [
                -100.0 * 0.000598,
                0.0,
                16384.0 * 0.000598,
                250.0 * 0.000133090,
                -7.0 * 0.000133090,
                10.0 * 0.000133090
            ]
        );
        assert!(
            imu.describe()
                .contains("IMU ax,ay,az,gx,gy,gz; read 1000 times")
        );
        // Started: the first sample is there at once; the reader goes on.
        let mut started = imu.start().unwrap();
        assert!(matches!(
            started.samples.try_read(0).imu,
            ImuInput::Sample(_)
        ));
        started.producer.stop().unwrap();
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn a_device_without_imu_channels_or_units_is_refused_saying_why() {
        let dir = device("adc");
        std::fs::write(dir.join("in_voltage0_raw"), "1\n").unwrap();
        assert!(!is_imu(&dir));
        let e = IioImu::open(&dir, &IioSettings::default())
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("not an IMU"), "{e}");
        std::fs::write(dir.join("in_accel_x_raw"), "1\n").unwrap();
        let e = IioImu::open(&dir, &IioSettings::default())
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("no in_accel_x_scale or in_accel_scale"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
