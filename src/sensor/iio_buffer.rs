//! An IIO device's buffered interface: the kernel captures the chosen
//! channels at each firing of the device's trigger (its data-ready
//! interrupt) and queues them as binary scans, read from
//! `/dev/iio:deviceN`. One `read` takes every scan queued, so the rate is
//! the device's own, not what sysfs reads keep up with.
//!
//! Each channel's place in a scan follows the IIO ABI: the enabled
//! channels in the order of their `scan_elements/*_index`, each aligned
//! to its own size, the scan padded to its largest channel; each value as
//! its `scan_elements/*_type` says (`le:s16/16>>0`: little-endian, signed,
//! 16 bits of 16, not shifted).

use std::fs::File;
use std::io::{self, Read};
use std::os::unix::fs::OpenOptionsExt;
use std::os::unix::io::AsRawFd;
use std::path::{Path, PathBuf};

/// How one channel's value lies in a scan (its `_type` file).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ScanType {
    /// `be` rather than `le`.
    pub big_endian: bool,
    /// `s` rather than `u`: the value is sign-extended from `real_bits`.
    pub signed: bool,
    /// The bits that carry the value.
    pub real_bits: u32,
    /// The bits it occupies in the scan (8, 16, 32 or 64).
    pub storage_bits: u32,
    /// How far right the value is shifted within its storage.
    pub shift: u32,
}

impl ScanType {
    /// Parses a `_type` file's text: `[be|le]:[s|u]BITS/STORAGE>>SHIFT`.
    /// A repeated channel (`X2`) is refused: no IMU channel is one.
    pub fn parse(text: &str) -> Result<ScanType, String> {
        let text = text.trim();
        let bad = || format!("{text:?} is not a scan element type such as le:s16/16>>0");
        let (endian, rest) = text.split_once(':').ok_or_else(bad)?;
        let big_endian = match endian {
            "be" => true,
            "le" => false,
            _ => return Err(bad()),
        };
        let mut chars = rest.chars();
        let signed = match chars.next() {
            Some('s') => true,
            Some('u') => false,
            _ => return Err(bad()),
        };
        let (bits, rest) = chars.as_str().split_once('/').ok_or_else(bad)?;
        let (storage, shift) = rest.split_once(">>").ok_or_else(bad)?;
        if storage.contains('X') {
            return Err(format!("{text:?}: a repeated channel is not read"));
        }
        let number = |s: &str| s.parse::<u32>().map_err(|_| bad());
        let scan = ScanType {
            big_endian,
            signed,
            real_bits: number(bits)?,
            storage_bits: number(storage)?,
            shift: number(shift)?,
        };
        if !matches!(scan.storage_bits, 8 | 16 | 32 | 64)
            || scan.real_bits == 0
            || scan.real_bits + scan.shift > scan.storage_bits
        {
            return Err(bad());
        }
        Ok(scan)
    }

    /// The bytes it occupies in a scan.
    pub fn bytes(&self) -> usize {
        self.storage_bits as usize / 8
    }

    /// The value in `bytes` (exactly [`ScanType::bytes`] long).
    pub fn decode(&self, bytes: &[u8]) -> i64 {
        let mut word = [0u8; 8];
        let n = self.bytes().min(bytes.len());
        let stored = if self.big_endian {
            word[8 - n..].copy_from_slice(&bytes[..n]);
            u64::from_be_bytes(word)
        } else {
            word[..n].copy_from_slice(&bytes[..n]);
            u64::from_le_bytes(word)
        };
        let value = stored >> self.shift;
        let unused = 64 - self.real_bits;
        if self.signed {
            ((value << unused) as i64) >> unused
        } else {
            ((value << unused) >> unused) as i64
        }
    }
}

/// Where each enabled channel lies in a scan, and the scan's length.
/// `elements` are the enabled channels' scan indices and types; the
/// offsets come back in the same order.
pub fn scan_layout(elements: &[(u32, ScanType)]) -> (Vec<usize>, usize) {
    let mut order: Vec<usize> = (0..elements.len()).collect();
    order.sort_by_key(|&i| elements[i].0);
    let mut offsets = vec![0; elements.len()];
    let mut length = 0usize;
    let mut largest = 1usize;
    for i in order {
        let size = elements[i].1.bytes();
        length = length.next_multiple_of(size);
        offsets[i] = length;
        length += size;
        largest = largest.max(size);
    }
    (offsets, length.next_multiple_of(largest))
}

