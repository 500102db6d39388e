//! `--sensor iio:/sys/bus/iio/devices/iio:deviceN/in_voltageM_raw`: an
//! analog pressure sensor on an ADC that the kernel drives through its IIO
//! subsystem (the ADS1115 on I2C, the MCP3008 on SPI, a SoC's own ADC).
//!
//! volts = (raw + `_offset`) × `_scale` (mV) ÷ 1000 × `gain` +
//! `offset_volts`, from the channel's own `_scale` and `_offset` files
//! (`in_voltageM_scale` or the shared `in_voltage_scale`), then the
//! configured linear map (a 3.3 V ADC behind a divider).
//!
//! A reader thread reads the value `rate_hz` times a second with `pread`
//! on a file kept open (10–20 µs a read; open+read+close costs ~120 µs)
//! and holds it ([`held`](super::held)). A read failing (the device
//! unbound: `ENODEV`) is a fault; with `sensor.reconnect` the file is
//! opened again when it is back.

use std::fs::File;
use std::io;
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use crate::clock::MonotonicClock;
use crate::sensor::device::{self, DeviceReader};
use crate::sensor::held::{HeldSamples, Holder, hold};
use crate::sensor::pacer::Pacer;
use crate::sensor::settings::IioSettings;
use crate::sensor::{Producer, Sensor, SensorError, Started};
use crate::wakes::WakeLog;

/// What permission problems on IIO files need.
pub const PERMISSION_FIX: &str = "IIO sysfs files are usually readable by all; if not, run as root or add a udev rule, e.g. SUBSYSTEM==\"iio\", RUN+=\"/bin/chmod a+r /sys%p/in_voltage0_raw\"";

/// How a channel's raw value becomes volts: the pure part.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Conversion {
    /// Millivolts per count (the channel's `_scale`).
    pub scale_mv: f64,
    /// Counts added before scaling (the channel's `_offset`, usually 0).
    pub raw_offset: f64,
    /// The configured gain.
    pub gain: f64,
    /// The configured offset, volts.
    pub offset_volts: f64,
}

impl Conversion {
    /// Volts for a raw reading.
    pub fn volts(&self, raw: i64) -> f64 {
        (raw as f64 + self.raw_offset) * self.scale_mv / 1000.0 * self.gain + self.offset_volts
    }
}

/// A sysfs value as the kernel prints it: an integer and a newline.
pub fn parse_raw(bytes: &[u8]) -> Result<i64, String> {
    let text = std::str::from_utf8(bytes).map_err(|_| "not text".to_string())?;
    text.trim()
        .parse()
        .map_err(|_| format!("{:?} is not an integer", text.trim()))
}

/// Reads a sysfs number file (`_scale`, `_offset`).
fn read_number(path: &Path) -> io::Result<f64> {
    let text = std::fs::read_to_string(path)?;
    text.trim().parse().map_err(|_| {
        io::Error::new(
            io::ErrorKind::InvalidData,
            format!("{:?} is not a number", text.trim()),
        )
    })
}

/// A channel's attribute `what` (`scale`, `offset`) in the device's
/// directory `dir`: the channel's own file (`{channel}_{what}`), else its
/// type's shared one (`{shared}_{what}`), read; `None` when neither exists.
pub(crate) fn channel_attribute(
    dir: &Path,
    channel: &str,
    shared: &str,
    what: &str,
) -> Option<io::Result<f64>> {
    [format!("{channel}_{what}"), format!("{shared}_{what}")]
        .into_iter()
        .map(|f| dir.join(f))
        .find(|p| p.exists())
        .map(|p| read_number(&p))
}

/// The channel's `_scale` and `_offset` (its own files, else the type's
/// shared ones): `in_voltage0_raw` → `in_voltage0_scale` or
/// `in_voltage_scale`.
fn channel_files(raw: &Path) -> Result<(f64, f64), String> {
    let name = raw
        .file_name()
        .and_then(|n| n.to_str())
        .and_then(|n| n.strip_suffix("_raw"))
        .ok_or_else(|| "not a channel's `_raw` file (e.g. in_voltage0_raw)".to_string())?;
    let dir = raw.parent().unwrap_or(Path::new("."));
    // `in_voltage0` → `in_voltage`: the shared attribute's prefix.
    let shared = name.trim_end_matches(|c: char| c.is_ascii_digit());
    let find = |what: &str| channel_attribute(dir, name, shared, what);
    let scale = match find("scale") {
        Some(Ok(scale)) if scale.is_finite() && scale > 0.0 => scale,
        Some(Ok(scale)) => return Err(format!("its scale is {scale} mV per count")),
        Some(Err(e)) => return Err(format!("cannot read its scale: {e}")),
        None => {
            return Err(format!(
                "no {name}_scale or {shared}_scale beside it: not a voltage channel?"
            ));
        }
    };
    let offset = match find("offset") {
        Some(Ok(offset)) if offset.is_finite() => offset,
        Some(Ok(_)) | None => 0.0,
        Some(Err(e)) => return Err(format!("cannot read its offset: {e}")),
    };
    Ok((scale, offset))
}

/// An opened ADC channel.
pub struct IioSensor {
    path: PathBuf,
    settings: IioSettings,
    reconnect: bool,
    file: File,
    conversion: Conversion,
    first_raw: i64,
}

