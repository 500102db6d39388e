//! What sensors this machine has (`sipnpuff sensors`): input devices with
//! absolute axes or keys (head-worn IMUs marked), IIO voltage channels
//! and IMUs, and serial ports, each with the `--sensor` line that uses it. The
//! clinician's first step.

use std::path::{Path, PathBuf};

use evdev::raw_stream::RawDevice;
use serde::Serialize;

use crate::control::imu::Channels;
use crate::sensor::evdev::{event_nodes, is_accelerometer};

/// One absolute axis of an input device.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Axis {
    /// Its Linux name (`ABS_X`).
    pub name: String,
    /// Reported minimum.
    pub min: i32,
    /// Reported maximum.
    pub max: i32,
    /// Position now.
    pub value: i32,
}

/// Something that may be a sip-and-puff sensor.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum FoundSensor {
    /// An input device.
    Evdev {
        /// `/dev/input/eventN`.
        path: PathBuf,
        /// Its name (empty if it could not be opened).
        name: String,
        /// Absolute axes.
        axes: Vec<Axis>,
        /// Keys and buttons, by name.
        keys: Vec<String>,
        /// A head-worn IMU (the accelerometer property): for head
        /// gestures, not breaths.
        imu: bool,
        /// Why it could not be opened, if it could not.
        error: Option<String>,
        /// How to use it.
        use_with: Vec<String>,
    },
    /// An IIO voltage channel.
    Iio {
        /// Its `_raw` file.
        path: PathBuf,
        /// The IIO device's name.
        device: String,
        /// Its scale, mV per count.
        scale_mv: Option<f64>,
        /// Its value now.
        raw: Option<i64>,
        /// Why it could not be read, if it could not.
        error: Option<String>,
        /// How to use it.
        use_with: Vec<String>,
    },
    /// An IIO IMU: a device with accel or anglvel channels.
    #[serde(rename = "iio_imu")]
    IioImu {
        /// The device's directory.
        path: PathBuf,
        /// The IIO device's name.
        device: String,
        /// Its IMU channels (`ax,ay,az,gx,gy,gz`), or why they cannot be
        /// read.
        channels: Result<String, String>,
        /// How to use it.
        use_with: Vec<String>,
    },
    /// A serial port with a device behind it.
    Serial {
        /// `/dev/ttyACM0`, …
        path: PathBuf,
        /// What the system says it is.
        description: String,
        /// How to use it.
        use_with: Vec<String>,
    },
}

impl FoundSensor {
    /// The `--sensor` lines that use it.
    pub fn use_with(&self) -> &[String] {
        match self {
            FoundSensor::Evdev { use_with, .. }
            | FoundSensor::Iio { use_with, .. }
            | FoundSensor::IioImu { use_with, .. }
            | FoundSensor::Serial { use_with, .. } => use_with,
        }
    }
}

/// Everything found, input devices first.
pub fn list() -> Vec<FoundSensor> {
    let mut found: Vec<FoundSensor> = event_nodes()
        .iter()
        .filter_map(|p| evdev_device(p))
        .collect();
    found.extend(iio_channels(Path::new("/sys/bus/iio/devices")));
    found.extend(serial_ports());
    found
}

/// An input device, if it has absolute axes or keys (or cannot be opened:
/// then it is listed with the reason).
fn evdev_device(path: &Path) -> Option<FoundSensor> {
    let device = match RawDevice::open(path) {
        Ok(device) => device,
        Err(e) => {
            let error = match e.kind() {
                std::io::ErrorKind::PermissionDenied => {
                    format!(
                        "permission denied: {}",
                        crate::sensor::evdev::PERMISSION_FIX
                    )
                }
                _ => e.to_string(),
            };
            return Some(FoundSensor::Evdev {
                path: path.to_path_buf(),
                name: String::new(),
                axes: Vec::new(),
                keys: Vec::new(),
                imu: false,
                error: Some(error),
                use_with: Vec::new(),
            });
        }
    };
    let name = device.name().unwrap_or("").to_string();
    let state = device.get_abs_state().ok();
    let axes: Vec<Axis> = device
        .supported_absolute_axes()
        .map(|set| {
            set.iter()
                .map(|code| {
                    let info = state
                        .as_ref()
                        .and_then(|s| s.get(usize::from(code.0)).copied());
                    Axis {
                        name: format!("{code:?}"),
                        min: info.map_or(0, |i| i.minimum),
                        max: info.map_or(0, |i| i.maximum),
                        value: info.map_or(0, |i| i.value),
                    }
                })
                .collect()
        })
        .unwrap_or_default();
    let keys: Vec<String> = device
        .supported_keys()
        .map(|set| set.iter().map(|k| format!("{k:?}")).collect())
        .unwrap_or_default();
    if axes.is_empty() && keys.is_empty() {
        return None;
    }
    let target = if name.is_empty() {
        format!("evdev:{}", path.display())
    } else {
        format!("evdev:name={name}")
    };
    let imu = is_accelerometer(&device);
    let mut use_with = Vec::new();
    if imu {
        use_with.push(format!(
            "--sensor '{target}' with [gestures] set = \"SET.toml\"   (a head-worn IMU: head gestures, docs/gestures.md)"
        ));
    } else if let Some(axis) = axes.first() {
        use_with.push(format!(
            "--sensor '{target}'   (pressure on an axis; [sensor.evdev] axis = \"{}\" if not ABS_X)",
            axis.name
        ));
    }
    if !imu && keys.len() >= 2 {
        use_with.push(format!(
            "--sensor '{target}' with [sensor.evdev] input = \"switches\", sip_keys = [\"{}\"], puff_keys = [\"{}\"]   (switch closures; pick the keys the device sends)",
            keys[0], keys[1]
        ));
    }
    Some(FoundSensor::Evdev {
        path: path.to_path_buf(),
        name,
        axes,
        keys,
        imu,
        error: None,
        use_with,
    })
}

