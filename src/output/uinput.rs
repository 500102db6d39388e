//! `--output uinput`: the computer's keyboard and pointer, as a virtual
//! input device made through `/dev/uinput` (kernel
//! `Documentation/input/uinput.rst`) with the evdev crate's
//! [`VirtualDevice`]. The desktop sees one more keyboard and mouse; a
//! chord is typed and a click clicked as by a real one.
//!
//! The device registers exactly the keys a chord may name
//! ([`KEYS`](crate::control::keys::KEYS)), the left, right and middle
//! buttons, and the relative axes X, Y and the wheel. Each command becomes
//! a fixed sequence of events ([`plan`], pure and tested exactly); every
//! key and button written down is tracked until it is written up, and
//! [`Output::close`] and `Drop` let go of whatever is still down before the
//! device is destroyed. Nothing may stay pressed: a stuck Ctrl would turn
//! the person's next keystrokes into shortcuts they did not ask for.

use std::fs::OpenOptions;
use std::io;
use std::os::unix::fs::{FileTypeExt, MetadataExt};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime};

use evdev::uinput::VirtualDevice;
use evdev::{
    AttributeSet, BusType, EventType, InputEvent, InputId, KeyCode, RelativeAxisCode,
    SynchronizationCode,
};

use crate::control::keys::{self, KEYS};
use crate::control::output_command::{OutputCommand, PointerMove};
use crate::control::target::Click;
use crate::output::settings::UinputSettings;
use crate::output::{Output, OutputError, OutputReport};

/// Where the kernel's uinput device is.
pub const UINPUT_PATH: &str = "/dev/uinput";

/// The udev rule that lets the `input` group create virtual devices.
pub const UDEV_RULE: &str =
    r#"KERNEL=="uinput", GROUP="input", MODE="0660", OPTIONS+="static_node=uinput""#;

/// Where [`UDEV_RULE`] goes.
pub const UDEV_RULE_FILE: &str = "/etc/udev/rules.d/99-sipnpuff-uinput.rules";

/// How long a chord's keys stay down: longer than one 60 Hz frame
/// (16.7 ms), so an application that samples the keyboard once a frame
/// still sees the whole chord, and short enough to feel instant.
pub const KEY_HOLD: Duration = Duration::from_millis(20);

/// How long a click holds its button: longer than libinput's 25 ms button
/// debounce window, inside which a press and its release can be taken for
/// a bouncing switch and dropped.
pub const BUTTON_HOLD: Duration = Duration::from_millis(30);

/// Between the two clicks of a double click (first up to second down):
/// clear of the 25 ms debounce window, far inside any desktop's
/// double-click time (400–500 ms by default).
pub const DOUBLE_CLICK_GAP: Duration = Duration::from_millis(60);

/// After the device is made, and before it is destroyed: time for the
/// desktop (udev, libinput) to open it before the first event, and to read
/// the last events (the releases) before it goes; a reader of a destroyed
/// device gets `ENODEV`, not the events still queued for it.
pub const SETTLE: Duration = Duration::from_millis(100);

/// Longest wait for the device's `/dev/input/eventN` to appear.
const NODE_WAIT: Duration = Duration::from_secs(2);

/// `EV_SYN`, `EV_KEY`, `EV_REL` and `SYN_REPORT`.
const EV_SYN: u16 = EventType::SYNCHRONIZATION.0;
const EV_KEY: u16 = EventType::KEY.0;
const EV_REL: u16 = EventType::RELATIVE.0;
const SYN_REPORT: u16 = SynchronizationCode::SYN_REPORT.0;

/// The pointer's buttons: left (clicks and the drag), right, middle.
const BTN_LEFT: u16 = KeyCode::BTN_LEFT.0;
const BTN_RIGHT: u16 = KeyCode::BTN_RIGHT.0;
const BTN_MIDDLE: u16 = KeyCode::BTN_MIDDLE.0;
const BUTTONS: [u16; 3] = [BTN_LEFT, BTN_RIGHT, BTN_MIDDLE];

