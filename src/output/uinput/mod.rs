//! `--output uinput`: the computer's keyboard and pointer, as a virtual
//! input device made through `/dev/uinput` (kernel
//! `Documentation/input/uinput.rst`) with the evdev crate's
//! [`VirtualDevice`]. The desktop sees one more keyboard and mouse; a
//! chord is typed and a click clicked as by a real one.
//!
//! The device registers exactly the keys a chord may name
//! ([`KEYS`]), the left, right and middle
//! buttons, and the relative axes X, Y and the wheel. Each command becomes
//! a fixed sequence of events (`plan.rs`, pure and tested exactly); every
//! key and button written down is tracked until it is written up, and
//! [`Output::close`] and `Drop` let go of whatever is still down before the
//! device is destroyed. Nothing may stay pressed: a stuck Ctrl would turn
//! the person's next keystrokes into shortcuts they did not ask for.

mod driver;
mod plan;

use std::fs::OpenOptions;
use std::io;
use std::os::unix::fs::{FileTypeExt, MetadataExt};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime};

use evdev::uinput::VirtualDevice;
use evdev::{AttributeSet, BusType, InputEvent, InputId, KeyCode, RelativeAxisCode};

use crate::control::keys::KEYS;
use crate::control::output_command::OutputCommand;
use crate::output::settings::UinputSettings;
use crate::output::{Output, OutputError, OutputReport};
use driver::{Driver, SETTLE, Sink};
use plan::{AXES, BUTTONS, UinputEvent};

/// Where the kernel's uinput device is.
pub const UINPUT_PATH: &str = "/dev/uinput";

/// The udev rule that lets the `input` group create virtual devices.
pub const UDEV_RULE: &str =
    r#"KERNEL=="uinput", GROUP="input", MODE="0660", OPTIONS+="static_node=uinput""#;

/// Where [`UDEV_RULE`] goes.
pub const UDEV_RULE_FILE: &str = "/etc/udev/rules.d/99-sipnpuff-uinput.rules";

/// Longest wait for the device's `/dev/input/eventN` to appear.
const NODE_WAIT: Duration = Duration::from_secs(2);

/// `UINPUT_MINOR`: uinput is the misc (major 10) character device 223.
const UINPUT_DEV: (u32, u32) = (10, 223);

/// Longest device name: the kernel's `UINPUT_MAX_NAME_SIZE` is 80 with
/// its terminating zero, and evdev's builder asserts (panics) unless the
/// name and its zero are shorter than that, so 78 bytes.
pub const MAX_NAME: usize = 78;

/// The made device, as a [`Sink`]; closing it (dropping) destroys it.
struct Device {
    device: VirtualDevice,
    /// The frame being written, as evdev's events.
    events: Vec<InputEvent>,
}

impl Sink for Device {
    /// `emit` writes the events and then one `SYN_REPORT 0`: the frame's
    /// closing `SYN` is that one (a frame without one gets it).
    fn write(&mut self, events: &[UinputEvent]) -> io::Result<()> {
        let body = events.strip_suffix(&[UinputEvent::SYN]).unwrap_or(events);
        self.events.clear();
        self.events.extend(
            body.iter()
                .map(|e| InputEvent::new(e.kind, e.code, e.value)),
        );
        self.device.emit(&self.events)
    }

    fn pause(&mut self, duration: Duration) {
        std::thread::sleep(duration);
    }
}

/// The computer's keyboard and pointer through uinput.
pub struct UinputOutput {
    driver: Driver<Device>,
    name: String,
    /// `/dev/input/eventN`, or why there is none.
    node: Result<PathBuf, String>,
}

impl UinputOutput {
    /// Makes the virtual keyboard and pointer named `settings.name`
    /// through `/dev/uinput`. No uinput module, or no permission: an error
    /// that says how to fix it, before anything starts.
    pub fn open(settings: &UinputSettings) -> Result<UinputOutput, OutputError> {
        let name = device_name(&settings.name)?;
        let path = Path::new(UINPUT_PATH);
        check_uinput(path)?;
        let refused = |what: &str, e: io::Error| OutputError {
            output: "uinput",
            detail: format!(
                "{} refused {what} ({e}): it is not the kernel's uinput device",
                path.display()
            ),
        };
        let keys: AttributeSet<KeyCode> = KEYS
            .iter()
            .map(|k| k.code)
            .chain(BUTTONS)
            .map(KeyCode)
            .collect();
        let axes: AttributeSet<RelativeAxisCode> = AXES.into_iter().map(RelativeAxisCode).collect();
        // The builder opens UINPUT_PATH again, as `check_uinput` did.
        let mut device = VirtualDevice::builder()
            .map_err(|e| open_error(path, &e))?
            .name(name)
            .input_id(InputId::new(BusType::BUS_VIRTUAL, 0, 0, 1))
            .with_keys(&keys)
            .map_err(|e| refused("UI_SET_EVBIT or UI_SET_KEYBIT", e))?
            .with_relative_axes(&axes)
            .map_err(|e| refused("UI_SET_EVBIT or UI_SET_RELBIT", e))?
            .build()
            .map_err(|e| refused("UI_DEV_SETUP (Linux 4.5 or later) or UI_DEV_CREATE", e))?;
        let node = match device.get_syspath() {
            Err(e) => Err(format!("no name under /sys ({e})")),
            Ok(sys) => wait_for_node(&sys, NODE_WAIT, || {
                device
                    .enumerate_dev_nodes_blocking()
                    .ok()?
                    .filter_map(Result::ok)
                    .find(|node| node.exists())
            }),
        };
        let mut driver = Driver::new(Device {
            device,
            events: Vec::with_capacity(16),
        });
        driver.sink.pause(SETTLE);
        Ok(UinputOutput {
            driver,
            name: settings.name.clone(),
            node,
        })
    }
}

