//! `--sensor serial:PATH[,baud=N]`: a sensor that streams text lines over a
//! serial port (USB CDC-ACM `/dev/ttyACM0`, a USB-serial adapter
//! `/dev/ttyUSB0`, a UART).
//!
//! Formats (`[sensor.serial] format`):
//! * `volts` — one value per line, volts (a microcontroller sampling an
//!   analog pressure sensor, ideally at 1 kHz);
//! * `counts` — one value per line, ADC counts; volts = counts ÷
//!   `full_scale` × 5;
//! * `flipmouse` — FLipMouse/FABI: `AT SR` starts
//!   `VALUES:<pressure 0–1023>,…` lines about every 50 ms (idle ≈ 512);
//! * `lipsync` — LipSync: `DM,1:2` starts
//!   `SUCCESS,0:DEBUG,2:<mouthpiece>,<ambient>,<diff>,<offset>` lines (hPa)
//!   every 100 ms; volts = neutral + diff × `volts_per_hpa`.
//!
//! The reader thread holds the latest value ([`held`](super::held)): a
//! 1 kHz sample-and-hold. A source slower than the detector needs is said
//! so at start ([`SerialSensor::rate_note`]): at 50 ms a line, a burst's
//! length is known only to ±50 ms. No line for `silence_ms` mid-run: the
//! samples stop and the core faults after `stale_ms`; the port failing
//! (unplugged) is a fault at once.

use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use serialport::TTYPort;

use crate::sensor::device::{self, DeviceReader};
use crate::sensor::held::{HeldSamples, Holder, Link, hold};
use crate::sensor::settings::{SerialFormat, SerialSettings};
use crate::sensor::{Producer, Sensor, SensorError, Started};
use crate::wakes::WakeLog;

/// What permission problems on serial ports need.
pub const PERMISSION_FIX: &str = "serial ports belong to root and the `dialout` group: add the user to it (`sudo usermod -aG dialout $USER`, then log in again)";

/// The longest line kept; longer ones are garbage (a wrong baud rate).
const MAX_LINE: usize = 256;

// --------------------------------------------------------------- lines

/// Turns lines of one format into volts: the pure part of the backend.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineFormat {
    settings: SerialSettings,
    neutral_volts: f64,
}

impl LineFormat {
    /// The format of `settings`, around the detector's `neutral_volts`
    /// (LipSync sends a pressure difference).
    pub fn new(settings: &SerialSettings, neutral_volts: f64) -> LineFormat {
        LineFormat {
            settings: *settings,
            neutral_volts,
        }
    }

    /// What to send to start the stream (the dialects wait for it).
    pub fn start_command(&self) -> &'static [u8] {
        match self.settings.format {
            SerialFormat::Flipmouse => b"AT SR\r",
            SerialFormat::Lipsync => b"DM,1:2\r\n",
            SerialFormat::Volts | SerialFormat::Counts | SerialFormat::Imu => b"",
        }
    }

    /// What to send to end it.
    pub fn stop_command(&self) -> &'static [u8] {
        match self.settings.format {
            SerialFormat::Flipmouse => b"AT ER\r",
            SerialFormat::Lipsync
            | SerialFormat::Volts
            | SerialFormat::Counts
            | SerialFormat::Imu => b"",
        }
    }

    /// The sample a line holds: `Ok(None)` for a line that carries none
    /// (an empty line, a dialect's acknowledgement), `Err` for a line
    /// that should have held one and does not.
    pub fn volts(&self, line: &str) -> Result<Option<f64>, String> {
        let line = line.trim();
        if line.is_empty() {
            return Ok(None);
        }
        let number = |text: &str| -> Result<f64, String> {
            let v: f64 = text
                .trim()
                .parse()
                .map_err(|_| format!("{text:?} is not a number"))?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(format!("{text:?} is not finite"))
            }
        };
        match self.settings.format {
            SerialFormat::Volts => number(line).map(Some),
            SerialFormat::Counts => number(line).map(|c| Some(c / self.settings.full_scale * 5.0)),
            SerialFormat::Flipmouse => match line.strip_prefix("VALUES:") {
                None => Ok(None),
                Some(values) => {
                    let pressure = values.split(',').next().unwrap_or("");
                    number(pressure).map(|p| Some(p / self.settings.full_scale * 5.0))
                }
            },
            SerialFormat::Lipsync => match line.strip_prefix("SUCCESS,0:DEBUG,2:") {
                None => Ok(None),
                Some(values) => {
                    let diff = values.split(',').nth(2).ok_or_else(|| {
                        format!("{line:?}: expected <mouthpiece>,<ambient>,<diff>,<offset>")
                    })?;
                    number(diff).map(|d| Some(self.neutral_volts + d * self.settings.volts_per_hpa))
                }
            },
            SerialFormat::Imu => Err(
                "format `imu` gives a head-worn IMU's samples, not a breath's: it needs [gestures] set"
                    .into(),
            ),
        }
    }
}

