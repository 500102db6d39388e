//! `--sensor evdev:…`: a sip-and-puff device that Linux sees as an input
//! device (USB HID → hid-generic → `/dev/input/eventN`).
//!
//! Two kinds of device:
//! * **axis**: pressure on one absolute axis (the Origin Breeze in
//!   Joystick Plus mode), mapped linearly from the axis's reported
//!   minimum..maximum to `volts_at_min..volts_at_max` (0–5 V by default:
//!   a 10-bit axis reads 512 ≈ 2.5 V). The axis's fuzz is set to 0
//!   (`EVIOCSABS`): hid-input gives joystick axes a fuzz of range/256 and
//!   the input core would drop every change smaller than that.
//! * **switches**: sip and puff as key or button closures (any number of
//!   keys each: soft and hard pairs), held as levels — the rest level, a
//!   puff at 5 V, a sip at 0 V — so the same detector classifies short and
//!   long by how long the key is held.
//!
//! A reader thread reads the device's events (`poll` with a timeout, so it
//! can be told to stop) and holds the latest value ([`held`](super::held));
//! an axis reports only changes, so silence is not staleness. The device
//! going away (`ENODEV`) is a fault; with `sensor.reconnect` the thread
//! looks for it again and resumes.

pub mod events;
pub mod imu;

use std::io;
use std::os::fd::{AsRawFd, RawFd};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use evdev::raw_stream::RawDevice;
use evdev::{AbsoluteAxisCode, KeyCode, PropType};

use crate::sensor::device::{self, DeviceReader};
use crate::sensor::held::{HeldSamples, Holder, Link, hold};
use crate::sensor::settings::{EvdevInput, EvdevSettings};
use crate::sensor::{EvdevTarget, Producer, Sensor, SensorError, Started};
use crate::wakes::WakeLog;
use events::{
    EV_SYN, EVENT_BYTES, EventMapper, Mapping, SYN_DROPPED, SwitchLevels, first_event_ns,
    parse_events,
};

/// What permission problems on input devices need.
pub const PERMISSION_FIX: &str = "input devices belong to root and the `input` group: add the user to it (`sudo usermod -aG input $USER`, then log in again) or install a udev rule, e.g. /etc/udev/rules.d/70-sipnpuff.rules: SUBSYSTEM==\"input\", ATTRS{name}==\"*Breeze*\", MODE=\"0660\", GROUP=\"plugdev\"";

/// The input devices of this machine, `/dev/input/eventN` in N order.
pub fn event_nodes() -> Vec<PathBuf> {
    let mut nodes: Vec<(u32, PathBuf)> = std::fs::read_dir("/dev/input")
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|entry| {
            let name = entry.file_name();
            let n = name.to_str()?.strip_prefix("event")?.parse().ok()?;
            Some((n, entry.path()))
        })
        .collect();
    nodes.sort();
    nodes.into_iter().map(|(_, path)| path).collect()
}

/// What kind of input device a backend reads: a sip-and-puff sensor or
/// a head-worn IMU (the accelerometer property tells them apart).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Wanted {
    /// Pressure on an axis or switch closures: anything but an IMU.
    Breath,
    /// A device with INPUT_PROP_ACCELEROMETER.
    Imu,
}

impl Wanted {
    /// Whether `device` is of this kind.
    fn accepts(self, device: &RawDevice) -> bool {
        is_accelerometer(device) == (self == Wanted::Imu)
    }

    /// Why `device` (given by its node) is not of this kind.
    fn refusal(self) -> &'static str {
        match self {
            Wanted::Breath => {
                "it is an accelerometer (a head-worn IMU), not a sip-and-puff sensor: for head gestures give a --config with [gestures] set = \"SET.toml\" (docs/gestures.md)"
            }
            Wanted::Imu => {
                "it is not an IMU (it has no INPUT_PROP_ACCELEROMETER property); `sipnpuff sensors` marks the IMUs this machine has"
            }
        }
    }

    /// What it is called in messages.
    fn what(self) -> &'static str {
        match self {
            Wanted::Breath => "input device",
            Wanted::Imu => "IMU (input device with the accelerometer property)",
        }
    }
}

