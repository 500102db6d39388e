//! `--sensor evdev:…` for a head-worn IMU: an input device with the
//! accelerometer property (INPUT_PROP_ACCELEROMETER), such as a game
//! controller's motion sensor or a worn board. Its ABS_X/Y/Z are
//! accelerations in counts per g and ABS_RX/RY/RZ angular rates in counts
//! per degree per second (each axis's resolution, as linux/input.h defines
//! it for accelerometers); each frame of events, up to SYN_REPORT, is one
//! sample, queued on the IMU ring ([`imu_ring`](crate::sensor::imu_ring)).
//!
//! evdev sends only changes, and no frame at all when nothing changed: a
//! still head whose counts stay the same sends nothing. While the device
//! is there, the reader repeats the held frame after [`HOLD_MS`] without
//! one, so stillness is not silence; the same values for `frozen_ms` are
//! still the frozen fault, and the device gone ends the reader (the IMU
//! lost, a fault at once).

use std::f64::consts::PI;
use std::io;
use std::os::fd::AsRawFd;
use std::path::PathBuf;
use std::sync::atomic::Ordering;

use evdev::raw_stream::RawDevice;

use crate::control::imu::{CHANNELS, Channel, Channels, ImuSample};
use crate::sensor::evdev::events::{
    EV_ABS, EV_SYN, EVENT_BYTES, InputEvent, SYN_DROPPED, SYN_REPORT, parse_events,
};
use crate::sensor::evdev::{Polled, Wanted, absinfo, clear_fuzz, find, poll_read};
use crate::sensor::imu_ring::{ImuFeed, ImuRing, imu_ring};
use crate::sensor::{EvdevTarget, Producer, Sensor, SensorError, Started};

/// Standard gravity, m/s² per g.
const STANDARD_GRAVITY: f64 = 9.806_65;

/// How long without a frame before the reader repeats the held one, ms:
/// below the head's `stale_ms` (100 by default), above a 100 Hz IMU's
/// period.
pub const HOLD_MS: i32 = 20;

/// The axis code of each channel: ABS_X, ABS_Y, ABS_Z, ABS_RX, ABS_RY,
/// ABS_RZ are 0..=5, in the channels' order.
fn axis_code(channel: Channel) -> u16 {
    channel.index() as u16
}

/// The SI value of one count on each channel the device has (m/s² for
/// the accelerations, rad/s for the rates).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImuAxes {
    per_count: [Option<f64>; CHANNELS],
}

impl ImuAxes {
    /// The axes from each channel's resolution (`None`: the device lacks
    /// that axis); an error names an axis without a resolution, or a
    /// device with none of the six.
    pub fn from_resolutions(resolutions: [Option<i32>; CHANNELS]) -> Result<ImuAxes, String> {
        let mut per_count = [None; CHANNELS];
        for channel in Channel::ALL {
            let Some(resolution) = resolutions.get(channel.index()).copied().flatten() else {
                continue;
            };
            let (axis, unit) = if channel.is_acceleration() {
                (["ABS_X", "ABS_Y", "ABS_Z"][channel.index()], "counts per g")
            } else {
                (
                    ["ABS_RX", "ABS_RY", "ABS_RZ"][channel.index() - 3],
                    "counts per degree per second",
                )
            };
            if resolution <= 0 {
                return Err(format!(
                    "its axis {axis} reports the resolution {resolution}: its {unit} are unknown, so its values cannot be read as {}",
                    if channel.is_acceleration() {
                        "m/s²"
                    } else {
                        "rad/s"
                    }
                ));
            }
            let si = if channel.is_acceleration() {
                STANDARD_GRAVITY
            } else {
                PI / 180.0
            };
            if let Some(slot) = per_count.get_mut(channel.index()) {
                *slot = Some(si / f64::from(resolution));
            }
        }
        let axes = ImuAxes { per_count };
        if axes.channels().is_empty() {
            return Err(
                "it has none of ABS_X, ABS_Y, ABS_Z, ABS_RX, ABS_RY, ABS_RZ: no acceleration or rate to read"
                    .to_string(),
            );
        }
        Ok(axes)
    }

    /// The channels the device gives.
    pub fn channels(&self) -> Channels {
        Channel::ALL
            .into_iter()
            .filter(|c| self.per_count.get(c.index()).is_some_and(Option::is_some))
            .fold(Channels::NONE, Channels::with)
    }
}

/// A device's frames as samples: the counts held per axis, changed by
/// events, a sample at each SYN_REPORT. Pure.
#[derive(Debug, Clone)]
pub struct ImuFrames {
    axes: ImuAxes,
    counts: [i32; CHANNELS],
}