/// Splits a byte stream into lines (ended by CR, LF or both); a line
/// longer than 256 bytes is dropped whole (garbage: a wrong baud rate).
#[derive(Debug, Default)]
pub struct LineSplitter {
    line: Vec<u8>,
    overlong: bool,
}

impl LineSplitter {
    /// Feeds bytes; calls `each` with every complete line.
    pub fn feed(&mut self, bytes: &[u8], mut each: impl FnMut(&str)) {
        for &b in bytes {
            if b == b'\n' || b == b'\r' {
                if !self.overlong && !self.line.is_empty() {
                    each(&String::from_utf8_lossy(&self.line));
                }
                self.line.clear();
                self.overlong = false;
            } else if self.line.len() < MAX_LINE {
                self.line.push(b);
            } else {
                self.overlong = true;
            }
        }
    }
}

// --------------------------------------------------------------- the port

/// An opened serial port that has answered.
pub struct SerialSensor {
    path: PathBuf,
    baud: u32,
    /// The line format and the rest of the settings with it.
    format: LineFormat,
    reconnect: bool,
    port: TTYPort,
    splitter: LineSplitter,
    last_volts: f64,
    /// The source's period, measured at start, ms.
    period_ms: f64,
}

/// The port's read timeout: how often the reader checks the stop flag.
pub(crate) const READ_TIMEOUT: Duration = Duration::from_millis(20);

/// Opens `path` at `baud` and starts the stream (dialects).
pub(crate) fn open_port(
    path: &Path,
    baud: u32,
    format: &LineFormat,
) -> Result<TTYPort, SensorError> {
    let mut port = serialport::new(path.to_string_lossy(), baud)
        .timeout(READ_TIMEOUT)
        .open_native()
        .map_err(|e| match e.kind {
            serialport::ErrorKind::Io(kind) => SensorError::opening_device(
                path,
                io::Error::new(kind, e.description.clone()),
                PERMISSION_FIX,
            ),
            serialport::ErrorKind::NoDevice => SensorError::WrongDevice {
                device: path.display().to_string(),
                message: format!(
                    "cannot open it ({}): is it in use by another program (a modem manager, a serial console)?",
                    e.description
                ),
            },
            _ => SensorError::Io {
                what: format!("cannot open {}", path.display()),
                error: io::Error::other(e.description),
            },
        })?;
    let start = format.start_command();
    if !start.is_empty() {
        port.write_all(start).map_err(|e| SensorError::Io {
            what: format!("{}: cannot send the start command", path.display()),
            error: e,
        })?;
    }
    Ok(port)
}