/// The pointer's axes.
const REL_X: u16 = RelativeAxisCode::REL_X.0;
const REL_Y: u16 = RelativeAxisCode::REL_Y.0;
const REL_WHEEL: u16 = RelativeAxisCode::REL_WHEEL.0;
const AXES: [u16; 3] = [REL_X, REL_Y, REL_WHEEL];

// ------------------------------------------------------------ the plan

/// One input event: type, code, value (`struct input_event` without its
/// time, which the kernel sets when the event is written).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Event {
    /// `EV_*`.
    pub kind: u16,
    /// Key, button or axis code.
    pub code: u16,
    /// Key: 1 down, 0 up; axis: the motion.
    pub value: i32,
}

impl Event {
    /// A key or button going down (`true`) or up.
    pub const fn key(code: u16, down: bool) -> Event {
        Event {
            kind: EV_KEY,
            code,
            value: down as i32,
        }
    }

    /// Relative motion on an axis.
    pub const fn rel(code: u16, value: i32) -> Event {
        Event {
            kind: EV_REL,
            code,
            value,
        }
    }

    /// `SYN_REPORT`: the events since the last one happened together.
    pub const SYN: Event = Event {
        kind: EV_SYN,
        code: SYN_REPORT,
        value: 0,
    };
}

/// One step of what a command writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// Write this event (a frame of them ends with [`Event::SYN`]).
    Write(Event),
    /// Wait this long before the next.
    Pause(Duration),
}

/// The keys and buttons written down and not yet up, in the order they
/// went down.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Held {
    codes: Vec<u16>,
}

impl Held {
    /// Nothing held, with room for a chord and a drag.
    pub fn new() -> Held {
        Held {
            codes: Vec::with_capacity(8),
        }
    }

    /// `code` is down (again: no change).
    pub fn press(&mut self, code: u16) {
        if !self.contains(code) {
            self.codes.push(code);
        }
    }

    /// `code` is up.
    pub fn release(&mut self, code: u16) {
        self.codes.retain(|&c| c != code);
    }

    /// Whether `code` is down.
    pub fn contains(&self, code: u16) -> bool {
        self.codes.contains(&code)
    }

    /// Nothing is down.
    pub fn is_empty(&self) -> bool {
        self.codes.is_empty()
    }

    /// What is down, in the order it went down.
    pub fn codes(&self) -> &[u16] {
        &self.codes
    }
}

/// What `command` writes, given what is held, into `out` (cleared first;
/// its capacity is reused):
///
/// * `Key`: each key down with `SYN` after it (modifiers first, as
///   [`Chord::codes`](crate::control::target::Chord::codes) orders them),
///   [`KEY_HOLD`], each key up in reverse order with `SYN` after it;
/// * `Click`: the button down, `SYN`, [`BUTTON_HOLD`], up, `SYN`; a double
///   click is two left clicks [`DOUBLE_CLICK_GAP`] apart;
/// * `Button`: the left button down or up, `SYN`, unless it already is;
/// * `Pointer`: the non-zero of `REL_X`, `REL_Y`, `REL_WHEEL`, one `SYN`;
/// * `ReleaseAll`: everything held up, last pressed first, one `SYN`;
/// * `Home`: nothing (the home is not the computer).
pub fn plan(command: &OutputCommand, held: &Held, out: &mut Vec<Step>) {
    out.clear();
    let write = |out: &mut Vec<Step>, event: Event| out.push(Step::Write(event));
    match *command {
        OutputCommand::Key(chord) => {
            for &code in chord.codes() {
                write(out, Event::key(code, true));
                write(out, Event::SYN);
            }
            out.push(Step::Pause(KEY_HOLD));
            for &code in chord.codes().iter().rev() {
                write(out, Event::key(code, false));
                write(out, Event::SYN);
            }
        }
        OutputCommand::Click(click) => {
            let (button, times) = match click {
                Click::Left => (BTN_LEFT, 1),
                Click::Right => (BTN_RIGHT, 1),
                Click::Double => (BTN_LEFT, 2),
            };
            for i in 0..times {
                if i > 0 {
                    out.push(Step::Pause(DOUBLE_CLICK_GAP));
                }
                write(out, Event::key(button, true));
                write(out, Event::SYN);
                out.push(Step::Pause(BUTTON_HOLD));
                write(out, Event::key(button, false));
                write(out, Event::SYN);
            }
        }
        OutputCommand::Button { down } => {
            if held.contains(BTN_LEFT) != down {
                write(out, Event::key(BTN_LEFT, down));
                write(out, Event::SYN);
            }
        }
        OutputCommand::Pointer(motion) => {
            let axes = [
                (REL_X, motion.dx),
                (REL_Y, motion.dy),
                (REL_WHEEL, motion.wheel),
            ];
            for (code, value) in axes {
                if value != 0 {
                    write(out, Event::rel(code, value));
                }
            }
            if !motion.is_zero() {
                write(out, Event::SYN);
            }
        }
        OutputCommand::ReleaseAll => {
            for &code in held.codes().iter().rev() {
                write(out, Event::key(code, false));
            }
            if !held.is_empty() {
                write(out, Event::SYN);
            }
        }
        OutputCommand::Home { .. } => {}
    }
}