/// Whether the device says its axes are an accelerometer's
/// (INPUT_PROP_ACCELEROMETER).
pub fn is_accelerometer(device: &RawDevice) -> bool {
    device.properties().contains(PropType::ACCELEROMETER)
}

/// Finds and opens the target device, of the kind wanted: by node it must
/// be of that kind; by name, the first of that kind whose name matches.
pub(super) fn find(
    target: &EvdevTarget,
    wanted: Wanted,
) -> Result<(PathBuf, RawDevice), SensorError> {
    match target {
        EvdevTarget::Path(path) => {
            let device = RawDevice::open(path)
                .map_err(|e| SensorError::opening_device(path, e, PERMISSION_FIX))?;
            if !wanted.accepts(&device) {
                return Err(SensorError::WrongDevice {
                    device: format!("{} ({:?})", path.display(), device.name().unwrap_or("?")),
                    message: wanted.refusal().to_string(),
                });
            }
            Ok((path.clone(), device))
        }
        EvdevTarget::Name(part) => {
            let mut denied = Vec::new();
            let mut names = Vec::new();
            for path in event_nodes() {
                match RawDevice::open(&path) {
                    Ok(device) => {
                        let name = device.name().unwrap_or("").to_string();
                        if wanted.accepts(&device) {
                            if name.contains(part.as_str()) {
                                return Ok((path, device));
                            }
                            names.push(format!("{name:?}"));
                        }
                    }
                    Err(e) if e.kind() == io::ErrorKind::PermissionDenied => {
                        denied.push(path.display().to_string());
                    }
                    Err(_) => {}
                }
            }
            let message = if denied.is_empty() {
                format!(
                    "no {}'s name contains {part:?} (names: {}); is it plugged in? `sipnpuff sensors` lists what this machine has",
                    wanted.what(),
                    if names.is_empty() {
                        "none".to_string()
                    } else {
                        names.join(", ")
                    }
                )
            } else {
                format!(
                    "no readable {}'s name contains {part:?}, and {} could not be opened (permission denied: {PERMISSION_FIX})",
                    wanted.what(),
                    denied.join(", ")
                )
            };
            Err(SensorError::WrongDevice {
                device: target.to_string(),
                message,
            })
        }
    }
}

/// The mapping for this device, checked against what it has.
fn mapping_for(
    path: &Path,
    device: &RawDevice,
    settings: &EvdevSettings,
    rest_volts: f64,
) -> Result<Mapping, SensorError> {
    let name = device.name().unwrap_or("?");
    let wrong = |message: String| SensorError::WrongDevice {
        device: format!("{} ({name:?})", path.display()),
        message,
    };
    match settings.input {
        EvdevInput::Axis => {
            let code: AbsoluteAxisCode = settings
                .axis
                .parse()
                .map_err(|_| wrong(format!("{:?} is not an absolute axis name", settings.axis)))?;
            let axes: Vec<String> = device
                .supported_absolute_axes()
                .map(|a| a.iter().map(|c| format!("{c:?}")).collect())
                .unwrap_or_default();
            if !axes.contains(&settings.axis) {
                return Err(wrong(if axes.is_empty() {
                    "it has no absolute axis: a switch device needs `[sensor.evdev] input = \"switches\"` with its sip_keys and puff_keys".to_string()
                } else {
                    format!(
                        "it has no axis {} (it has {}): set `[sensor.evdev] axis`",
                        settings.axis,
                        axes.join(", ")
                    )
                }));
            }
            let info = absinfo(device.as_raw_fd(), code.0).map_err(|e| SensorError::Io {
                what: format!("{}: cannot read the axis range", path.display()),
                error: e,
            })?;
            if info.maximum <= info.minimum {
                return Err(wrong(format!(
                    "axis {} reports the range {}..{}: no pressure can be read from it",
                    settings.axis, info.minimum, info.maximum
                )));
            }
            Ok(Mapping::Axis {
                code: code.0,
                range: (info.minimum, info.maximum),
                volts: (settings.volts_at_min, settings.volts_at_max),
            })
        }
        EvdevInput::Switches => {
            let have: Vec<KeyCode> = device
                .supported_keys()
                .map(|k| k.iter().collect())
                .unwrap_or_default();
            let codes = |names: &[String]| -> Result<Vec<u16>, SensorError> {
                let mut codes = Vec::new();
                for n in names {
                    let code: KeyCode = n
                        .parse()
                        .map_err(|_| wrong(format!("{n:?} is not a key name")))?;
                    if !have.contains(&code) {
                        let list: Vec<String> =
                            have.iter().take(24).map(|k| format!("{k:?}")).collect();
                        return Err(wrong(format!(
                            "it has no key {n} (it has {}): set `[sensor.evdev] sip_keys` and `puff_keys`",
                            if list.is_empty() {
                                "no keys".to_string()
                            } else {
                                list.join(", ")
                            }
                        )));
                    }
                    codes.push(code.0);
                }
                Ok(codes)
            };
            Ok(Mapping::Switches {
                sip: codes(&settings.sip_keys)?,
                puff: codes(&settings.puff_keys)?,
                levels: SwitchLevels::around(rest_volts),
            })
        }
    }
}

