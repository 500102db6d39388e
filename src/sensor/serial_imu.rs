//! `--sensor serial:PATH` with `[sensor.serial] format = "imu"`: a
//! head-worn IMU on a microcontroller that prints one line per sample,
//! `ax,ay,az,gx,gy,gz` (m/s² with gravity, rad/s), at its own rate.
//!
//! The reader thread splits the stream into lines and queues each sample
//! on the IMU ring ([`imu_ring`](crate::sensor::imu_ring)); the port gone
//! (unplugged) ends the reader, which the core sees as the IMU lost. A
//! port that sends no sample within `answer_timeout_ms` at start is an
//! error saying what to check.

use std::io::{self, Read};
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::time::Instant;

use serialport::TTYPort;

use crate::control::imu::{CHANNELS, ImuSample};
use crate::sensor::imu_ring::{ImuRing, imu_ring};
use crate::sensor::serial::{LineSplitter, open_port};
use crate::sensor::settings::SerialSettings;
use crate::sensor::{Producer, Sensor, SensorError, Started};

/// A line's sample: six finite numbers separated by commas; `None` for
/// anything else (a header, a boot message, a line cut short).
pub fn imu_line(line: &str) -> Option<ImuSample> {
    let mut values = [0.0; CHANNELS];
    let mut fields = line.trim().split(',');
    for value in &mut values {
        *value = fields.next()?.trim().parse().ok()?;
    }
    let sample = ImuSample { values };
    (fields.next().is_none() && sample.is_finite()).then_some(sample)
}

/// An opened serial IMU that has answered.
pub struct SerialImu {
    path: PathBuf,
    baud: u32,
    port: TTYPort,
    splitter: LineSplitter,
}

impl SerialImu {
    /// Opens `path` and waits for the first sample (within
    /// `answer_timeout_ms`, else an error saying what to check).
    pub fn open(
        path: &Path,
        baud: Option<u32>,
        settings: &SerialSettings,
    ) -> Result<SerialImu, SensorError> {
        let baud = baud.unwrap_or(settings.baud);
        let format = crate::sensor::serial::LineFormat::new(settings, 0.0);
        let port = open_port(path, baud, &format)?;
        let mut imu = SerialImu {
            path: path.to_path_buf(),
            baud,
            port,
            splitter: LineSplitter::default(),
        };
        let answer = std::time::Duration::from_millis(u64::from(settings.answer_timeout_ms));
        let started = Instant::now();
        let mut buffer = [0u8; 512];
        let mut seen = None;
        while started.elapsed() < answer {
            let n = match imu.port.read(&mut buffer) {
                Ok(n) => n,
                Err(e) if e.kind() == io::ErrorKind::TimedOut => 0,
                Err(e) => {
                    return Err(SensorError::Io {
                        what: format!("{}: cannot read", path.display()),
                        error: e,
                    });
                }
            };
            let mut got = false;
            imu.splitter
                .feed(buffer.get(..n).unwrap_or_default(), |line| {
                    got |= imu_line(line).is_some();
                    seen.get_or_insert_with(|| line.to_string());
                });
            if got {
                return Ok(imu);
            }
        }
        Err(SensorError::WrongDevice {
            device: path.display().to_string(),
            message: match seen {
                Some(line) => format!(
                    "no IMU sample in {} ms: lines such as {line:?} are not `ax,ay,az,gx,gy,gz` (six numbers, m/s² and rad/s)",
                    settings.answer_timeout_ms
                ),
                None => format!(
                    "sent nothing in {} ms at {baud} baud: is the IMU's program running, at this speed?",
                    settings.answer_timeout_ms
                ),
            },
        })
    }
}

impl Sensor for SerialImu {
    type Samples = ImuRing;

    fn describe(&self) -> String {
        format!(
            "serial:{} ({} baud, format imu: ax,ay,az,gx,gy,gz)",
            self.path.display(),
            self.baud
        )
    }

    fn start(mut self) -> Result<Started<ImuRing>, SensorError> {
        let (mut feed, samples) = imu_ring();
        let thread = Producer::spawn("sensor-serial-imu", move |stop, _log| {
            let mut buffer = [0u8; 4096];
            while !stop.load(Ordering::Relaxed) {
                let n = match self.port.read(&mut buffer) {
                    Ok(0) => break,
                    Ok(n) => n,
                    Err(e)
                        if matches!(
                            e.kind(),
                            io::ErrorKind::TimedOut | io::ErrorKind::Interrupted
                        ) =>
                    {
                        continue;
                    }
                    Err(_) => break,
                };
                self.splitter
                    .feed(buffer.get(..n).unwrap_or_default(), |line| {
                        if let Some(sample) = imu_line(line) {
                            feed.push(sample);
                        }
                    });
            }
            // `feed` dropped: the control thread is told the port is gone.
            Ok(())
        })?;
        Ok(Started {
            samples,
            producer: thread,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_is_six_finite_numbers() {
        assert_eq!(
            imu_line(" 0.1, -0.2,9.8,0.01,0,-0.5\r"),
            Some(ImuSample {
                values: [0.1, -0.2, 9.8, 0.01, 0.0, -0.5]
            })
        );
        for not in [
            "ax,ay,az,gx,gy,gz",
            "0.1,0.2,9.8,0,0",
            "0.1,0.2,9.8,0,0,0,7",
            "0.1,0.2,NaN,0,0,0",
            "booting",
            "",
        ] {
            assert_eq!(imu_line(not), None, "{not}");
        }
    }
}