// ------------------------------------------------------------ the driver

/// Where the events go: the device, or a recorder in tests.
trait Sink {
    /// Writes one frame (events ending with `SYN`) at once.
    fn write(&mut self, events: &[Event]) -> io::Result<()>;
    /// Waits.
    fn pause(&mut self, duration: Duration);
}

/// Why commands were lost: the first failure in words, and how many.
#[derive(Debug, Default)]
struct Failures {
    count: u64,
    first: Option<String>,
}

/// Carries out the plans on a sink: tracks what is held, counts, and lets
/// go of everything held when closed or dropped.
struct Driver<S: Sink> {
    sink: S,
    held: Held,
    steps: Vec<Step>,
    frame: Vec<Event>,
    applied: u64,
    failures: Failures,
    /// Keys and buttons that could not be let go of at the end.
    stuck: Option<String>,
    travel: PointerMove<i64>,
    tick_zero: Option<SystemTime>,
    /// An event was written: wait [`SETTLE`] before the device goes.
    wrote: bool,
    closed: bool,
}

impl<S: Sink> Driver<S> {
    fn new(sink: S) -> Driver<S> {
        Driver {
            sink,
            held: Held::new(),
            steps: Vec::with_capacity(32),
            frame: Vec::with_capacity(16),
            applied: 0,
            failures: Failures::default(),
            stuck: None,
            travel: PointerMove::default(),
            tick_zero: None,
            wrote: false,
            closed: false,
        }
    }

    fn apply(&mut self, command: &OutputCommand) {
        if !command.is_for_computer() {
            return;
        }
        if self.closed {
            self.lost(command, "the device was already closed");
            return;
        }
        let mut steps = std::mem::take(&mut self.steps);
        plan(command, &self.held, &mut steps);
        let result = self.run(&steps);
        self.steps = steps;
        match result {
            Ok(()) => self.applied += 1,
            Err(error) => {
                self.lost(command, &error.to_string());
                // Everything held goes up now, on the safe side: this
                // command's keys (a failed write may still have pressed
                // them) and a drag's button alike.
                let _ = self.release_all();
            }
        }
    }

    /// Writes the steps, a frame at a time; stops at the first failure.
    fn run(&mut self, steps: &[Step]) -> io::Result<()> {
        self.frame.clear();
        for step in steps {
            match *step {
                Step::Pause(duration) => self.sink.pause(duration),
                Step::Write(event) => {
                    self.frame.push(event);
                    if event == Event::SYN {
                        self.flush()?;
                    }
                }
            }
        }
        // A plan's frames all end with SYN; anything left is written too.
        if !self.frame.is_empty() {
            self.flush()?;
        }
        Ok(())
    }