/// The voltage channels under an IIO devices directory.
pub fn iio_channels(root: &Path) -> Vec<FoundSensor> {
    let mut devices: Vec<PathBuf> = std::fs::read_dir(root)
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("iio:device"))
        })
        .collect();
    devices.sort();
    let mut found = Vec::new();
    for dir in devices {
        let device = std::fs::read_to_string(dir.join("name"))
            .map(|s| s.trim().to_string())
            .unwrap_or_default();
        if crate::sensor::iio_imu::is_imu(&dir) {
            let channels = crate::sensor::iio_imu::imu_channels(&dir).map(|found| {
                found
                    .iter()
                    .fold(Channels::NONE, |set, (c, _)| set.with(*c))
                    .to_string()
            });
            let mut use_with = vec![format!(
                "--sensor iio:{} with [gestures] set = \"SET.toml\"   (a head-worn IMU: head gestures, docs/gestures.md)",
                dir.display()
            )];
            if dir.join("buffer/enable").exists() {
                let trigger = std::fs::read_to_string(dir.join("trigger/current_trigger"))
                    .map(|t| t.trim().to_string())
                    .unwrap_or_default();
                use_with.push(format!(
                    "and [sensor.iio] buffered = true to read its buffer at its own rate ({})",
                    if trigger.is_empty() {
                        "no trigger set: name its data-ready trigger as [sensor.iio] trigger"
                            .to_string()
                    } else {
                        format!("trigger {trigger}")
                    }
                ));
            }
            found.push(FoundSensor::IioImu {
                use_with,
                path: dir.clone(),
                device: device.clone(),
                channels,
            });
        }
        let mut channels: Vec<PathBuf> = std::fs::read_dir(&dir)
            .into_iter()
            .flatten()
            .flatten()
            .map(|e| e.path())
            .filter(|p| {
                p.file_name()
                    .and_then(|n| n.to_str())
                    .is_some_and(|n| n.starts_with("in_voltage") && n.ends_with("_raw"))
            })
            .collect();
        channels.sort();
        for path in channels {
            let raw = std::fs::read(&path);
            let (raw, error) = match raw {
                Ok(bytes) => match crate::sensor::iio::parse_raw(&bytes) {
                    Ok(v) => (Some(v), None),
                    Err(e) => (None, Some(e)),
                },
                Err(e) => (None, Some(e.to_string())),
            };
            let scale_mv = scale_of(&path);
            found.push(FoundSensor::Iio {
                use_with: vec![format!("--sensor iio:{}", path.display())],
                path,
                device: device.clone(),
                scale_mv,
                raw,
                error,
            });
        }
    }
    found
}

/// A channel's scale, from its own file or the shared one.
fn scale_of(raw: &Path) -> Option<f64> {
    let name = raw.file_name()?.to_str()?.strip_suffix("_raw")?;
    let shared = name.trim_end_matches(|c: char| c.is_ascii_digit());
    [format!("{name}_scale"), format!("{shared}_scale")]
        .iter()
        .find_map(|f| std::fs::read_to_string(raw.parent()?.join(f)).ok())
        .and_then(|s| s.trim().parse().ok())
}

/// Serial ports with a device behind them (USB, or a UART the kernel
/// bound a driver to).
fn serial_ports() -> Vec<FoundSensor> {
    let Ok(ports) = serialport::available_ports() else {
        return Vec::new();
    };
    ports
        .into_iter()
        .map(|port| {
            let description = match port.port_type {
                serialport::SerialPortType::UsbPort(usb) => format!(
                    "USB {:04x}:{:04x}{}{}",
                    usb.vid,
                    usb.pid,
                    usb.manufacturer
                        .map(|m| format!(" {m}"))
                        .unwrap_or_default(),
                    usb.product.map(|p| format!(" {p}")).unwrap_or_default()
                ),
                serialport::SerialPortType::PciPort => "PCI".into(),
                serialport::SerialPortType::BluetoothPort => "Bluetooth".into(),
                serialport::SerialPortType::Unknown => "serial port".into(),
            };
            let path = PathBuf::from(&port.port_name);
            FoundSensor::Serial {
                use_with: vec![
                    format!(
                        "--sensor serial:{}   (one value per line, volts; [sensor.serial] format = \"counts\", \"flipmouse\" or \"lipsync\" for others, \"imu\" for a head-worn IMU's `ax,ay,az,gx,gy,gz` lines)",
                        path.display()
                    ),
                ],
                path,
                description,
            }
        })
        .collect()
}