/// `EVIOCGABS(code)`.
pub(super) fn absinfo(fd: RawFd, code: u16) -> io::Result<libc::input_absinfo> {
    let request = ioc(2, 0x40 + u64::from(code), size_of::<libc::input_absinfo>());
    // SAFETY: all-zero bytes are a valid `input_absinfo` (plain integers).
    let mut info: libc::input_absinfo = unsafe { std::mem::zeroed() };
    // SAFETY: EVIOCGABS writes one `input_absinfo` into `info`, which is
    // valid and writable for that size.
    let rc = unsafe { libc::ioctl(fd, request as _, &mut info) };
    if rc < 0 {
        return Err(io::Error::last_os_error());
    }
    Ok(info)
}

/// `EVIOCSABS(code)`: sets the axis's fuzz to 0 so that every change is
/// delivered (hid-input's fuzz drops changes smaller than range/256).
pub(super) fn clear_fuzz(fd: RawFd, code: u16) -> io::Result<()> {
    let mut info = absinfo(fd, code)?;
    if info.fuzz == 0 {
        return Ok(());
    }
    info.fuzz = 0;
    let request = ioc(1, 0xc0 + u64::from(code), size_of::<libc::input_absinfo>());
    // SAFETY: EVIOCSABS reads one `input_absinfo` from `info`.
    let rc = unsafe { libc::ioctl(fd, request as _, &info) };
    if rc < 0 {
        return Err(io::Error::last_os_error());
    }
    Ok(())
}