impl ImuFrames {
    /// Frames on `axes`, starting from the counts the device holds now.
    pub fn new(axes: ImuAxes, counts: [i32; CHANNELS]) -> ImuFrames {
        ImuFrames { axes, counts }
    }

    /// Takes the counts the device holds (after the kernel dropped events).
    pub fn resync(&mut self, counts: [i32; CHANNELS]) {
        self.counts = counts;
    }

    /// Applies one event; the frame's sample when it ends one.
    pub fn apply(&mut self, event: InputEvent) -> Option<ImuSample> {
        match event.kind {
            EV_ABS => {
                if let Some(count) = self.counts.get_mut(usize::from(event.code)) {
                    *count = event.value;
                }
                None
            }
            EV_SYN if event.code == SYN_REPORT => Some(self.sample()),
            _ => None,
        }
    }

    /// The sample the held counts make (a channel the device lacks reads 0).
    pub fn sample(&self) -> ImuSample {
        let mut values = [0.0; CHANNELS];
        for ((value, count), per_count) in
            values.iter_mut().zip(self.counts).zip(self.axes.per_count)
        {
            *value = per_count.map_or(0.0, |k| f64::from(count) * k);
        }
        ImuSample { values }
    }
}

/// An opened IMU, not yet reading.
pub struct EvdevImu {
    target: EvdevTarget,
    path: PathBuf,
    device: RawDevice,
    axes: ImuAxes,
    resolutions: [Option<i32>; CHANNELS],
}

impl EvdevImu {
    /// Finds and opens the IMU (a device with the accelerometer property),
    /// reads its axes' resolutions and sets their fuzz to 0 (so every
    /// change is delivered).
    pub fn open(target: &EvdevTarget) -> Result<EvdevImu, SensorError> {
        let (path, device) = find(target, Wanted::Imu)?;
        let has: Vec<u16> = device
            .supported_absolute_axes()
            .map(|set| set.iter().map(|code| code.0).collect())
            .unwrap_or_default();
        let fd = device.as_raw_fd();
        let mut resolutions = [None; CHANNELS];
        for channel in Channel::ALL {
            let code = axis_code(channel);
            if !has.contains(&code) {
                continue;
            }
            let info = absinfo(fd, code).map_err(|e| SensorError::Io {
                what: format!("{}: cannot read the axes", path.display()),
                error: e,
            })?;
            if let Some(slot) = resolutions.get_mut(channel.index()) {
                *slot = Some(info.resolution);
            }
            clear_fuzz(fd, code).map_err(|e| SensorError::Io {
                what: format!(
                    "{}: cannot set the axes' fuzz to 0 (EVIOCSABS; small movements would be dropped)",
                    path.display()
                ),
                error: e,
            })?;
        }
        let axes =
            ImuAxes::from_resolutions(resolutions).map_err(|message| SensorError::WrongDevice {
                device: format!("{} ({:?})", path.display(), device.name().unwrap_or("?")),
                message,
            })?;
        Ok(EvdevImu {
            target: target.clone(),
            path,
            device,
            axes,
            resolutions,
        })
    }

    /// The channels it gives.
    pub fn channels(&self) -> Channels {
        self.axes.channels()
    }
}

/// The counts the device holds now, per channel.
fn counts_now(device: &RawDevice) -> io::Result<[i32; CHANNELS]> {
    let state = device.get_abs_state()?;
    let mut counts = [0; CHANNELS];
    for (count, info) in counts.iter_mut().zip(state.iter()) {
        *count = info.value;
    }
    Ok(counts)
}

impl Sensor for EvdevImu {
    type Samples = ImuRing;

    fn describe(&self) -> String {
        let scale: Vec<String> = Channel::ALL
            .into_iter()
            .filter_map(|c| {
                let r = self.resolutions.get(c.index()).copied().flatten()?;
                Some(format!(
                    "{c} {r}/{}",
                    if c.is_acceleration() { "g" } else { "°/s" }
                ))
            })
            .collect();
        format!(
            "{} ({:?} at {}; IMU {})",
            self.target,
            self.device.name().unwrap_or("?"),
            self.path.display(),
            scale.join(", ")
        )
    }

    fn start(self) -> Result<Started<ImuRing>, SensorError> {
        let counts = counts_now(&self.device).map_err(|e| SensorError::Io {
            what: format!("{}: cannot read its state", self.path.display()),
            error: e,
        })?;
        let (mut feed, samples) = imu_ring();
        let mut frames = ImuFrames::new(self.axes, counts);
        feed.push(frames.sample());
        let device = self.device;
        let producer = Producer::spawn("sensor-evdev-imu", move |stop, _log| {
            // The device gone (or the stop) ends the loop; `feed` dropped
            // tells the control thread the IMU is lost.
            let _ = read_frames(&device, &mut frames, &mut feed, || {
                stop.load(Ordering::Relaxed)
            });
            Ok(())
        })?;
        Ok(Started { samples, producer })
    }
}

