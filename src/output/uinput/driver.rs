//! Carries out the plans on a sink (the device, or a recorder in tests):
//! tracks what is held, counts what was applied and lost, sums the
//! pointer's travel, and lets go of everything held when closed or
//! dropped.

use std::io;
use std::time::{Duration, SystemTime};

use crate::control::keys;
use crate::control::output_command::{OutputCommand, PointerMove};
use crate::control::target::Click;
use crate::output::OutputReport;
use crate::output::uinput::plan::{
    BTN_LEFT, BTN_MIDDLE, BTN_RIGHT, EV_KEY, EV_REL, HeldKeys, REL_WHEEL, REL_X, REL_Y,
    UinputEvent, WriteStep, plan,
};

/// After the device is made, and before it is destroyed: time for the
/// desktop (udev, libinput) to open it before the first event, and to read
/// the last events (the releases) before it goes; a reader of a destroyed
/// device gets `ENODEV`, not the events still queued for it.
pub const SETTLE: Duration = Duration::from_millis(100);

/// Where the events go: the device, or a recorder in tests.
pub(super) trait Sink {
    /// Writes one frame (events ending with `SYN`) at once.
    fn write(&mut self, events: &[UinputEvent]) -> io::Result<()>;
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
pub(super) struct Driver<S: Sink> {
    pub(super) sink: S,
    held: HeldKeys,
    steps: Vec<WriteStep>,
    frame: Vec<UinputEvent>,
    applied: u64,
    failures: Failures,
    /// Keys and buttons that could not be let go of at the end.
    stuck: Option<String>,
    travel: PointerMove<i64>,
    pub(super) tick_zero: Option<SystemTime>,
    /// An event was written: wait [`SETTLE`] before the device goes.
    wrote: bool,
    closed: bool,
}

impl<S: Sink> Driver<S> {
    pub(super) fn new(sink: S) -> Driver<S> {
        Driver {
            sink,
            held: HeldKeys::new(),
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

    pub(super) fn apply(&mut self, command: &OutputCommand) {
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
    fn run(&mut self, steps: &[WriteStep]) -> io::Result<()> {
        self.frame.clear();
        for step in steps {
            match *step {
                WriteStep::Pause(duration) => self.sink.pause(duration),
                WriteStep::Write(event) => {
                    self.frame.push(event);
                    if event == UinputEvent::SYN {
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
    pub(super) fn finish(&mut self) {
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

    pub(super) fn report(&self, output: String) -> OutputReport {
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

#[cfg(test)]
mod tests {
    use std::cell::RefCell;
    use std::rc::Rc;

    use super::*;
    use crate::control::target::Chord;
    use crate::output::uinput::plan::KEY_HOLD;

    const KEY_LEFTCTRL: u16 = 29;
    const KEY_LEFTALT: u16 = 56;
    const KEY_T: u16 = 20;

    fn key(text: &str) -> OutputCommand {
        OutputCommand::Key(Chord::parse(text).unwrap())
    }

    /// What a recorder saw: each frame written, each pause.
    #[derive(Debug, Clone, PartialEq)]
    enum Seen {
        Frame(Vec<UinputEvent>),
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
        fn write(&mut self, events: &[UinputEvent]) -> io::Result<()> {
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

    fn frame(events: &[UinputEvent]) -> Seen {
        Seen::Frame(events.to_vec())
    }

    #[test]
    fn a_chord_is_written_a_frame_per_key() {
        let (mut d, seen) = recorder(&[]);
        d.apply(&key("ctrl+alt+t"));
        let k = UinputEvent::key;
        assert_eq!(
            *seen.borrow(),
            [
                frame(&[k(KEY_LEFTCTRL, true), UinputEvent::SYN]),
                frame(&[k(KEY_LEFTALT, true), UinputEvent::SYN]),
                frame(&[k(KEY_T, true), UinputEvent::SYN]),
                Seen::Pause(KEY_HOLD),
                frame(&[k(KEY_T, false), UinputEvent::SYN]),
                frame(&[k(KEY_LEFTALT, false), UinputEvent::SYN]),
                frame(&[k(KEY_LEFTCTRL, false), UinputEvent::SYN]),
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
                frame(&[UinputEvent::key(272, true), UinputEvent::SYN]),
                frame(&[UinputEvent::key(272, false), UinputEvent::SYN]),
            ]
        );
        d.apply(&OutputCommand::Button { down: true });
        d.finish();
        assert_eq!(
            seen.borrow()[2..],
            [
                frame(&[UinputEvent::key(272, true), UinputEvent::SYN]),
                frame(&[UinputEvent::key(272, false), UinputEvent::SYN]),
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
                frame(&[UinputEvent::key(272, true), UinputEvent::SYN]),
                frame(&[UinputEvent::key(272, false), UinputEvent::SYN]),
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
        let k = UinputEvent::key;
        assert_eq!(
            *seen.borrow(),
            [
                frame(&[k(KEY_LEFTCTRL, true), UinputEvent::SYN]),
                frame(&[k(KEY_LEFTALT, true), UinputEvent::SYN]),
                frame(&[
                    k(KEY_T, false),
                    k(KEY_LEFTALT, false),
                    k(KEY_LEFTCTRL, false),
                    UinputEvent::SYN
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
            sequence: crate::control::sequence::Sequence::default(),
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
}