/// Text for people.
pub fn to_text(found: &[FoundSensor]) -> String {
    let mut out = String::new();
    if found.is_empty() {
        out +=
            "no input device with axes or keys, no IIO voltage channel and no serial port found\n";
        out += "(plug the sensor in; if it is plugged in, check `dmesg` for its driver)\n";
    }
    for f in found {
        match f {
            FoundSensor::Evdev {
                path,
                name,
                axes,
                keys,
                imu,
                error,
                ..
            } => {
                out += &format!(
                    "evdev   {}  {name:?}{}\n",
                    path.display(),
                    if *imu { "  (an IMU)" } else { "" }
                );
                if let Some(e) = error {
                    out += &format!("        cannot open it: {e}\n");
                }
                if !axes.is_empty() {
                    let list: Vec<String> = axes
                        .iter()
                        .map(|a| format!("{} {}..{} (now {})", a.name, a.min, a.max, a.value))
                        .collect();
                    out += &format!("        axes: {}\n", list.join(", "));
                }
                if !keys.is_empty() {
                    let shown: Vec<&str> = keys.iter().take(16).map(String::as_str).collect();
                    let more = keys.len().saturating_sub(shown.len());
                    out += &format!(
                        "        keys: {}{}\n",
                        shown.join(", "),
                        if more > 0 {
                            format!(" and {more} more")
                        } else {
                            String::new()
                        }
                    );
                }
            }
            FoundSensor::Iio {
                path,
                device,
                scale_mv,
                raw,
                error,
                ..
            } => {
                out += &format!("iio     {}  ({device:?}", path.display());
                if let Some(scale) = scale_mv {
                    out += &format!(", {scale} mV per count");
                    if let Some(raw) = raw {
                        out += &format!(", now {raw} = {:.4} V", *raw as f64 * scale / 1000.0);
                    }
                }
                out += ")\n";
                if let Some(e) = error {
                    out += &format!("        cannot read it: {e}\n");
                }
            }
            FoundSensor::IioImu {
                path,
                device,
                channels,
                ..
            } => {
                out += &format!("iio     {}  ({device:?}, an IMU", path.display());
                match channels {
                    Ok(channels) => out += &format!(": {channels})\n"),
                    Err(e) => out += &format!(")\n        cannot read it: {e}\n"),
                }
            }
            FoundSensor::Serial {
                path, description, ..
            } => {
                out += &format!("serial  {}  ({description})\n", path.display());
            }
        }
        for u in f.use_with() {
            out += &format!("        use:  {u}\n");
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iio_voltage_channels_are_listed_with_scale_value_and_sensor_line() {
        let root = std::env::temp_dir().join(format!("sipnpuff-iio-list-{}", std::process::id()));
        let dev = root.join("iio:device0");
        std::fs::create_dir_all(&dev).unwrap();
        std::fs::write(dev.join("name"), "ads1015\n").unwrap();
        std::fs::write(dev.join("in_voltage0_raw"), "40000\n").unwrap();
        std::fs::write(dev.join("in_voltage1_raw"), "bad\n").unwrap();
        std::fs::write(dev.join("in_voltage_scale"), "0.0625\n").unwrap();
        std::fs::write(dev.join("in_temp_raw"), "1\n").unwrap();
        let imu = root.join("iio:device1");
        std::fs::create_dir_all(&imu).unwrap();
        std::fs::write(imu.join("name"), "mpu6050\n").unwrap();
        for axis in ["x", "y", "z"] {
            std::fs::write(imu.join(format!("in_anglvel_{axis}_raw")), "3\n").unwrap();
        }
        std::fs::write(imu.join("in_anglvel_scale"), "0.000133090\n").unwrap();
        std::fs::create_dir_all(imu.join("buffer")).unwrap();
        std::fs::write(imu.join("buffer/enable"), "0\n").unwrap();
        let found = iio_channels(&root);
        assert_eq!(found.len(), 3, "{found:?}");
        let text = to_text(&found);
        assert!(
            text.contains("(\"ads1015\", 0.0625 mV per count, now 40000 = 2.5000 V)"),
            "{text}"
        );
        assert!(
            text.contains(&format!(
                "use:  --sensor iio:{}",
                dev.join("in_voltage0_raw").display()
            )),
            "{text}"
        );
        assert!(
            text.contains("cannot read it: \"bad\" is not an integer"),
            "{text}"
        );
        assert!(
            text.contains(&format!(
                "iio     {}  (\"mpu6050\", an IMU: gx,gy,gz)\n        use:  --sensor iio:{} with [gestures] set",
                imu.display(),
                imu.display()
            )),
            "{text}"
        );
        assert!(
            text.contains(
                "use:  and [sensor.iio] buffered = true to read its buffer at its own rate (no trigger set: name its data-ready trigger"
            ),
            "{text}"
        );
        std::fs::remove_dir_all(&root).ok();
    }
}
