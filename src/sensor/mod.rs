//! The sensor seam: where samples come from, and how they reach the
//! control thread without ever blocking it.
//!
//! A backend's life: **open** (its constructor: find the device or file,
//! say clearly what is wrong) → [`Sensor::start`] (spawn its producer
//! thread, if it has one) → **samples** ([`Samples::try_read`], once per
//! tick on the control thread) → **stop** ([`Producer::stop`]: the thread
//! ends and is joined, and reports any error it met).
//!
//! How samples reach the control thread: a backend that reads a file runs
//! a producer thread into a bounded ring ([`ring`]), a device's reader
//! thread holds its latest value ([`held`]), and the synthetic sensor
//! (`sim::synthetic_sensor`) computes its samples in the loop. The control thread takes the sample
//! due each tick and never waits; what it throws away is counted: the
//! samples of skipped ticks, a backlog past two (a producer running ahead
//! adds at most 2 ms), everything queued over a stall longer than
//! `stale_ms` ([`Samples::discard_backlog`]). A tick with no sample gives
//! the core [`Sample::Missing`]: after `stale_ms` the core faults and the
//! arm brakes.
//!
//! Backends: [`csv`] (recordings played in real time) and the devices: [`evdev`] (USB HID
//! sip-and-puff devices: an analog axis or switches), [`serial`] (a
//! microcontroller's stream, the FLipMouse and LipSync dialects) and
//! [`iio`] (an ADC through the kernel's IIO subsystem). A device's neutral
//! is measured before anything can move ([`rezero`]); [`listing`] finds
//! what this machine has (`sipnpuff sensors`). A head-worn IMU is read
//! by the same seam ([`imu_sensor`]: evdev, IIO, serial or a recording),
//! alone or beside a breath sensor ([`with_imu`]).

pub mod csv;
pub mod device;
pub mod evdev;
pub mod held;
pub mod iio;
pub mod iio_buffer;
pub mod iio_imu;
pub mod imu_playback;
pub mod imu_ring;
pub mod imu_sensor;
pub mod listing;
pub mod pacer;
pub mod rezero;
pub mod ring;
pub mod serial;
pub mod serial_imu;
pub mod settings;
pub mod with_imu;

use std::fmt;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;

use crate::control::imu::ImuInput;
use crate::control::sample::Sample;
use crate::wakes::{WakeLog, Wakes};

/// Which sensor to open: the `--sensor` forms, a contract documented in
/// `--help` and `docs/commands.md`. A new backend adds its form here and
/// one line where it is opened (`wiring/sensor.rs`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SensorSpec {
    /// `synthetic`: the built-in scripted user on the seeded sensor model;
    /// `synthetic:NAME`: one of the built-in breathers (`sipnpuff
    /// generate --help` lists them) in that user's place.
    Synthetic(Option<String>),
    /// `csv:PATH`: a recording played in real time.
    Csv(PathBuf),
    /// `evdev:/dev/input/eventN` or `evdev:name=SUBSTRING`: an input
    /// device (USB HID) by its node or by (part of) its name.
    Evdev(EvdevTarget),
    /// `serial:PATH[,baud=N]`: a serial port.
    Serial {
        /// The port, e.g. `/dev/ttyACM0`.
        path: PathBuf,
        /// The line speed, if given (else `sensor.serial.baud`).
        baud: Option<u32>,
    },
    /// `iio:/sys/bus/iio/devices/iio:deviceN/in_voltageM_raw`: an ADC
    /// channel; `iio:/sys/bus/iio/devices/iio:deviceN`, with a gesture
    /// set: an IMU's accel and anglvel channels.
    Iio(PathBuf),
}

impl SensorSpec {
    /// The forms, for messages.
    pub const FORMS: &str = "`synthetic[:BREATHER]`, `csv:PATH`, `evdev:/dev/input/eventN`, `evdev:name=SUBSTRING`, `serial:PATH[,baud=N]` or `iio:/sys/bus/iio/devices/iio:deviceN/in_voltageM_raw`";