impl SerialSensor {
    /// Opens the port, starts the stream and waits for samples: the first
    /// within `answer_timeout_ms` (else an error saying what to check), then
    /// a few more to measure the source's period.
    pub fn open(
        path: &Path,
        baud: Option<u32>,
        settings: &SerialSettings,
        neutral_volts: f64,
        reconnect: bool,
    ) -> Result<SerialSensor, SensorError> {
        let baud = baud.unwrap_or(settings.baud);
        let format = LineFormat::new(settings, neutral_volts);
        let port = open_port(path, baud, &format)?;
        let mut sensor = SerialSensor {
            path: path.to_path_buf(),
            baud,
            format,
            reconnect,
            port,
            splitter: LineSplitter::default(),
            last_volts: f64::NAN,
            period_ms: f64::NAN,
        };
        sensor.measure_period()?;
        Ok(sensor)
    }

    /// Waits for the first sample, then counts the samples that follow
    /// (at least 200 over at least 200 ms, or for 1.5 s). Lines arrive in
    /// batches (a USB packet holds many), so the period is the time over
    /// the number of samples, never the time between reads.
    fn measure_period(&mut self) -> Result<(), SensorError> {
        let answer = Duration::from_millis(u64::from(self.format.settings.answer_timeout_ms));
        let started = Instant::now();
        // The first read that held a sample, the last one, and the samples
        // read after the first.
        let mut first: Option<Instant> = None;
        let mut last = started;
        let mut counted = 0u32;
        let mut bad: Option<String> = None;
        let mut other_lines = 0u32;
        let mut buffer = [0u8; 512];
        loop {
            if first.is_none() && started.elapsed() > answer {
                let mut message = format!(
                    "sent nothing readable as `{}` in {} ms at {} baud",
                    self.format.settings.format.name(),
                    self.format.settings.answer_timeout_ms,
                    self.baud
                );
                if let Some(bad) = &bad {
                    message += &format!(" (last line: {bad})");
                } else if other_lines > 0 {
                    message += &format!(" ({other_lines} lines without a sample)");
                }
                message += ": check the baud rate (`serial:PATH,baud=N`), `[sensor.serial] format`, and that the device streams values";
                return Err(SensorError::WrongDevice {
                    device: self.path.display().to_string(),
                    message,
                });
            }
            if let Some(t) = first {
                let spent = t.elapsed();
                if (counted >= 200 && spent >= Duration::from_millis(200))
                    || spent > Duration::from_millis(1500)
                {
                    break;
                }
            }
            let n = match self.port.read(&mut buffer) {
                Ok(0) => return Err(self.gone("the port closed")),
                Ok(n) => n,
                Err(e) if e.kind() == io::ErrorKind::TimedOut => continue,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(self.gone(&e.to_string())),
            };
            let now = Instant::now();
            let format = self.format;
            let mut samples = 0u32;
            let mut latest = None;
            self.splitter
                .feed(&buffer[..n], |line| match format.volts(line) {
                    Ok(Some(v)) => {
                        latest = Some(v);
                        samples += 1;
                    }
                    Ok(None) => other_lines += 1,
                    Err(e) => bad = Some(e),
                });
            if let Some(v) = latest {
                self.last_volts = v;
                if first.is_none() {
                    first = Some(now);
                } else {
                    counted += samples;
                    last = now;
                }
            }
        }
        self.period_ms = match first {
            Some(first) if counted > 0 => {
                last.duration_since(first).as_secs_f64() * 1000.0 / f64::from(counted)
            }
            _ => f64::NAN,
        };
        Ok(())
    }

    fn gone(&self, detail: &str) -> SensorError {
        SensorError::Disconnected {
            what: self.path.display().to_string(),
            detail: detail.to_string(),
        }
    }

    /// The source's period as measured at start, ms (NaN if unknown).
    pub fn period_ms(&self) -> f64 {
        self.period_ms
    }

    /// What the source's rate means for burst timing, if it is slower than
    /// the detector needs; `None` for a source of about 1 kHz.
    pub fn rate_note(&self, min_burst_ms: u32, long_burst_ms: u32) -> Option<String> {
        rate_note(self.period_ms, min_burst_ms, long_burst_ms)
    }
}