/// A device's buffer, set up to capture some of its channels and enabled;
/// disabled again when dropped.
pub struct IioBuffer {
    dir: PathBuf,
    device: File,
    /// Each wanted channel's offset and type in a scan, in the order asked.
    fields: Vec<(usize, ScanType)>,
    scan_bytes: usize,
    trigger: Option<String>,
}

/// Scans the buffer holds before the kernel drops the oldest.
const BUFFER_SCANS: usize = 128;

/// What a deploying engineer does when the buffer's files may not be
/// written.
pub const BUFFER_PERMISSION_FIX: &str = "the buffer's sysfs files and /dev/iio:deviceN belong to root: run as root, or add a udev rule that gives them to the service's group (docs/sensors.md, \"An IIO IMU\")";

fn write_attribute(path: &Path, value: &str) -> Result<(), String> {
    std::fs::write(path, value).map_err(|e| {
        let fix = if e.kind() == io::ErrorKind::PermissionDenied {
            format!(" ({BUFFER_PERMISSION_FIX})")
        } else {
            String::new()
        };
        format!("cannot write {value:?} to {}: {e}{fix}", path.display())
    })
}

fn read_attribute(path: &Path) -> Result<String, String> {
    std::fs::read_to_string(path)
        .map(|s| s.trim().to_string())
        .map_err(|e| format!("cannot read {}: {e}", path.display()))
}

/// The names of the triggers the kernel has (`/sys/bus/iio/devices/trigger*/name`).
fn triggers(dir: &Path) -> Vec<String> {
    let devices = dir.parent().unwrap_or(Path::new("/sys/bus/iio/devices"));
    let mut names: Vec<String> = ["/sys/bus/iio/devices", &devices.to_string_lossy()]
        .iter()
        .filter_map(|d| std::fs::read_dir(d).ok())
        .flatten()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with("trigger"))
        .filter_map(|e| std::fs::read_to_string(e.path().join("name")).ok())
        .map(|n| n.trim().to_string())
        .collect();
    names.sort();
    names.dedup();
    names
}