/// `CLOCK_REALTIME` now, ns: the clock evdev stamps events with.
fn realtime_now_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; CLOCK_REALTIME always
    // exists.
    unsafe { libc::clock_gettime(libc::CLOCK_REALTIME, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// `_IOC(dir, 'E', nr, size)` (dir 1 = write, 2 = read).
fn ioc(dir: u64, nr: u64, size: usize) -> u64 {
    (dir << 30) | ((size as u64) << 16) | (u64::from(b'E') << 8) | nr
}

/// The level the device stands at now (read from its state, not events).
fn current_volts(device: &RawDevice, mapper: &mut EventMapper) -> io::Result<f64> {
    match mapper.mapping() {
        Mapping::Axis { code, .. } => {
            let value = absinfo(device.as_raw_fd(), *code)?.value;
            Ok(mapper.axis_volts(value).unwrap_or(f64::NAN))
        }
        Mapping::Switches { .. } => {
            let keys = device.get_key_state()?;
            mapper.set_keys(|code| keys.contains(KeyCode(code)));
            Ok(mapper.switch_volts().unwrap_or(f64::NAN))
        }
    }
}

/// An opened input device, not yet reading.
pub struct EvdevSensor {
    target: EvdevTarget,
    settings: EvdevSettings,
    rest_volts: f64,
    reconnect: bool,
    path: PathBuf,
    device: RawDevice,
    mapper: EventMapper,
}

impl EvdevSensor {
    /// Finds and opens the device, checks it has the configured axis or
    /// keys, clears the axis's fuzz and grabs it if asked. `rest_volts` is
    /// what switches read at rest (the detector's neutral).
    pub fn open(
        target: &EvdevTarget,
        settings: &EvdevSettings,
        rest_volts: f64,
        reconnect: bool,
    ) -> Result<EvdevSensor, SensorError> {
        let (path, mut device) = find(target, Wanted::Breath)?;
        let mapping = mapping_for(&path, &device, settings, rest_volts)?;
        prepare(&path, &mut device, &mapping, settings.grab)?;
        Ok(EvdevSensor {
            target: target.clone(),
            settings: settings.clone(),
            rest_volts,
            reconnect,
            path,
            device,
            mapper: EventMapper::new(mapping),
        })
    }

    /// The device's name, as the kernel gives it.
    pub fn name(&self) -> String {
        self.device.name().unwrap_or("?").to_string()
    }

    /// An analog axis (its neutral can be measured), or switches.
    pub fn is_analog(&self) -> bool {
        matches!(self.mapper.mapping(), Mapping::Axis { .. })
    }
}

/// Clears the fuzz and grabs, as the settings ask.
fn prepare(
    path: &Path,
    device: &mut RawDevice,
    mapping: &Mapping,
    grab: bool,
) -> Result<(), SensorError> {
    if let Mapping::Axis { code, .. } = mapping {
        clear_fuzz(device.as_raw_fd(), *code).map_err(|e| SensorError::Io {
            what: format!(
                "{}: cannot set the axis fuzz to 0 (EVIOCSABS; small pressure changes would be dropped)",
                path.display()
            ),
            error: e,
        })?;
    }
    if grab {
        device.grab().map_err(|e| SensorError::Io {
            what: format!(
                "{}: cannot grab the device (another program holds it? set `[sensor.evdev] grab = false` to share it)",
                path.display()
            ),
            error: e,
        })?;
    }
    Ok(())
}

impl Sensor for EvdevSensor {
    type Samples = HeldSamples;

    fn describe(&self) -> String {
        let what = match self.mapper.mapping() {
            Mapping::Axis {
                range: (min, max),
                volts: (a, b),
                ..
            } => format!("axis {} {min}..{max} → {a}..{b} V", self.settings.axis),
            Mapping::Switches { .. } => format!(
                "switches: sip {}, puff {}",
                self.settings.sip_keys.join("/"),
                self.settings.puff_keys.join("/")
            ),
        };
        format!(
            "{} ({:?} at {}; {what}{}{})",
            self.target,
            self.name(),
            self.path.display(),
            if self.settings.grab { "; grabbed" } else { "" },
            if self.reconnect { "; reconnects" } else { "" }
        )
    }

    fn start(self) -> Result<Started<HeldSamples>, SensorError> {
        let (holder, samples) = hold();
        let mut reader = Reader { sensor: self };
        // The level now, before the first event: an axis at rest sends
        // nothing until it changes.
        let now = current_volts(&reader.sensor.device, &mut reader.sensor.mapper).map_err(|e| {
            SensorError::Io {
                what: format!("{}: cannot read its state", reader.sensor.path.display()),
                error: e,
            }
        })?;
        holder.set(now);
        let producer = Producer::spawn("sensor-evdev", move |stop, log| {
            device::run(&mut reader, &holder, &stop, log)
        })?;
        Ok(Started { samples, producer })
    }
}

/// What one wait on a device's events gave.
pub(super) enum Polled {
    /// Nothing within the timeout.
    TimedOut,
    /// A signal (or a spurious wake-up): wait again.
    Interrupted,
    /// This many bytes of events read.
    Read(usize),
}

/// Waits up to `timeout_ms` for the device's events and reads them into
/// `buffer`; the device gone is an `ENODEV` error.
pub(super) fn poll_read(fd: RawFd, buffer: &mut [u8], timeout_ms: i32) -> io::Result<Polled> {
    let mut poll = libc::pollfd {
        fd,
        events: libc::POLLIN,
        revents: 0,
    };
    // SAFETY: one valid pollfd, for the length given.
    let ready = unsafe { libc::poll(&mut poll, 1, timeout_ms) };
    if ready < 0 {
        let e = io::Error::last_os_error();
        return match e.kind() {
            io::ErrorKind::Interrupted => Ok(Polled::Interrupted),
            _ => Err(e),
        };
    }
    if ready == 0 {
        return Ok(Polled::TimedOut);
    }
    if poll.revents & (libc::POLLERR | libc::POLLHUP | libc::POLLNVAL) != 0
        && poll.revents & libc::POLLIN == 0
    {
        return Err(io::Error::from_raw_os_error(libc::ENODEV));
    }
    // SAFETY: reads at most `buffer.len()` bytes into `buffer`.
    let n = unsafe { libc::read(fd, buffer.as_mut_ptr().cast(), buffer.len()) };
    if n < 0 {
        let e = io::Error::last_os_error();
        return match e.kind() {
            io::ErrorKind::Interrupted | io::ErrorKind::WouldBlock => Ok(Polled::Interrupted),
            _ => Err(e),
        };
    }
    if n == 0 {
        return Err(io::Error::from_raw_os_error(libc::ENODEV));
    }
    Ok(Polled::Read(n.unsigned_abs()))
}

/// The reader thread's side of the device.
struct Reader {
    sensor: EvdevSensor,
}

/// How long a poll waits before checking the stop flag, ms.
const POLL_MS: i32 = 50;

impl DeviceReader for Reader {
    fn what(&self) -> String {
        self.sensor.target.to_string()
    }

    fn reconnects(&self) -> bool {
        self.sensor.reconnect
    }

    fn read_until_lost(
        &mut self,
        holder: &Holder,
        stop: &AtomicBool,
        log: &mut WakeLog,
    ) -> io::Result<()> {
        let fd = self.sensor.device.as_raw_fd();
        let mut buffer = [0u8; EVENT_BYTES * 64];
        // How late the thread woke for each batch, from its first event's
        // kernel stamp, on the clock the kernel stamps with by default
        // (CLOCK_REALTIME: a step of the clock is one outlier). Asking for
        // another clock (EVIOCSCLOCKID) would flush the queued events and
        // queue SYN_DROPPED, whose state read right after a reopen is
        // stale.
        log.due_on("its first event's kernel time stamp");
        while !stop.load(Ordering::Relaxed) {
            let n = match poll_read(fd, &mut buffer, POLL_MS)? {
                Polled::Read(n) => n,
                Polled::TimedOut | Polled::Interrupted => continue,
            };
            if let Some(at) = first_event_ns(buffer.get(..n).unwrap_or_default()) {
                log.woke(realtime_now_ns().saturating_sub(at));
            }
            let mut dropped = false;
            for event in parse_events(buffer.get(..n).unwrap_or_default()) {
                if event.kind == EV_SYN && event.code == SYN_DROPPED {
                    dropped = true;
                } else if let Some(volts) = self.sensor.mapper.apply(event) {
                    holder.set(volts);
                }
            }
            if dropped {
                // The kernel's buffer overflowed: read the state itself.
                holder.set(current_volts(&self.sensor.device, &mut self.sensor.mapper)?);
            }
        }
        Ok(())
    }

    /// An axis's value as the kernel holds it right after a reopen is
    /// stale (0, a full sip, until the device's first report: usbhid
    /// polls only while the node is open), so nothing is held until a
    /// report arrives; the core stays in fault meanwhile. Keys are read
    /// from the kernel's key state, which is current.
    fn try_reopen(&mut self, holder: &Holder) -> bool {
        let s = &self.sensor;
        let Ok(mut again) = EvdevSensor::open(&s.target, &s.settings, s.rest_volts, true) else {
            return false;
        };
        if again.is_analog() {
            holder.link(Link::Waiting);
        } else {
            let Ok(volts) = current_volts(&again.device, &mut again.mapper) else {
                return false;
            };
            holder.set(volts);
        }
        self.sensor = again;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ioctl_numbers_match_linux() {
        // EVIOCGABS(ABS_X) = 0x80184540, EVIOCSABS(ABS_X) = 0x401845c0.
        assert_eq!(ioc(2, 0x40, size_of::<libc::input_absinfo>()), 0x8018_4540);
        assert_eq!(ioc(1, 0xc0, size_of::<libc::input_absinfo>()), 0x4018_45c0);
    }

    #[test]
    fn a_missing_device_says_so() {
        let error = |target| {
            EvdevSensor::open(&target, &EvdevSettings::default(), 2.5, false)
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default()
        };
        let e = error(EvdevTarget::Path("/dev/input/event-none".into()));
        assert!(e.contains("no such file or device"), "{e}");
        let e = error(EvdevTarget::Name("no device is called this".into()));
        assert!(e.contains("no input device's name contains"), "{e}");
    }
}