    /// Writes the frame. A key written down counts as held before the
    /// write (a failed write may have pressed it); up, after it succeeds.
    fn flush(&mut self) -> io::Result<()> {
        for e in &self.frame {
            if e.kind == EV_KEY && e.value != 0 {
                self.held.press(e.code);
            }
        }
        self.wrote = true;
        let result = self.sink.write(&self.frame);
        if result.is_ok() {
            for e in &self.frame {
                match (e.kind, e.code) {
                    (EV_KEY, code) if e.value == 0 => self.held.release(code),
                    (EV_REL, REL_X) => self.travel.dx += i64::from(e.value),
                    (EV_REL, REL_Y) => self.travel.dy += i64::from(e.value),
                    (EV_REL, REL_WHEEL) => self.travel.wheel += i64::from(e.value),
                    _ => {}
                }
            }
        }
        self.frame.clear();
        result
    }

    /// Lets go of everything held, in one frame.
    fn release_all(&mut self) -> io::Result<()> {
        let mut steps = std::mem::take(&mut self.steps);
        plan(&OutputCommand::ReleaseAll, &self.held, &mut steps);
        let result = self.run(&steps);
        self.steps = steps;
        result
    }

    /// Counts a lost command and keeps the first failure's words.
    fn lost(&mut self, command: &OutputCommand, why: &str) {
        self.failures.count += 1;
        if self.failures.first.is_none() {
            let when = match self.tick_zero.map(|t| SystemTime::now().duration_since(t)) {
                Some(Ok(since)) => format!("{:.1} s into the run", since.as_secs_f64()),
                Some(Err(_)) | None => "before the run began".to_owned(),
            };
            self.failures.first = Some(format!("{} {when}: {why}", doing(command)));
        }
    }

    /// Lets go of everything held and waits for readers to take the last
    /// events. Once; the device may then be destroyed.
    fn finish(&mut self) {
        if self.closed {
            return;
        }
        self.closed = true;
        if !self.held.is_empty() {
            let names = key_names(self.held.codes());
            if let Err(error) = self.release_all() {
                self.stuck = Some(format!(
                    "could not let go of {names} before closing ({error}); the kernel lets go of them when the device is removed, which followed"
                ));
            }
        }
        if self.wrote {
            self.sink.pause(SETTLE);
        }
    }

    fn report(&self, output: String) -> OutputReport {
        let mut notes = Vec::new();
        if let Some(first) = &self.failures.first {
            let n = self.failures.count;
            notes.push(format!(
                "{n} command{} could not be written to the device; the first: {first}",
                if n == 1 { "" } else { "s" }
            ));
        }
        if let Some(stuck) = &self.stuck {
            notes.push(stuck.clone());
        }
        OutputReport {
            output,
            applied: self.applied,
            dropped: 0,
            lost: self.failures.count,
            notes,
            pointer_travel: Some(self.travel),
        }
    }
}

impl<S: Sink> Drop for Driver<S> {
    /// Whatever way the output ends, nothing stays pressed.
    fn drop(&mut self) {
        self.finish();
    }
}

/// What a command was doing, for a note: "typing Ctrl+Alt+T".
fn doing(command: &OutputCommand) -> String {
    match command {
        OutputCommand::Key(chord) => format!("typing {}", chord.label()),
        OutputCommand::Click(Click::Double) => "a double click".to_owned(),
        OutputCommand::Click(click) => format!("a {} click", click.name()),
        OutputCommand::Button { down: true } => "pressing the left button".to_owned(),
        OutputCommand::Button { down: false } => "letting go of the left button".to_owned(),
        OutputCommand::Pointer(m) => format!(
            "moving the pointer (x {}, y {}, wheel {})",
            m.dx, m.dy, m.wheel
        ),
        OutputCommand::ReleaseAll => "letting go of every key and button".to_owned(),
        OutputCommand::Home { .. } => "a home event".to_owned(),
    }
}