impl IioBuffer {
    /// Sets up the buffer of the device in `dir` to capture `channels`
    /// (their sysfs names, e.g. `in_accel_x`) and nothing else, with
    /// `trigger` as its trigger (empty: the one it has), and enables it.
    /// The device's node is `dev` (`/dev/iio:deviceN`).
    pub fn open(
        dir: &Path,
        dev: &Path,
        channels: &[&str],
        trigger: &str,
    ) -> Result<IioBuffer, String> {
        let enable = dir.join("buffer/enable");
        let elements = dir.join("scan_elements");
        if !enable.exists() || !elements.is_dir() {
            return Err(format!(
                "{} has no buffered interface (no buffer/enable or scan_elements/): set [sensor.iio] buffered = false to read it through sysfs",
                dir.display()
            ));
        }
        let device = std::fs::OpenOptions::new()
            .read(true)
            .custom_flags(libc::O_NONBLOCK)
            .open(dev)
            .map_err(|e| match e.kind() {
                io::ErrorKind::PermissionDenied => {
                    format!(
                        "cannot open {}: {e} ({BUFFER_PERMISSION_FIX})",
                        dev.display()
                    )
                }
                _ if e.raw_os_error() == Some(libc::EBUSY) => format!(
                    "{} is busy: another program reads its buffer",
                    dev.display()
                ),
                _ => format!("cannot open {}: {e}", dev.display()),
            })?;
        // A run that was killed may have left it enabled; nothing may be
        // changed while it is.
        write_attribute(&enable, "0")?;
        let trigger = Self::choose_trigger(dir, trigger)?;
        let mut fields = Vec::new();
        let mut wanted = Vec::new();
        let listing = std::fs::read_dir(&elements)
            .map_err(|e| format!("cannot list {}: {e}", elements.display()))?;
        let mut enables: Vec<PathBuf> = listing
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.to_string_lossy().ends_with("_en"))
            .collect();
        enables.sort();
        for path in &enables {
            let name = path
                .file_name()
                .map(|n| n.to_string_lossy().trim_end_matches("_en").to_string())
                .unwrap_or_default();
            let on = channels.contains(&name.as_str());
            write_attribute(path, if on { "1" } else { "0" })?;
        }
        for name in channels {
            let index = read_attribute(&elements.join(format!("{name}_index")))?;
            let index: u32 = index
                .parse()
                .map_err(|_| format!("{name}_index reads {index:?}, not a number"))?;
            let kind = ScanType::parse(&read_attribute(&elements.join(format!("{name}_type")))?)
                .map_err(|e| format!("{name}_type: {e}"))?;
            wanted.push((index, kind));
        }
        let (offsets, scan_bytes) = scan_layout(&wanted);
        fields.extend(offsets.into_iter().zip(wanted.iter().map(|w| w.1)));
        let length = dir.join("buffer/length");
        if length.exists() {
            write_attribute(&length, &BUFFER_SCANS.to_string())?;
        }
        write_attribute(&enable, "1").map_err(|e| match &trigger {
            Some(t) => format!("{e}; is its trigger {t} one the device accepts?"),
            None => e,
        })?;
        Ok(IioBuffer {
            dir: dir.to_path_buf(),
            device,
            fields,
            scan_bytes,
            trigger,
        })
    }

    /// The trigger to use: `asked` written to `trigger/current_trigger`,
    /// else the one set there; an error naming the kernel's triggers when
    /// the device needs one and has none. `None` for a device without
    /// triggers (its own FIFO fills the buffer).
    fn choose_trigger(dir: &Path, asked: &str) -> Result<Option<String>, String> {
        let current = dir.join("trigger/current_trigger");
        if !current.exists() {
            return if asked.is_empty() {
                Ok(None)
            } else {
                Err(format!(
                    "{} takes no trigger (no trigger/current_trigger): leave [sensor.iio] trigger empty",
                    dir.display()
                ))
            };
        }
        if !asked.is_empty() {
            write_attribute(&current, asked)
                .map_err(|e| format!("{e}; the triggers are: {}", triggers(dir).join(", ")))?;
        }
        let set = read_attribute(&current)?;
        if set.is_empty() {
            let known = triggers(dir);
            return Err(format!(
                "its buffer needs a trigger and none is set: name one as [sensor.iio] trigger ({})",
                if known.is_empty() {
                    "the kernel has none: the device's data-ready interrupt is not wired, so read it through sysfs with buffered = false".to_string()
                } else {
                    format!("the kernel's: {}", known.join(", "))
                }
            ));
        }
        Ok(Some(set))
    }

    /// The trigger it captures on, if it has one.
    pub fn trigger(&self) -> Option<&str> {
        self.trigger.as_deref()
    }

    /// The bytes of one scan.
    pub fn scan_bytes(&self) -> usize {
        self.scan_bytes
    }

    /// Waits up to `timeout_ms` for scans and hands each one's raw values
    /// (in the order the channels were asked) to `each`. `Ok(0)` when none
    /// came; an error when the device is gone.
    pub fn read(&mut self, timeout_ms: i32, mut each: impl FnMut(&[i64])) -> io::Result<usize> {
        let mut poll = libc::pollfd {
            fd: self.device.as_raw_fd(),
            events: libc::POLLIN,
            revents: 0,
        };
        // SAFETY: one valid pollfd, its count 1.
        let ready = unsafe { libc::poll(&mut poll, 1, timeout_ms) };
        if ready < 0 {
            let e = io::Error::last_os_error();
            return if e.kind() == io::ErrorKind::Interrupted {
                Ok(0)
            } else {
                Err(e)
            };
        }
        // Read even when poll saw nothing: an unbound device's buffer
        // polls as empty, and only `read` says it is gone (ENODEV).
        let mut bytes = [0u8; 1024];
        let whole = bytes.len() / self.scan_bytes.max(1) * self.scan_bytes.max(1);
        let n = match self.device.read(&mut bytes[..whole]) {
            Ok(0) => return Err(io::Error::from_raw_os_error(libc::ENODEV)),
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => return Ok(0),
            Err(e) => return Err(e),
        };
        let mut values = [0i64; 8];
        let mut scans = 0;
        for scan in bytes[..n].chunks_exact(self.scan_bytes.max(1)) {
            for ((offset, kind), value) in self.fields.iter().zip(values.iter_mut()) {
                *value = kind.decode(scan.get(*offset..).unwrap_or_default());
            }
            each(&values[..self.fields.len().min(values.len())]);
            scans += 1;
        }
        Ok(scans)
    }
}