/// What a source period of `period_ms` means for the detector's timings,
/// if it is coarser than 2 ms.
pub fn rate_note(period_ms: f64, min_burst_ms: u32, long_burst_ms: u32) -> Option<String> {
    if period_ms.is_nan() || period_ms <= 2.0 {
        return None;
    }
    let p = period_ms.round();
    Some(format!(
        "the sensor sends a sample every {p:.0} ms ({:.0} per second), not every 1 ms: burst lengths are known only to ±{p:.0} ms; bursts shorter than about {:.0} ms (min_burst_ms {min_burst_ms} + one period) may be missed, and bursts within {p:.0} ms of long_burst_ms ({long_burst_ms} ms) may be classed either way{}",
        1000.0 / period_ms,
        f64::from(min_burst_ms) + p,
        if p > f64::from(min_burst_ms) {
            format!(
                "; a {min_burst_ms} ms burst cannot be timed at all: use a 1 kHz sensor (an analog sensor on an ADC) or raise min_burst_ms"
            )
        } else {
            String::new()
        }
    ))
}

impl Sensor for SerialSensor {
    type Samples = HeldSamples;

    fn describe(&self) -> String {
        let rate = if self.period_ms.is_finite() {
            format!("; a sample every {:.1} ms", self.period_ms)
        } else {
            String::new()
        };
        format!(
            "serial:{} ({} baud, format {}{rate}{})",
            self.path.display(),
            self.baud,
            self.format.settings.format.name(),
            if self.reconnect { "; reconnects" } else { "" }
        )
    }

    fn start(self) -> Result<Started<HeldSamples>, SensorError> {
        let (holder, samples) = hold();
        if self.last_volts.is_finite() {
            holder.set(self.last_volts);
        }
        let mut reader = Reader { sensor: self };
        let producer = Producer::spawn("sensor-serial", move |stop, log| {
            device::run(&mut reader, &holder, &stop, log)
        })?;
        Ok(Started { samples, producer })
    }
}

/// The reader thread's side of the port.
struct Reader {
    sensor: SerialSensor,
}

impl DeviceReader for Reader {
    fn what(&self) -> String {
        format!("serial:{}", self.sensor.path.display())
    }

    fn reconnects(&self) -> bool {
        self.sensor.reconnect
    }