    /// Parses a `--sensor` value; the error lists the forms.
    pub fn parse(text: &str) -> Result<SensorSpec, String> {
        let needs = |form: &str, example: &str| format!("`{form}:` needs {example}");
        match text.split_once(':') {
            None if text == "synthetic" => Ok(SensorSpec::Synthetic(None)),
            Some(("synthetic", name)) if !name.is_empty() => {
                Ok(SensorSpec::Synthetic(Some(name.to_string())))
            }
            Some(("synthetic", _)) => Err(needs(
                "synthetic",
                "a breather's name, e.g. `synthetic:tremor_4hz`",
            )),
            Some(("csv", path)) if !path.is_empty() => Ok(SensorSpec::Csv(PathBuf::from(path))),
            Some(("csv", _)) => Err(needs("csv", "a path, e.g. `csv:fixtures/demo.csv`")),
            Some(("evdev", rest)) => match rest.strip_prefix("name=") {
                Some("") => Err(needs(
                    "evdev:name=",
                    "part of the device's name, e.g. `evdev:name=Breeze`",
                )),
                Some(name) => Ok(SensorSpec::Evdev(EvdevTarget::Name(name.into()))),
                None if rest.is_empty() => Err(needs(
                    "evdev",
                    "a device, e.g. `evdev:/dev/input/event3` or `evdev:name=Breeze` (`sipnpuff sensors` lists them)",
                )),
                None => Ok(SensorSpec::Evdev(EvdevTarget::Path(rest.into()))),
            },
            Some(("serial", rest)) => {
                let (path, options) = rest.split_once(',').unwrap_or((rest, ""));
                if path.is_empty() {
                    return Err(needs("serial", "a port, e.g. `serial:/dev/ttyACM0`"));
                }
                let baud = match options {
                    "" => None,
                    _ => match options.strip_prefix("baud=").map(str::parse::<u32>) {
                        Some(Ok(baud)) if baud > 0 => Some(baud),
                        _ => {
                            return Err(format!(
                                "`serial:{rest}`: after the port, only `,baud=N` (N a positive number) is understood"
                            ));
                        }
                    },
                };
                Ok(SensorSpec::Serial {
                    path: path.into(),
                    baud,
                })
            }
            Some(("iio", path)) if !path.is_empty() => Ok(SensorSpec::Iio(path.into())),
            Some(("iio", _)) => Err(needs(
                "iio",
                "a channel's raw file, e.g. `iio:/sys/bus/iio/devices/iio:device0/in_voltage0_raw`",
            )),
            _ => Err(format!(
                "unknown sensor {text:?}: choose {}",
                SensorSpec::FORMS
            )),
        }
    }

    /// A device (its neutral is measured at start; it may go away).
    pub fn is_device(&self) -> bool {
        matches!(
            self,
            SensorSpec::Evdev(_) | SensorSpec::Serial { .. } | SensorSpec::Iio(_)
        )
    }
}

/// A `--sensor` as it is written (a serial port without its baud).
impl fmt::Display for SensorSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SensorSpec::Synthetic(None) => write!(f, "synthetic"),
            SensorSpec::Synthetic(Some(name)) => write!(f, "synthetic:{name}"),
            SensorSpec::Csv(path) => write!(f, "csv:{}", path.display()),
            SensorSpec::Evdev(target) => write!(f, "{target}"),
            SensorSpec::Serial { path, .. } => write!(f, "serial:{}", path.display()),
            SensorSpec::Iio(path) => write!(f, "iio:{}", path.display()),
        }
    }
}

/// Which input device: by node or by name.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum EvdevTarget {
    /// `/dev/input/eventN`.
    Path(PathBuf),
    /// The first device (in event-number order) whose name contains this.
    Name(String),
}

impl std::fmt::Display for EvdevTarget {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            EvdevTarget::Path(path) => write!(f, "evdev:{}", path.display()),
            EvdevTarget::Name(name) => write!(f, "evdev:name={name}"),
        }
    }
}

/// One tick's read of a sensor. `Copy`, RT-safe.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Reading {
    /// What the core is given on this tick: the sample, none, or the
    /// device gone (the core then faults at once instead of waiting
    /// `stale_ms`).
    pub sample: Sample,
    /// The head-worn IMU's input on this tick (a sensor without one
    /// leaves it missing).
    pub imu: ImuInput,
    /// Older samples thrown away to catch up (the producer ran ahead).
    pub discarded: u64,
}

/// The control thread's side of a sensor. RT-safe: never blocks, never
/// allocates, never panics.
pub trait Samples: Send {
    /// The sample for the tick about to run, after `skipped` ticks the loop
    /// missed (their samples are stale and thrown away).
    fn try_read(&mut self, skipped: u64) -> Reading;

    /// The loop stalled for `skipped` ticks (longer than the core's
    /// `stale_ms`): throw away every sample of the gap and everything
    /// queued, so none is replayed as a breath; the next read starts
    /// fresh. Returns how many were thrown away (counted in the drops).
    fn discard_backlog(&mut self, skipped: u64) -> u64;

    /// No sample will ever come again (a recording or script ended).
    fn ended(&self) -> bool;
}

/// A sensor backend. Not RT-safe: opened and started before the loop.
pub trait Sensor {
    /// What the control thread reads.
    type Samples: Samples + 'static;

    /// What this sensor is, for the report (e.g. `csv:fixtures/demo.csv`).
    fn describe(&self) -> String;

    /// Starts delivering samples: spawns the producer thread, if any.
    fn start(self) -> Result<Started<Self::Samples>, SensorError>;
}