impl Drop for IioBuffer {
    fn drop(&mut self) {
        // Best effort: the device may be gone.
        let _ = std::fs::write(self.dir.join("buffer/enable"), "0");
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn kind(text: &str) -> ScanType {
        ScanType::parse(text).unwrap()
    }

    #[test]
    fn scan_types_are_read_as_the_iio_abi_writes_them() {
        assert_eq!(
            kind("le:s16/16>>0\n"),
            ScanType {
                big_endian: false,
                signed: true,
                real_bits: 16,
                storage_bits: 16,
                shift: 0
            }
        );
        assert_eq!(kind("be:u12/16>>4").shift, 4);
        for bad in [
            "",
            "le",
            "xe:s16/16>>0",
            "le:q16/16>>0",
            "le:s16/12>>0",
            "le:s16/16>>4",
            "le:s16/16X2>>0",
            "le:s0/16>>0",
        ] {
            assert!(ScanType::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn values_are_decoded_with_their_endianness_sign_and_shift() {
        assert_eq!(kind("le:s16/16>>0").decode(&[0x00, 0x80]), -32768);
        assert_eq!(kind("le:s16/16>>0").decode(&[0xff, 0x7f]), 32767);
        assert_eq!(kind("be:s16/16>>0").decode(&[0xff, 0xfe]), -2);
        // A 12-bit ADC value stored in the top of 16 bits, big-endian.
        assert_eq!(kind("be:s12/16>>4").decode(&[0x80, 0x00]), -2048);
        assert_eq!(kind("be:u12/16>>4").decode(&[0x80, 0x0f]), 2048);
        assert_eq!(kind("le:u8/8>>0").decode(&[200]), 200);
        assert_eq!(
            kind("le:s32/32>>0").decode(&(-70000i32).to_le_bytes()),
            -70000
        );
        assert_eq!(
            kind("le:s64/64>>0").decode(&i64::MIN.to_le_bytes()),
            i64::MIN
        );
    }

    #[test]
    fn a_scan_is_laid_out_by_index_with_each_channel_aligned() {
        let s16 = kind("le:s16/16>>0");
        let s64 = kind("le:s64/64>>0");
        let u8_ = kind("le:u8/8>>0");
        // The BMI160's six channels: gyro (4, 5, 6) before accel (7, 8, 9).
        let bmi: Vec<(u32, ScanType)> = [7, 8, 9, 4, 5, 6].iter().map(|&i| (i, s16)).collect();
        assert_eq!(scan_layout(&bmi), (vec![6, 8, 10, 0, 2, 4], 12));
        // A byte, then a 64-bit timestamp aligned to 8, the scan to 16.
        assert_eq!(scan_layout(&[(0, u8_), (3, s64)]), (vec![0, 8], 16));
        // Three 16-bit values padded to their size: 6 bytes.
        assert_eq!(
            scan_layout(&[(2, s16), (0, s16), (1, s16)]),
            (vec![4, 0, 2], 6)
        );
    }

    /// A device directory laid out as sysfs lays out a BMI160's buffer,
    /// and a file standing for its node holding `scans`.
    fn bmi160(name: &str, trigger: &str, scans: &[[i16; 6]]) -> (PathBuf, PathBuf) {
        let dir =
            std::env::temp_dir().join(format!("sipnpuff-iio-buffer-{name}-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("scan_elements")).unwrap();
        std::fs::create_dir_all(dir.join("buffer")).unwrap();
        std::fs::create_dir_all(dir.join("trigger")).unwrap();
        std::fs::write(dir.join("buffer/enable"), "0\n").unwrap();
        std::fs::write(dir.join("buffer/length"), "2\n").unwrap();
        std::fs::write(dir.join("trigger/current_trigger"), format!("{trigger}\n")).unwrap();
        for (channel, index) in [
            ("in_anglvel_x", 4),
            ("in_anglvel_y", 5),
            ("in_anglvel_z", 6),
            ("in_accel_x", 7),
            ("in_accel_y", 8),
            ("in_accel_z", 9),
        ] {
            let element = |what: &str| dir.join("scan_elements").join(format!("{channel}_{what}"));
            std::fs::write(element("en"), "0\n").unwrap();
            std::fs::write(element("index"), format!("{index}\n")).unwrap();
            std::fs::write(element("type"), "le:s16/16>>0\n").unwrap();
        }
        std::fs::write(dir.join("scan_elements/in_timestamp_en"), "1\n").unwrap();
        let node = dir.join("node");
        let bytes: Vec<u8> = scans
            .iter()
            .flat_map(|scan| scan.iter().flat_map(|v| v.to_le_bytes()))
            .collect();
        std::fs::write(&node, bytes).unwrap();
        (dir, node)
    }

    #[test]
    fn a_buffer_is_set_up_for_the_channels_asked_and_its_scans_decoded() {
        // Scans in the device's order: gyro x, y, z, then accel x, y, z.
        let (dir, node) = bmi160(
            "ok",
            "bmi160-dev0",
            &[[1, 2, 3, 4, 5, 6], [-1, -2, -3, 16384, 0, -16384]],
        );
        let asked = [
            "in_accel_x",
            "in_accel_y",
            "in_accel_z",
            "in_anglvel_x",
            "in_anglvel_y",
            "in_anglvel_z",
        ];
        let mut buffer = IioBuffer::open(&dir, &node, &asked, "").unwrap();
        let attribute = |p: &str| std::fs::read_to_string(dir.join(p)).unwrap();
        assert_eq!(attribute("buffer/enable"), "1");
        assert_eq!(attribute("buffer/length"), "128");
        assert_eq!(attribute("scan_elements/in_accel_z_en"), "1");
        assert_eq!(attribute("scan_elements/in_timestamp_en"), "0");
        assert_eq!(
            (buffer.scan_bytes(), buffer.trigger()),
            (12, Some("bmi160-dev0"))
        );
        let mut got = Vec::new();
        assert_eq!(buffer.read(0, |raws| got.push(raws.to_vec())).unwrap(), 2);
        // Each scan's values in the order asked: accel first.
        assert_eq!(
            got,
            [vec![4, 5, 6, 1, 2, 3], vec![16384, 0, -16384, -1, -2, -3]]
        );
        drop(buffer);
        assert_eq!(attribute("buffer/enable"), "0");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn a_buffer_without_a_trigger_or_without_a_buffer_is_refused_saying_what_to_do() {
        let (dir, node) = bmi160("untriggered", "", &[]);
        let e = IioBuffer::open(&dir, &node, &["in_accel_x"], "")
            .err()
            .unwrap_or_default();
        assert!(
            e.contains("needs a trigger and none is set: name one as [sensor.iio] trigger"),
            "{e}"
        );
        std::fs::remove_dir_all(dir.join("buffer")).unwrap();
        let e = IioBuffer::open(&dir, &node, &["in_accel_x"], "")
            .err()
            .unwrap_or_default();
        assert!(e.contains("has no buffered interface"), "{e}");
        assert!(e.contains("buffered = false"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// A scan type: storage, then the bits within it, then a shift that fits.
    fn scan_types() -> impl Strategy<Value = ScanType> {
        (
            prop::sample::select(vec![8u32, 16, 32, 64]),
            any::<bool>(),
            any::<bool>(),
        )
            .prop_flat_map(|(storage, big_endian, signed)| {
                (1..=storage).prop_flat_map(move |real_bits| {
                    (0..=storage - real_bits).prop_map(move |shift| ScanType {
                        big_endian,
                        signed,
                        real_bits,
                        storage_bits: storage,
                        shift,
                    })
                })
            })
    }

    proptest! {
        /// Any value in range, stored as the ABI says, reads back.
        #[test]
        fn decoding_inverts_encoding(value in any::<i64>(), kind in scan_types()) {
            let unused = 64 - kind.real_bits;
            let value = if kind.signed {
                (value << unused) >> unused
            } else {
                ((value as u64) << unused >> unused) as i64
            };
            let stored = ((value as u64) << unused >> unused) << kind.shift;
            let n = kind.bytes();
            let bytes = if kind.big_endian {
                stored.to_be_bytes()[8 - n..].to_vec()
            } else {
                stored.to_le_bytes()[..n].to_vec()
            };
            prop_assert_eq!(kind.decode(&bytes), value);
        }
    }
}