impl Output for UinputOutput {
    fn describe(&self) -> String {
        match &self.node {
            Ok(node) => format!("uinput \"{}\" ({})", self.name, node.display()),
            Err(why) => format!("uinput \"{}\" ({why})", self.name),
        }
    }

    fn begin(&mut self, tick_zero: SystemTime) {
        self.driver.tick_zero = Some(tick_zero);
    }

    fn has_deadlines(&self) -> bool {
        true
    }

    fn apply(&mut self, command: &OutputCommand) {
        self.driver.apply(command);
    }

    fn close(&mut self) -> OutputReport {
        self.driver.finish();
        let mut report = self.driver.report(self.describe());
        if let Err(why) = &self.node {
            report.notes.push(format!(
                "the device had no event node ({why}): programs that read /dev/input saw nothing"
            ));
        }
        report
    }
}

/// The name as the device takes it: at most [`MAX_NAME`] bytes, no NUL.
fn device_name(name: &str) -> Result<&str, OutputError> {
    if name.len() > MAX_NAME {
        return Err(OutputError {
            output: "uinput",
            detail: format!(
                "the device name is {} bytes; at most {MAX_NAME} fit",
                name.len()
            ),
        });
    }
    if name.contains('\0') {
        return Err(OutputError {
            output: "uinput",
            detail: "the device name holds a NUL character".to_owned(),
        });
    }
    Ok(name)
}

/// That `path` opens for reading and writing and is the kernel's uinput
/// device, or an error that says what to do. evdev's builder opens
/// [`UINPUT_PATH`] itself and answers only with an `io::Error`; this
/// check comes first so the person reads which fix they need.
fn check_uinput(path: &Path) -> Result<(), OutputError> {
    let file = OpenOptions::new()
        .read(true)
        .write(true)
        .open(path)
        .map_err(|e| open_error(path, &e))?;
    let meta = file.metadata().map_err(|e| open_error(path, &e))?;
    let rdev = meta.rdev();
    let found = (libc::major(rdev), libc::minor(rdev));
    if meta.file_type().is_char_device() && found == UINPUT_DEV {
        return Ok(());
    }
    let what = if meta.file_type().is_char_device() {
        format!("the character device {}:{}", found.0, found.1)
    } else if meta.is_file() {
        "a regular file".to_owned()
    } else {
        "not a character device".to_owned()
    };
    Err(OutputError {
        output: "uinput",
        detail: format!(
            "{} is {what}: it is not the kernel's uinput device (the character device {}:{})",
            path.display(),
            UINPUT_DEV.0,
            UINPUT_DEV.1
        ),
    })
}

/// Why `path` could not be opened, and what to do about it.
fn open_error(path: &Path, error: &io::Error) -> OutputError {
    let path = path.display();
    let module = "Load the uinput module: `sudo modprobe uinput` (and at every boot: `echo uinput | sudo tee /etc/modules-load.d/uinput.conf`).";
    let access = format!(
        "Let the `input` group use it with a udev rule: put\n    {UDEV_RULE}\ninto {UDEV_RULE_FILE}, run `sudo udevadm control --reload-rules && sudo udevadm trigger`, then join the group: `sudo usermod -aG input $USER` and log in again."
    );
    let detail = match error.raw_os_error() {
        Some(libc::ENOENT) => format!("there is no {path} ({error}). {module} {access}"),
        Some(libc::ENODEV | libc::ENXIO) => {
            format!("{path} is there but no driver answers ({error}). {module}")
        }
        Some(libc::EACCES | libc::EPERM | libc::EROFS) => {
            format!("no permission to open {path} for writing ({error}). {access}")
        }
        _ => format!("cannot open {path} ({error})."),
    };
    OutputError {
        output: "uinput",
        detail,
    }
}