/// A device already opened, started and measured (its neutral) before the
/// loop: the run takes it as it is.
pub struct Prepared<S> {
    /// What the device is, with what was measured.
    pub description: String,
    /// The started device.
    pub started: Started<S>,
}

impl<S: Samples + 'static> Sensor for Prepared<S> {
    type Samples = S;

    fn describe(&self) -> String {
        self.description.clone()
    }

    fn start(self) -> Result<Started<S>, SensorError> {
        Ok(self.started)
    }
}

/// A started sensor: the control thread's side and the producer's handle.
pub struct Started<S> {
    /// For the control thread.
    pub samples: S,
    /// For whoever stops the run.
    pub producer: Producer,
}

/// The producer thread of a started sensor, if it has one.
#[derive(Debug)]
pub struct Producer {
    thread: Option<JoinHandle<(Result<(), SensorError>, Wakes)>>,
    stop: Arc<AtomicBool>,
    /// A second sensor's producer, stopped with this one.
    also: Option<Box<Producer>>,
}

impl Producer {
    /// A sensor without a thread.
    pub fn none() -> Producer {
        Producer {
            thread: None,
            stop: Arc::new(AtomicBool::new(false)),
            also: None,
        }
    }

    /// This producer and `other` as one: both are stopped together (a
    /// breath sensor's and an IMU's, read side by side).
    pub fn and(mut self, other: Producer) -> Producer {
        self.also = Some(Box::new(match self.also.take() {
            None => other,
            Some(also) => also.and(other),
        }));
        self
    }

    /// Spawns a producer thread named `name`; `body` gets the flag that
    /// asks it to end, and the log of its wake-ups (a reader that knows
    /// when its data was due records how late it woke for it).
    pub fn spawn(
        name: &str,
        body: impl FnOnce(Arc<AtomicBool>, &mut WakeLog) -> Result<(), SensorError> + Send + 'static,
    ) -> Result<Producer, SensorError> {
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let thread = std::thread::Builder::new()
            .name(name.into())
            .spawn(move || {
                let mut log = WakeLog::start();
                let result = body(flag, &mut log);
                (result, log.finish())
            })
            .map_err(|error| SensorError::Io {
                what: format!("cannot start the {name} thread"),
                error,
            })?;
        Ok(Producer {
            thread: Some(thread),
            stop,
            also: None,
        })
    }

    /// Its threads (and those joined with it), with their names: for the
    /// run to give them their real-time priority.
    pub fn threads(&self) -> Vec<(String, libc::pthread_t)> {
        use std::os::unix::thread::JoinHandleExt;
        let mut threads = self
            .also
            .as_ref()
            .map_or_else(Vec::new, |also| also.threads());
        if let Some(thread) = &self.thread {
            let name = thread.thread().name().unwrap_or("sensor").to_string();
            threads.insert(0, (name, thread.as_pthread_t()));
        }
        threads
    }

    /// Asks the thread (and any joined with it) to end, waits for it, and
    /// returns what it met: the first error, if both met one.
    pub fn stop(self) -> Result<(), SensorError> {
        self.stop_with_wakes().0
    }

    /// As [`Producer::stop`], with each thread's name and wake-up log.
    pub fn stop_with_wakes(mut self) -> (Result<(), SensorError>, Vec<(String, Wakes)>) {
        self.stop.store(true, Ordering::Relaxed);
        let (also, mut wakes) = self
            .also
            .take()
            .map_or((Ok(()), Vec::new()), |also| also.stop_with_wakes());
        let own = match self.thread.take() {
            None => Ok(()),
            Some(thread) => {
                let name = thread.thread().name().unwrap_or("sensor").to_string();
                match thread.join() {
                    Ok((result, log)) => {
                        wakes.insert(0, (name, log));
                        result
                    }
                    Err(_) => Err(SensorError::Disconnected {
                        what: "the sensor thread".into(),
                        detail: "it stopped unexpectedly (panicked)".into(),
                    }),
                }
            }
        };
        (own.and(also), wakes)
    }
}

impl Drop for Producer {
    /// A producer dropped without [`Producer::stop`] is still told to end.
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
    }
}

/// Why a sensor cannot deliver, in words that say what to do.
#[derive(Debug)]
#[non_exhaustive]
pub enum SensorError {
    /// The device or file does not exist.
    NotFound {
        /// What was looked for.
        path: PathBuf,
    },
    /// The device or file exists but may not be opened.
    Permission {
        /// The device or file.
        path: PathBuf,
        /// What gives access (a group, a udev rule).
        fix: String,
    },
    /// The device is there but is not a sip-and-puff sensor as configured
    /// (no such axis or key, a port that sends nothing readable).
    WrongDevice {
        /// The device.
        device: String,
        /// What is wrong and what to check.
        message: String,
    },
    /// The sensor went away while running.
    Disconnected {
        /// Which sensor.
        what: String,
        /// What happened.
        detail: String,
    },
    /// The sensor delivered something that is not a sample.
    BadData {
        /// Where: file and line, or device.
        context: String,
        /// What is wrong.
        message: String,
    },
    /// Any other I/O problem.
    Io {
        /// What was being done.
        what: String,
        /// The system's error.
        error: std::io::Error,
    },
}