impl IioSensor {
    /// Opens the channel, reads its scale and one value.
    pub fn open(
        path: &Path,
        settings: &IioSettings,
        reconnect: bool,
    ) -> Result<IioSensor, SensorError> {
        if settings.buffered {
            return Err(SensorError::WrongDevice {
                device: path.display().to_string(),
                message: "[sensor.iio] buffered is for an IMU; a pressure channel is read through sysfs (its ADC converts at most a few hundred times a second): set buffered = false".to_string(),
            });
        }
        let file =
            File::open(path).map_err(|e| SensorError::opening_device(path, e, PERMISSION_FIX))?;
        let (scale_mv, raw_offset) =
            channel_files(path).map_err(|message| SensorError::WrongDevice {
                device: path.display().to_string(),
                message,
            })?;
        let first_raw = read_raw(&file).map_err(|e| SensorError::WrongDevice {
            device: path.display().to_string(),
            message: format!("cannot read a value: {e}"),
        })?;
        Ok(IioSensor {
            path: path.to_path_buf(),
            settings: settings.clone(),
            reconnect,
            file,
            conversion: Conversion {
                scale_mv,
                raw_offset,
                gain: settings.gain,
                offset_volts: settings.offset_volts,
            },
            first_raw,
        })
    }

    /// How raw readings become volts.
    pub fn conversion(&self) -> Conversion {
        self.conversion
    }
}

/// One `pread` of the whole value.
pub(crate) fn read_raw(file: &File) -> io::Result<i64> {
    let mut buffer = [0u8; 32];
    let n = file.read_at(&mut buffer, 0)?;
    parse_raw(&buffer[..n]).map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e))
}

impl Sensor for IioSensor {
    type Samples = HeldSamples;

    fn describe(&self) -> String {
        let c = self.conversion;
        format!(
            "iio:{} ({} mV per count{}{}; read {} times a second{})",
            self.path.display(),
            c.scale_mv,
            if c.gain != 1.0 {
                format!(" × {}", c.gain)
            } else {
                String::new()
            },
            if c.offset_volts != 0.0 {
                format!(" + {} V", c.offset_volts)
            } else {
                String::new()
            },
            self.settings.rate_hz,
            if self.reconnect { "; reconnects" } else { "" }
        )
    }

    fn start(self) -> Result<Started<HeldSamples>, SensorError> {
        let (holder, samples) = hold();
        holder.set(self.conversion.volts(self.first_raw));
        let mut reader = Reader { sensor: self };
        let producer = Producer::spawn("sensor-iio", move |stop, log| {
            device::run(&mut reader, &holder, &stop, log)
        })?;
        Ok(Started { samples, producer })
    }
}

/// The reader thread's side of the channel.
struct Reader {
    sensor: IioSensor,
}

impl DeviceReader for Reader {
    fn what(&self) -> String {
        format!("iio:{}", self.sensor.path.display())
    }

    fn reconnects(&self) -> bool {
        self.sensor.reconnect
    }

    /// Reads at `rate_hz` on absolute deadlines (no drift).
    fn read_until_lost(
        &mut self,
        holder: &Holder,
        stop: &AtomicBool,
        log: &mut WakeLog,
    ) -> io::Result<()> {
        let period_ns = 1_000_000_000 / u64::from(self.sensor.settings.rate_hz.max(1));
        // Behind (a slow read): from now, no burst of catch-up reads.
        let mut pacer = Pacer::new(MonotonicClock, period_ns, false);
        log.due_on("its read's deadline");
        while !stop.load(Ordering::Relaxed) {
            let raw = read_raw(&self.sensor.file)?;
            holder.set(self.sensor.conversion.volts(raw));
            log.woke(pacer.wait());
        }
        Ok(())
    }

    fn try_reopen(&mut self, holder: &Holder) -> bool {
        let Ok(again) = IioSensor::open(&self.sensor.path, &self.sensor.settings, true) else {
            return false;
        };
        holder.set(again.conversion.volts(again.first_raw));
        self.sensor = again;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sysfs_values_parse_and_convert() {
        assert_eq!(parse_raw(b"16000\n"), Ok(16000));
        assert_eq!(parse_raw(b"-12\n"), Ok(-12));
        assert!(parse_raw(b"x\n").is_err());
        // The ADS1115 at ±4.096 V: 0.125 mV a count; at ±2.048 V 0.0625.
        let c = Conversion {
            scale_mv: 0.0625,
            raw_offset: 0.0,
            gain: 1.0,
            offset_volts: 0.0,
        };
        assert_eq!(c.volts(32000), 2.0);
        // A 3.3 V ADC behind a 5 → 3.3 V divider.
        let d = Conversion {
            scale_mv: 0.8056640625, // 3300 mV / 4096
            raw_offset: 0.0,
            gain: 5.0 / 3.3,
            offset_volts: 0.0,
        };
        assert!((d.volts(4096) - 5.0).abs() < 1e-12);
    }

    #[test]
    fn a_channel_in_a_sysfs_like_directory_is_read_with_its_scale() {
        let dir = std::env::temp_dir().join(format!("sipnpuff-iio-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("in_voltage0_raw"), "40000\n").unwrap();
        std::fs::write(dir.join("in_voltage_scale"), "0.062500000\n").unwrap();
        let sensor = IioSensor::open(
            &dir.join("in_voltage0_raw"),
            &IioSettings {
                offset_volts: 0.5,
                ..IioSettings::default()
            },
            false,
        )
        .unwrap();
        assert_eq!(sensor.conversion().scale_mv, 0.0625);
        assert_eq!(sensor.conversion().volts(sensor.first_raw), 3.0);
        // Without a scale file it is not a voltage channel.
        std::fs::write(dir.join("in_current1_raw"), "1\n").unwrap();
        let e = IioSensor::open(&dir.join("in_current1_raw"), &IioSettings::default(), false)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("no in_current1_scale"), "{e}");
        // Its buffer is for an IMU: asked for it, the channel says so.
        let buffered = IioSettings {
            buffered: true,
            ..IioSettings::default()
        };
        let e = IioSensor::open(&dir.join("in_voltage0_raw"), &buffered, false)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("buffered is for an IMU"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