/// The device's event node (`/dev/input/eventN`), once `find` finds it;
/// `sys` is the device's directory under /sys, for the message. Waits up
/// to `limit`.
fn wait_for_node(
    sys: &Path,
    limit: Duration,
    mut find: impl FnMut() -> Option<PathBuf>,
) -> Result<PathBuf, String> {
    let start = Instant::now();
    loop {
        if let Some(node) = find() {
            return Ok(node);
        }
        if start.elapsed() >= limit {
            return Err(format!(
                "no /dev/input/event node for {} after {} ms: is the evdev module loaded?",
                sys.display(),
                limit.as_millis()
            ));
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[cfg(test)]
mod tests {
    use std::os::unix::fs::PermissionsExt;

    use super::*;

    fn open_err(path: &Path) -> OutputError {
        match check_uinput(path) {
            Ok(()) => panic!("{} passed as uinput", path.display()),
            Err(e) => e,
        }
    }

    const MODULE: &str = "Load the uinput module: `sudo modprobe uinput` (and at every boot: `echo uinput | sudo tee /etc/modules-load.d/uinput.conf`).";
    const ACCESS: &str = "Let the `input` group use it with a udev rule: put\n    KERNEL==\"uinput\", GROUP=\"input\", MODE=\"0660\", OPTIONS+=\"static_node=uinput\"\ninto /etc/udev/rules.d/99-sipnpuff-uinput.rules, run `sudo udevadm control --reload-rules && sudo udevadm trigger`, then join the group: `sudo usermod -aG input $USER` and log in again.";

    #[test]
    fn no_uinput_device_says_to_load_the_module_and_add_the_rule() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("uinput");
        let error = open_err(&path);
        assert_eq!(error.output, "uinput");
        assert_eq!(
            error.detail,
            format!(
                "there is no {} ({}). {MODULE} {ACCESS}",
                path.display(),
                io::Error::from_raw_os_error(libc::ENOENT)
            )
        );
    }

    #[test]
    fn no_permission_says_which_rule_and_group() {
        let path = Path::new("/dev/uinput");
        let eacces = io::Error::from_raw_os_error(libc::EACCES);
        assert_eq!(
            open_error(path, &eacces).detail,
            format!("no permission to open /dev/uinput for writing ({eacces}). {ACCESS}")
        );
        let enodev = io::Error::from_raw_os_error(libc::ENODEV);
        assert_eq!(
            open_error(path, &enodev).detail,
            format!("/dev/uinput is there but no driver answers ({enodev}). {MODULE}")
        );
    }

    #[test]
    fn an_unreadable_file_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("uinput");
        std::fs::write(&path, b"").unwrap();
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o000)).unwrap();
        let error = open_err(&path);
        let opens = OpenOptions::new().read(true).write(true).open(&path);
        if opens.is_ok() {
            // Root (CAP_DAC_OVERRIDE) opens it anyway; it then is no
            // uinput device.
            assert_eq!(error.detail, not_uinput(&path, "a regular file"));
        } else {
            let eacces = io::Error::from_raw_os_error(libc::EACCES);
            assert_eq!(
                error.detail,
                format!(
                    "no permission to open {} for writing ({eacces}). {ACCESS}",
                    path.display()
                )
            );
        }
    }

    fn not_uinput(path: &Path, what: &str) -> String {
        format!(
            "{} is {what}: it is not the kernel's uinput device (the character device 10:223)",
            path.display(),
        )
    }

    #[test]
    fn a_file_that_is_not_uinput_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("uinput");
        std::fs::write(&path, b"").unwrap();
        assert_eq!(open_err(&path).detail, not_uinput(&path, "a regular file"));
        // A character device, but another one.
        let null = Path::new("/dev/null");
        assert_eq!(
            open_err(null).detail,
            not_uinput(null, "the character device 1:3")
        );
    }

    #[test]
    fn names_that_do_not_fit_are_refused() {
        // 79 bytes would fit the kernel, but evdev's builder panics on it.
        let fits = "x".repeat(MAX_NAME);
        assert_eq!(device_name(&fits).unwrap(), fits);
        assert_eq!(
            device_name(&"x".repeat(79)).unwrap_err().detail,
            "the device name is 79 bytes; at most 78 fit"
        );
        assert_eq!(
            device_name("a\0b").unwrap_err().detail,
            "the device name holds a NUL character"
        );
    }

    #[test]
    fn the_event_node_is_waited_for() {
        let sys = Path::new("/sys/devices/virtual/input/input8");
        let mut calls = 0;
        let found = wait_for_node(sys, Duration::from_secs(5), || {
            calls += 1;
            (calls == 3).then(|| PathBuf::from("/dev/input/event12"))
        });
        assert_eq!(found, Ok(PathBuf::from("/dev/input/event12")));
        assert_eq!(calls, 3);
        assert_eq!(
            wait_for_node(sys, Duration::from_millis(20), || None),
            Err(
                "no /dev/input/event node for /sys/devices/virtual/input/input8 after 20 ms: is the evdev module loaded?"
                    .to_owned()
            )
        );
    }
}
