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

use std::io;
use std::os::fd::{AsRawFd, RawFd};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use evdev::raw_stream::RawDevice;
use evdev::{AbsoluteAxisCode, KeyCode};

use crate::sensor::device::{self, DeviceReader};
use crate::sensor::held::{HeldSamples, Holder, Link, hold};
use crate::sensor::settings::{EvdevInput, EvdevSettings};
use crate::sensor::{EvdevTarget, Producer, Sensor, SensorError, Started};

/// What permission problems on input devices need.
pub const PERMISSION_FIX: &str = "input devices belong to root and the `input` group: add the user to it (`sudo usermod -aG input $USER`, then log in again) or install a udev rule, e.g. /etc/udev/rules.d/70-sipnpuff.rules: SUBSYSTEM==\"input\", ATTRS{name}==\"*Breeze*\", MODE=\"0660\", GROUP=\"plugdev\"";

// --------------------------------------------------------------- events

/// `EV_SYN`, `EV_KEY`, `EV_ABS` and `SYN_DROPPED` from linux/input.h.
const EV_SYN: u16 = 0x00;
const EV_KEY: u16 = 0x01;
const EV_ABS: u16 = 0x03;
const SYN_DROPPED: u16 = 3;

/// Bytes of one `struct input_event` on 64-bit Linux (timeval, type,
/// code, value).
pub const EVENT_BYTES: usize = 24;

/// One input event: type, code, value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InputEvent {
    /// `EV_*`.
    pub kind: u16,
    /// Axis or key code.
    pub code: u16,
    /// New value (axis position; key 1 down, 0 up, 2 repeat).
    pub value: i32,
}

/// The events in `bytes`, as read from an event node (whole events only;
/// a trailing partial event is ignored).
pub fn parse_events(bytes: &[u8]) -> impl Iterator<Item = InputEvent> + '_ {
    bytes.chunks_exact(EVENT_BYTES).map(|e| InputEvent {
        kind: u16::from_ne_bytes([e[16], e[17]]),
        code: u16::from_ne_bytes([e[18], e[19]]),
        value: i32::from_ne_bytes([e[20], e[21], e[22], e[23]]),
    })
}

/// How events become volts: the pure part of the backend.
#[derive(Debug, Clone, PartialEq)]
pub enum Mapping {
    /// One axis, linearly.
    Axis {
        /// The axis code.
        code: u16,
        /// Its reported minimum and maximum.
        range: (i32, i32),
        /// Volts at the minimum and at the maximum.
        volts: (f64, f64),
    },
    /// Keys held as levels.
    Switches {
        /// Codes meaning sip.
        sip: Vec<u16>,
        /// Codes meaning puff.
        puff: Vec<u16>,
        /// Levels at rest, sipping and puffing, volts.
        levels: SwitchLevels,
    },
}

/// The levels switches are held at.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwitchLevels {
    /// Nothing pressed (and both sip and puff pressed: ambiguous, so
    /// nothing moves).
    pub rest: f64,
    /// A sip key down.
    pub sip: f64,
    /// A puff key down.
    pub puff: f64,
}

impl SwitchLevels {
    /// Rest at the detector's neutral, puff at 5 V, sip at 0 V: beyond
    /// every valid threshold and hysteresis band, inside the valid range.
    pub fn around(neutral_volts: f64) -> SwitchLevels {
        SwitchLevels {
            rest: neutral_volts,
            sip: 0.0,
            puff: 5.0,
        }
    }
}

/// Turns a device's events into the level to hold.
#[derive(Debug, Clone)]
pub struct EventMapper {
    mapping: Mapping,
    sip_down: Vec<bool>,
    puff_down: Vec<bool>,
}

impl EventMapper {
    /// A mapper with nothing pressed.
    pub fn new(mapping: Mapping) -> EventMapper {
        let (sip, puff) = match &mapping {
            Mapping::Axis { .. } => (0, 0),
            Mapping::Switches { sip, puff, .. } => (sip.len(), puff.len()),
        };
        EventMapper {
            mapping,
            sip_down: vec![false; sip],
            puff_down: vec![false; puff],
        }
    }

    /// Volts for an axis position.
    pub fn axis_volts(&self, value: i32) -> Option<f64> {
        let Mapping::Axis {
            range: (min, max),
            volts: (at_min, at_max),
            ..
        } = self.mapping
        else {
            return None;
        };
        let span = f64::from(max) - f64::from(min);
        Some(at_min + (f64::from(value) - f64::from(min)) / span * (at_max - at_min))
    }