    fn read_until_lost(
        &mut self,
        holder: &Holder,
        stop: &AtomicBool,
        _log: &mut WakeLog,
    ) -> io::Result<()> {
        let silence = Duration::from_millis(u64::from(self.sensor.format.settings.silence_ms));
        let mut last_sample = Instant::now();
        let mut buffer = [0u8; 4096];
        while !stop.load(Ordering::Relaxed) {
            let n = match self.sensor.port.read(&mut buffer) {
                Ok(0) => return Err(io::Error::from(io::ErrorKind::BrokenPipe)),
                Ok(n) => n,
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::TimedOut | io::ErrorKind::Interrupted
                    ) =>
                {
                    0
                }
                Err(e) => return Err(e),
            };
            let format = self.sensor.format;
            let mut got = false;
            self.sensor.splitter.feed(&buffer[..n], |line| {
                if let Ok(Some(v)) = format.volts(line) {
                    holder.set(v);
                    got = true;
                }
            });
            if got {
                last_sample = Instant::now();
            } else if last_sample.elapsed() > silence {
                holder.link(Link::Silent);
            }
        }
        Ok(())
    }

    fn try_reopen(&mut self, _holder: &Holder) -> bool {
        match open_port(&self.sensor.path, self.sensor.baud, &self.sensor.format) {
            Ok(port) => {
                self.sensor.port = port;
                self.sensor.splitter = LineSplitter::default();
                true
            }
            Err(_) => false,
        }
    }

    /// The device stops streaming (best effort: the port may be gone).
    fn finish(&mut self) {
        let stop_command = self.sensor.format.stop_command();
        if !stop_command.is_empty() {
            let _ = self.sensor.port.write_all(stop_command);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn format(format: SerialFormat) -> LineFormat {
        LineFormat::new(
            &SerialSettings {
                format,
                ..SerialSettings::default()
            },
            2.5,
        )
    }

    #[test]
    fn recorded_lines_of_each_format_give_volts() {
        let v = format(SerialFormat::Volts);
        assert_eq!(v.volts("2.500"), Ok(Some(2.5)));
        assert_eq!(v.volts(" 3.75 \r"), Ok(Some(3.75)));
        assert_eq!(v.volts(""), Ok(None));
        assert!(v.volts("2,5").is_err());
        assert!(v.volts("NaN").is_err(), "not finite");
        let c = format(SerialFormat::Counts);
        assert_eq!(c.volts("1023"), Ok(Some(5.0)));
        assert_eq!(c.volts("0"), Ok(Some(0.0)));
        let f = format(SerialFormat::Flipmouse);
        assert_eq!(f.start_command(), b"AT SR\r");
        assert_eq!(
            f.volts("VALUES:512,0,0,0,0,0,0,0,1"),
            Ok(Some(512.0 / 1023.0 * 5.0))
        );
        assert_eq!(f.volts("VALUES:1023,3,4,5,6,7,8,0,1"), Ok(Some(5.0)));
        assert_eq!(f.volts("OK"), Ok(None), "an acknowledgement");
        assert!(f.volts("VALUES:x,0").is_err());
        let l = format(SerialFormat::Lipsync);
        assert_eq!(l.start_command(), b"DM,1:2\r\n");
        // diff +10 hPa at 0.05 V/hPa around 2.5 V.
        assert_eq!(
            l.volts("SUCCESS,0:DEBUG,2:1023.25,1013.25,10.00,0.00"),
            Ok(Some(3.0))
        );
        assert_eq!(
            l.volts("SUCCESS,0:DEBUG,2:1003.25,1013.25,-10,0"),
            Ok(Some(2.0))
        );
        assert_eq!(l.volts("SUCCESS,1:2"), Ok(None));
        assert!(l.volts("SUCCESS,0:DEBUG,2:1,2").is_err());
    }

    #[test]
    fn lines_split_on_cr_lf_and_overlong_lines_are_dropped() {
        let mut s = LineSplitter::default();
        let mut lines = Vec::new();
        s.feed(b"2.5\r\n2.", |l| lines.push(l.to_string()));
        s.feed(b"6\n\n3.0\r", |l| lines.push(l.to_string()));
        assert_eq!(lines, ["2.5", "2.6", "3.0"]);
        lines.clear();
        let long = vec![b'7'; MAX_LINE + 10];
        s.feed(&long, |l| lines.push(l.to_string()));
        s.feed(b"\n2.4\n", |l| lines.push(l.to_string()));
        assert_eq!(lines, ["2.4"], "the overlong line is dropped whole");
    }

    #[test]
    fn a_slow_source_is_said_so_with_what_it_means() {
        assert_eq!(rate_note(1.0, 40, 500), None, "1 kHz");
        let flip = rate_note(50.0, 40, 500).unwrap_or_default();
        assert!(flip.contains("every 50 ms (20 per second)"), "{flip}");
        assert!(flip.contains("±50 ms"), "{flip}");
        assert!(flip.contains("a 40 ms burst cannot be timed"), "{flip}");
        let fast = rate_note(10.0, 40, 500).unwrap_or_default();
        assert!(!fast.contains("cannot be timed"), "{fast}");
    }

    #[test]
    fn a_missing_port_says_so() {
        let e = SerialSensor::open(
            Path::new("/dev/ttyNONE9"),
            None,
            &SerialSettings::default(),
            2.5,
            false,
        )
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
        assert!(e.contains("/dev/ttyNONE9"), "{e}");
    }
}