/// "Ctrl, T, the left button".
fn key_names(codes: &[u16]) -> String {
    codes
        .iter()
        .map(|&code| match code {
            BTN_LEFT => "the left button".to_owned(),
            BTN_RIGHT => "the right button".to_owned(),
            BTN_MIDDLE => "the middle button".to_owned(),
            _ => keys::by_code(code).map_or_else(|| format!("key {code}"), |k| k.label.to_owned()),
        })
        .collect::<Vec<_>>()
        .join(", ")
}

// ------------------------------------------------------------ the device

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
    fn write(&mut self, events: &[Event]) -> io::Result<()> {
        let body = events.strip_suffix(&[Event::SYN]).unwrap_or(events);
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
    use std::cell::RefCell;
    use std::os::unix::fs::PermissionsExt;
    use std::rc::Rc;

    use super::*;
    use crate::control::target::Chord;

    const KEY_LEFTCTRL: u16 = 29;
    const KEY_LEFTALT: u16 = 56;
    const KEY_T: u16 = 20;

    fn down(code: u16) -> Step {
        Step::Write(Event::key(code, true))
    }
    fn up(code: u16) -> Step {
        Step::Write(Event::key(code, false))
    }
    const SYN: Step = Step::Write(Event::SYN);

    fn planned(command: OutputCommand, held: &Held) -> Vec<Step> {
        let mut out = Vec::new();
        plan(&command, held, &mut out);
        out
    }

    fn key(text: &str) -> OutputCommand {
        OutputCommand::Key(Chord::parse(text).unwrap())
    }

    #[test]
    fn a_chord_presses_in_order_and_releases_in_reverse() {
        assert_eq!(
            planned(key("ctrl+alt+t"), &Held::new()),
            [
                down(KEY_LEFTCTRL),
                SYN,
                down(KEY_LEFTALT),
                SYN,
                down(KEY_T),
                SYN,
                Step::Pause(KEY_HOLD),
                up(KEY_T),
                SYN,
                up(KEY_LEFTALT),
                SYN,
                up(KEY_LEFTCTRL),
                SYN,
            ]
        );
        assert_eq!(
            planned(key("space"), &Held::new()),
            [down(57), SYN, Step::Pause(KEY_HOLD), up(57), SYN]
        );
    }

    #[test]
    fn clicks() {
        let click = |button| vec![down(button), SYN, Step::Pause(BUTTON_HOLD), up(button), SYN];
        let held = Held::new();
        assert_eq!(
            planned(OutputCommand::Click(Click::Left), &held),
            click(272)
        );
        assert_eq!(
            planned(OutputCommand::Click(Click::Right), &held),
            click(273)
        );
        let mut double = click(272);
        double.push(Step::Pause(DOUBLE_CLICK_GAP));
        double.extend(click(272));
        assert_eq!(planned(OutputCommand::Click(Click::Double), &held), double);
    }

    #[test]
    fn pointer_moves_write_the_non_zero_axes_then_one_syn() {
        let held = Held::new();
        let moved =
            |dx, dy, wheel| planned(OutputCommand::Pointer(PointerMove { dx, dy, wheel }), &held);
        let rel = |code, value| Step::Write(Event::rel(code, value));
        assert_eq!(moved(3, -2, 1), [rel(0, 3), rel(1, -2), rel(8, 1), SYN]);
        assert_eq!(moved(0, 5, 0), [rel(1, 5), SYN]);
        assert_eq!(moved(-7, 0, 0), [rel(0, -7), SYN]);
        assert_eq!(moved(0, 0, 0), []);
    }

    #[test]
    fn the_button_goes_down_and_up_once() {
        let mut held = Held::new();
        let press = OutputCommand::Button { down: true };
        let release = OutputCommand::Button { down: false };
        assert_eq!(planned(press, &held), [down(272), SYN]);
        assert_eq!(planned(release, &held), []);
        held.press(272);
        assert_eq!(planned(press, &held), []);
        assert_eq!(planned(release, &held), [up(272), SYN]);
    }

    #[test]
    fn release_all_lets_go_of_the_last_pressed_first() {
        let mut held = Held::new();
        assert_eq!(planned(OutputCommand::ReleaseAll, &held), []);
        held.press(KEY_LEFTCTRL);
        held.press(272);
        held.press(KEY_T);
        held.press(KEY_LEFTCTRL);
        assert_eq!(
            planned(OutputCommand::ReleaseAll, &held),
            [up(KEY_T), up(272), up(KEY_LEFTCTRL), SYN]
        );
    }

    /// What a recorder saw: each frame written, each pause.
    #[derive(Debug, Clone, PartialEq)]
    enum Seen {
        Frame(Vec<Event>),
        Pause(Duration),
    }

    /// A sink that records, and fails the writes it is told to.
    struct Recorder {
        seen: Rc<RefCell<Vec<Seen>>>,
        /// Writes (counting from 1) that fail with EIO.
        fail: Vec<usize>,
        writes: usize,
    }

    impl Sink for Recorder {
        fn write(&mut self, events: &[Event]) -> io::Result<()> {
            self.writes += 1;
            if self.fail.contains(&self.writes) {
                return Err(io::Error::from_raw_os_error(libc::EIO));
            }
            self.seen.borrow_mut().push(Seen::Frame(events.to_vec()));
            Ok(())
        }
        fn pause(&mut self, duration: Duration) {
            self.seen.borrow_mut().push(Seen::Pause(duration));
        }
    }

    fn recorder(fail: &[usize]) -> (Driver<Recorder>, Rc<RefCell<Vec<Seen>>>) {
        let seen = Rc::new(RefCell::new(Vec::new()));
        let sink = Recorder {
            seen: Rc::clone(&seen),
            fail: fail.to_vec(),
            writes: 0,
        };
        (Driver::new(sink), seen)
    }

    fn frame(events: &[Event]) -> Seen {
        Seen::Frame(events.to_vec())
    }

    #[test]
    fn a_chord_is_written_a_frame_per_key() {
        let (mut d, seen) = recorder(&[]);
        d.apply(&key("ctrl+alt+t"));
        let k = Event::key;
        assert_eq!(
            *seen.borrow(),
            [
                frame(&[k(KEY_LEFTCTRL, true), Event::SYN]),
                frame(&[k(KEY_LEFTALT, true), Event::SYN]),
                frame(&[k(KEY_T, true), Event::SYN]),
                Seen::Pause(KEY_HOLD),
                frame(&[k(KEY_T, false), Event::SYN]),
                frame(&[k(KEY_LEFTALT, false), Event::SYN]),
                frame(&[k(KEY_LEFTCTRL, false), Event::SYN]),
            ]
        );
        assert!(d.held.is_empty());
        assert_eq!(d.applied, 1);
    }

    #[test]
    fn release_all_and_close_let_go_of_a_drag() {
        let (mut d, seen) = recorder(&[]);
        d.apply(&OutputCommand::Button { down: true });
        assert_eq!(d.held.codes(), [272]);
        d.apply(&OutputCommand::ReleaseAll);
        d.apply(&OutputCommand::ReleaseAll);
        assert_eq!(
            *seen.borrow(),
            [
                frame(&[Event::key(272, true), Event::SYN]),
                frame(&[Event::key(272, false), Event::SYN]),
            ]
        );
        d.apply(&OutputCommand::Button { down: true });
        d.finish();
        assert_eq!(
            seen.borrow()[2..],
            [
                frame(&[Event::key(272, true), Event::SYN]),
                frame(&[Event::key(272, false), Event::SYN]),
                Seen::Pause(SETTLE),
            ]
        );
        let report = d.report("test".into());
        assert_eq!(
            report,
            OutputReport {
                output: "test".into(),
                applied: 4,
                dropped: 0,
                lost: 0,
                notes: vec![],
                pointer_travel: Some(PointerMove::default()),
            }
        );
        // Closed: nothing more is written, and the command is lost.
        d.apply(&OutputCommand::Button { down: true });
        assert_eq!(seen.borrow().len(), 5);
        assert_eq!(d.report(String::new()).lost, 1);
    }

    #[test]
    fn dropping_the_output_lets_go_of_what_is_held() {
        let (mut d, seen) = recorder(&[]);
        d.apply(&OutputCommand::Button { down: true });
        drop(d);
        assert_eq!(
            *seen.borrow(),
            [
                frame(&[Event::key(272, true), Event::SYN]),
                frame(&[Event::key(272, false), Event::SYN]),
                Seen::Pause(SETTLE),
            ]
        );
        // Nothing ever written: nothing to release, no wait.
        let (d, seen) = recorder(&[]);
        drop(d);
        assert_eq!(*seen.borrow(), []);
    }

    #[test]
    fn a_failed_write_loses_the_command_and_lets_go_of_its_keys() {
        // The third write (T down) fails: Ctrl and Alt are down, T may be.
        let (mut d, seen) = recorder(&[3]);
        d.apply(&key("ctrl+alt+t"));
        let k = Event::key;
        assert_eq!(
            *seen.borrow(),
            [
                frame(&[k(KEY_LEFTCTRL, true), Event::SYN]),
                frame(&[k(KEY_LEFTALT, true), Event::SYN]),
                frame(&[
                    k(KEY_T, false),
                    k(KEY_LEFTALT, false),
                    k(KEY_LEFTCTRL, false),
                    Event::SYN
                ]),
            ]
        );
        assert!(d.held.is_empty());
        assert_eq!((d.applied, d.failures.count), (0, 1));
        let note = &d.report(String::new()).notes;
        assert_eq!(
            note,
            &[format!(
                "1 command could not be written to the device; the first: typing Ctrl+Alt+T before the run began: {}",
                io::Error::from_raw_os_error(libc::EIO)
            )]
        );
    }

    #[test]
    fn keys_that_cannot_be_let_go_of_are_reported() {
        // The drag's release fails at the close, and so does every later write.
        let (mut d, _seen) = recorder(&[2, 3, 4]);
        d.begin_for_test();
        d.apply(&OutputCommand::Button { down: true });
        d.finish();
        let report = d.report(String::new());
        assert_eq!(report.lost, 0);
        assert_eq!(
            report.notes,
            [format!(
                "could not let go of the left button before closing ({}); the kernel lets go of them when the device is removed, which followed",
                io::Error::from_raw_os_error(libc::EIO)
            )]
        );
    }

    #[test]
    fn the_travel_counts_what_was_written() {
        let (mut d, _seen) = recorder(&[2]);
        let moved = |dx, dy, wheel| OutputCommand::Pointer(PointerMove { dx, dy, wheel });
        d.apply(&moved(5, -3, 0));
        d.apply(&moved(100, 100, 100)); // fails: not travelled
        d.apply(&moved(-2, 0, 1));
        d.apply(&moved(0, 0, 0));
        let report = d.report(String::new());
        assert_eq!(
            report.pointer_travel,
            Some(PointerMove {
                dx: 3,
                dy: -3,
                wheel: 1
            })
        );
        assert_eq!((report.applied, report.lost), (3, 1));
        assert!(
            report.notes[0].starts_with(
                "1 command could not be written to the device; the first: moving the pointer (x 100, y 100, wheel 100)"
            ),
            "{:?}",
            report.notes
        );
    }

    #[test]
    fn home_events_are_not_for_the_computer() {
        let (mut d, seen) = recorder(&[]);
        d.apply(&OutputCommand::Home {
            event: crate::control::target::HomeEvent::new("lights").unwrap(),
            tick: 5,
            sequence: crate::control::action::ActionSeq::default(),
        });
        assert_eq!(*seen.borrow(), []);
        assert_eq!((d.applied, d.failures.count), (0, 0));
    }

    impl Driver<Recorder> {
        /// The run began just now.
        fn begin_for_test(&mut self) {
            self.tick_zero = Some(SystemTime::now());
        }
    }

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