    /// The level the keys now down stand for (switches), if any.
    pub fn switch_volts(&self) -> Option<f64> {
        let Mapping::Switches { levels, .. } = &self.mapping else {
            return None;
        };
        let sip = self.sip_down.iter().any(|&d| d);
        let puff = self.puff_down.iter().any(|&d| d);
        Some(match (sip, puff) {
            (true, false) => levels.sip,
            (false, true) => levels.puff,
            _ => levels.rest,
        })
    }

    /// Applies one event; the new level if it changed what is held.
    pub fn apply(&mut self, event: InputEvent) -> Option<f64> {
        match (&self.mapping, event.kind) {
            (Mapping::Axis { code, .. }, EV_ABS) if event.code == *code => {
                self.axis_volts(event.value)
            }
            (Mapping::Switches { sip, puff, .. }, EV_KEY) if event.value != 2 => {
                let down = event.value != 0;
                let mut hit = false;
                for (slot, _) in self
                    .sip_down
                    .iter_mut()
                    .zip(sip)
                    .filter(|(_, c)| **c == event.code)
                {
                    *slot = down;
                    hit = true;
                }
                for (slot, _) in self
                    .puff_down
                    .iter_mut()
                    .zip(puff)
                    .filter(|(_, c)| **c == event.code)
                {
                    *slot = down;
                    hit = true;
                }
                if hit { self.switch_volts() } else { None }
            }
            _ => None,
        }
    }

    /// Sets which keys are down from the device's key state (after
    /// opening, and after the kernel dropped events).
    fn set_keys(&mut self, is_down: impl Fn(u16) -> bool) {
        if let Mapping::Switches { sip, puff, .. } = &self.mapping {
            for (slot, code) in self.sip_down.iter_mut().zip(sip) {
                *slot = is_down(*code);
            }
            for (slot, code) in self.puff_down.iter_mut().zip(puff) {
                *slot = is_down(*code);
            }
        }
    }
}

// --------------------------------------------------------------- devices

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