impl SensorError {
    /// The error for a failed open of `path`: not found, permission, or
    /// another I/O problem.
    pub fn opening(path: &std::path::Path, error: std::io::Error) -> SensorError {
        SensorError::opening_device(
            path,
            error,
            "run as a user who may read it (e.g. in the file's group) or add a udev rule",
        )
    }

    /// [`SensorError::opening`] for a device, whose permission error says
    /// what gives access (`fix`).
    pub fn opening_device(path: &std::path::Path, error: std::io::Error, fix: &str) -> SensorError {
        match error.kind() {
            std::io::ErrorKind::NotFound => SensorError::NotFound {
                path: path.to_path_buf(),
            },
            std::io::ErrorKind::PermissionDenied => SensorError::Permission {
                path: path.to_path_buf(),
                fix: fix.to_string(),
            },
            _ => SensorError::Io {
                what: format!("cannot open {}", path.display()),
                error,
            },
        }
    }
}

impl fmt::Display for SensorError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SensorError::NotFound { path } => write!(
                f,
                "{}: no such file or device (check the path; for a device, that it is plugged in)",
                path.display()
            ),
            SensorError::Permission { path, fix } => {
                write!(f, "{}: permission denied: {fix}", path.display())
            }
            SensorError::WrongDevice { device, message } => write!(f, "{device}: {message}"),
            SensorError::Disconnected { what, detail } => {
                write!(f, "{what} disconnected: {detail}")
            }
            SensorError::BadData { context, message } => write!(f, "{context}: {message}"),
            SensorError::Io { what, error } => write!(f, "{what}: {error}"),
        }
    }
}

impl std::error::Error for SensorError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sensor_forms_parse_and_errors_name_the_choices() {
        assert_eq!(
            SensorSpec::parse("synthetic"),
            Ok(SensorSpec::Synthetic(None))
        );
        assert_eq!(
            SensorSpec::parse("synthetic:tremor_4hz"),
            Ok(SensorSpec::Synthetic(Some("tremor_4hz".into())))
        );
        assert_eq!(
            SensorSpec::parse("csv:a/b.csv"),
            Ok(SensorSpec::Csv(PathBuf::from("a/b.csv")))
        );
        assert_eq!(
            SensorSpec::parse("evdev:/dev/input/event3"),
            Ok(SensorSpec::Evdev(EvdevTarget::Path(
                "/dev/input/event3".into()
            )))
        );
        assert_eq!(
            SensorSpec::parse("evdev:name=Breeze Joystick"),
            Ok(SensorSpec::Evdev(EvdevTarget::Name(
                "Breeze Joystick".into()
            )))
        );
        assert_eq!(
            SensorSpec::parse("serial:/dev/ttyACM0"),
            Ok(SensorSpec::Serial {
                path: "/dev/ttyACM0".into(),
                baud: None
            })
        );
        assert_eq!(
            SensorSpec::parse("serial:/dev/ttyUSB1,baud=9600"),
            Ok(SensorSpec::Serial {
                path: "/dev/ttyUSB1".into(),
                baud: Some(9600)
            })
        );
        assert_eq!(
            SensorSpec::parse("iio:/sys/bus/iio/devices/iio:device0/in_voltage0_raw"),
            Ok(SensorSpec::Iio(
                "/sys/bus/iio/devices/iio:device0/in_voltage0_raw".into()
            ))
        );
        for (bad, says) in [
            (
                "evdev",
                "`synthetic[:BREATHER]`, `csv:PATH`, `evdev:/dev/input/eventN`",
            ),
            ("evdev:", "`sipnpuff sensors` lists them"),
            ("evdev:name=", "part of the device's name"),
            ("serial:,baud=9600", "a port"),
            ("serial:/dev/ttyACM0,baud=fast", "only `,baud=N`"),
            ("serial:/dev/ttyACM0,baud=0", "only `,baud=N`"),
            ("iio:", "in_voltage0_raw"),
            ("usb:1", "unknown sensor"),
            ("synthetic:", "a breather's name"),
        ] {
            let e = SensorSpec::parse(bad).unwrap_err();
            assert!(e.contains(says), "{bad}: {e}");
        }
        assert!(
            SensorSpec::parse("csv:")
                .unwrap_err()
                .contains("needs a path")
        );
    }
}