/// Reads frames into `feed` until `stopping` or the device fails.
fn read_frames(
    device: &RawDevice,
    frames: &mut ImuFrames,
    feed: &mut ImuFeed,
    stopping: impl Fn() -> bool,
) -> io::Result<()> {
    let fd = device.as_raw_fd();
    let mut buffer = [0u8; EVENT_BYTES * 64];
    while !stopping() {
        let read = match poll_read(fd, &mut buffer, HOLD_MS)? {
            Polled::Read(n) => buffer.get(..n).unwrap_or_default(),
            Polled::Interrupted => continue,
            Polled::TimedOut => {
                // Nothing changed: the device holds its values.
                feed.push(frames.sample());
                continue;
            }
        };
        let mut dropped = false;
        for event in parse_events(read) {
            if event.kind == EV_SYN && event.code == SYN_DROPPED {
                dropped = true;
            } else if let Some(sample) = frames.apply(event) {
                feed.push(sample);
            }
        }
        if dropped {
            // The kernel's buffer overflowed: take the state itself.
            frames.resync(counts_now(device)?);
            feed.push(frames.sample());
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn abs(code: u16, value: i32) -> InputEvent {
        InputEvent {
            kind: EV_ABS,
            code,
            value,
        }
    }

    const REPORT: InputEvent = InputEvent {
        kind: EV_SYN,
        code: SYN_REPORT,
        value: 0,
    };

    #[test]
    fn counts_become_si_units_by_each_axis_resolution() {
        // 4096 counts per g, 1000 counts per °/s (a DualShock 4 gives 8192
        // and 1024).
        let axes = ImuAxes::from_resolutions([
            Some(4096),
            Some(4096),
            Some(4096),
            Some(1000),
            Some(1000),
            Some(1000),
        ])
        .unwrap();
        assert_eq!(axes.channels(), Channels::ALL);
        let mut frames = ImuFrames::new(axes, [0, 0, 4096, 0, 0, 0]);
        assert_eq!(frames.apply(abs(0, 2048)), None);
        assert_eq!(frames.apply(abs(3, 180_000)), None);
        let sample = frames.apply(REPORT).unwrap();
        assert_eq!(sample.values[0], 2048.0 * STANDARD_GRAVITY / 4096.0);
        assert_eq!(sample.values[2], STANDARD_GRAVITY);
        // 180 °/s is π rad/s.
        assert!((sample.values[3] - PI).abs() < 1e-12, "{sample:?}");
        // A frame that changes one axis keeps the others.
        frames.apply(abs(1, -4096));
        let next = frames.apply(REPORT).unwrap();
        assert_eq!(next.values[0], sample.values[0]);
        assert_eq!(next.values[1], -STANDARD_GRAVITY);
        // Other event kinds change nothing.
        let key = InputEvent {
            kind: 1,
            code: 0,
            value: 1,
        };
        assert_eq!(frames.apply(key), None);
        assert_eq!(frames.sample(), next);
    }

    #[test]
    fn an_accelerometer_alone_gives_its_three_channels_and_zero_rates() {
        let axes =
            ImuAxes::from_resolutions([Some(1000), Some(1000), Some(1000), None, None, None])
                .unwrap();
        assert_eq!(axes.channels().to_string(), "ax,ay,az");
        let mut frames = ImuFrames::new(axes, [0, 0, 1000, 77, 77, 77]);
        assert_eq!(frames.sample().rate(), [0.0; 3]);
        frames.resync([1000, 0, 0, 0, 0, 0]);
        assert_eq!(frames.sample().acceleration(), [STANDARD_GRAVITY, 0.0, 0.0]);
    }

    #[test]
    fn axes_without_units_or_without_any_channel_are_refused() {
        let e = ImuAxes::from_resolutions([Some(4096), Some(0), Some(4096), None, None, None])
            .unwrap_err();
        assert!(
            e.contains("ABS_Y reports the resolution 0: its counts per g are unknown"),
            "{e}"
        );
        let e = ImuAxes::from_resolutions([None, None, None, None, None, Some(-1)]).unwrap_err();
        assert!(e.contains("ABS_RZ"), "{e}");
        assert!(e.contains("rad/s"), "{e}");
        let e = ImuAxes::from_resolutions([None; CHANNELS]).unwrap_err();
        assert!(e.contains("none of ABS_X"), "{e}");
    }
}