/// Finds and opens the target device.
fn find(target: &EvdevTarget) -> Result<(PathBuf, RawDevice), SensorError> {
    match target {
        EvdevTarget::Path(path) => {
            let device = RawDevice::open(path)
                .map_err(|e| SensorError::opening_device(path, e, PERMISSION_FIX))?;
            Ok((path.clone(), device))
        }
        EvdevTarget::Name(part) => {
            let mut denied = Vec::new();
            let mut names = Vec::new();
            for path in event_nodes() {
                match RawDevice::open(&path) {
                    Ok(device) => {
                        let name = device.name().unwrap_or("").to_string();
                        if name.contains(part.as_str()) {
                            return Ok((path, device));
                        }
                        names.push(format!("{name:?}"));
                    }
                    Err(e) if e.kind() == io::ErrorKind::PermissionDenied => {
                        denied.push(path.display().to_string());
                    }
                    Err(_) => {}
                }
            }
            let message = if denied.is_empty() {
                format!(
                    "no input device's name contains {part:?} (names: {}); is it plugged in? `sipnpuff sensors` lists what this machine has",
                    if names.is_empty() {
                        "none".to_string()
                    } else {
                        names.join(", ")
                    }
                )
            } else {
                format!(
                    "no readable input device's name contains {part:?}, and {} could not be opened (permission denied: {PERMISSION_FIX})",
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
fn absinfo(fd: RawFd, code: u16) -> io::Result<libc::input_absinfo> {
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
fn clear_fuzz(fd: RawFd, code: u16) -> io::Result<()> {
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

/// `_IOC(dir, 'E', nr, size)` (dir 1 = write, 2 = read).
fn ioc(dir: u64, nr: u64, size: usize) -> u64 {
    (dir << 30) | ((size as u64) << 16) | (u64::from(b'E') << 8) | nr
}

/// The level the device stands at now (read from its state, not events).
fn current_volts(device: &RawDevice, mapper: &mut EventMapper) -> io::Result<f64> {
    match &mapper.mapping {
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
        let (path, mut device) = find(target)?;
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
        matches!(self.mapper.mapping, Mapping::Axis { .. })
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
        let what = match &self.mapper.mapping {
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
        let producer = Producer::spawn("sensor-evdev", move |stop| {
            device::run(&mut reader, &holder, &stop)
        })?;
        Ok(Started { samples, producer })
    }
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

    fn read_until_lost(&mut self, holder: &Holder, stop: &AtomicBool) -> io::Result<()> {
        let fd = self.sensor.device.as_raw_fd();
        let mut buffer = [0u8; EVENT_BYTES * 64];
        while !stop.load(Ordering::Relaxed) {
            let mut poll = libc::pollfd {
                fd,
                events: libc::POLLIN,
                revents: 0,
            };
            // SAFETY: one valid pollfd, for the length given.
            let ready = unsafe { libc::poll(&mut poll, 1, POLL_MS) };
            if ready < 0 {
                let e = io::Error::last_os_error();
                if e.kind() == io::ErrorKind::Interrupted {
                    continue;
                }
                return Err(e);
            }
            if ready == 0 {
                continue;
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
                match e.kind() {
                    io::ErrorKind::Interrupted | io::ErrorKind::WouldBlock => continue,
                    _ => return Err(e),
                }
            }
            if n == 0 {
                return Err(io::Error::from_raw_os_error(libc::ENODEV));
            }
            let mut dropped = false;
            for event in parse_events(&buffer[..n as usize]) {
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

    /// An event as the kernel writes it (timestamp, type, code, value).
    fn event_bytes(sec: i64, kind: u16, code: u16, value: i32) -> Vec<u8> {
        let mut b = Vec::new();
        b.extend(sec.to_ne_bytes());
        b.extend(0i64.to_ne_bytes());
        b.extend(kind.to_ne_bytes());
        b.extend(code.to_ne_bytes());
        b.extend(value.to_ne_bytes());
        b
    }

    #[test]
    fn recorded_event_bytes_parse_whole_events_only() {
        let mut bytes = event_bytes(1, EV_ABS, 0, 700);
        bytes.extend(event_bytes(1, EV_SYN, 0, 0));
        bytes.extend([1, 2, 3]); // a partial event
        let events: Vec<_> = parse_events(&bytes).collect();
        assert_eq!(
            events,
            [
                InputEvent {
                    kind: EV_ABS,
                    code: 0,
                    value: 700
                },
                InputEvent {
                    kind: EV_SYN,
                    code: 0,
                    value: 0
                }
            ]
        );
    }

    #[test]
    fn a_ten_bit_axis_maps_linearly_to_volts() {
        let mut m = EventMapper::new(Mapping::Axis {
            code: 0,
            range: (0, 1023),
            volts: (0.0, 5.0),
        });
        let at = |m: &mut EventMapper, value| {
            m.apply(InputEvent {
                kind: EV_ABS,
                code: 0,
                value,
            })
        };
        assert_eq!(at(&mut m, 0), Some(0.0));
        assert_eq!(at(&mut m, 1023), Some(5.0));
        assert_eq!(at(&mut m, 512), Some(512.0 / 1023.0 * 5.0)); // ≈ 2.502 V
        assert_eq!(
            m.apply(InputEvent {
                kind: EV_ABS,
                code: 1,
                value: 9
            }),
            None,
            "another axis"
        );
        // A signed axis (±4 kPa as -512..511) onto 0.5–4.5 V.
        let m = EventMapper::new(Mapping::Axis {
            code: 0,
            range: (-512, 511),
            volts: (0.5, 4.5),
        });
        assert_eq!(m.axis_volts(-512), Some(0.5));
        assert_eq!(m.axis_volts(511), Some(4.5));
    }

    #[test]
    fn switches_are_levels_and_soft_hard_pairs_both_count() {
        let trigger = KeyCode::BTN_TRIGGER.0;
        let thumb = KeyCode::BTN_THUMB.0;
        let thumb2 = KeyCode::BTN_THUMB2.0;
        let mut m = EventMapper::new(Mapping::Switches {
            sip: vec![trigger],
            puff: vec![thumb, thumb2],
            levels: SwitchLevels::around(2.5),
        });
        let key = |code, value| InputEvent {
            kind: EV_KEY,
            code,
            value,
        };
        assert_eq!(m.apply(key(thumb, 1)), Some(5.0), "soft puff");
        assert_eq!(m.apply(key(thumb2, 1)), Some(5.0), "hard puff too");
        assert_eq!(m.apply(key(thumb, 0)), Some(5.0), "hard still down");
        assert_eq!(m.apply(key(thumb2, 2)), None, "auto-repeat changes nothing");
        assert_eq!(m.apply(key(thumb2, 0)), Some(2.5), "released");
        assert_eq!(m.apply(key(trigger, 1)), Some(0.0), "sip");
        assert_eq!(m.apply(key(thumb, 1)), Some(2.5), "both: ambiguous, rest");
        assert_eq!(m.apply(key(trigger, 0)), Some(5.0));
        assert_eq!(m.apply(key(KeyCode::KEY_A.0, 1)), None, "another key");
    }

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
