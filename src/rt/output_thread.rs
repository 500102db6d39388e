//! The outputs beyond the arm, each on its own thread: the control thread
//! hands each output the commands it serves through a bounded ring
//! ([`OutputLane`]) and never waits for it — a full ring drops the command
//! and counts it. The output's thread carries the commands out as they
//! come and, when the control thread's end of the ring goes (the run
//! ended, stopped, faulted or its thread died), closes the output: every
//! key and button held is let go before the device or connection goes.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, OnceLock};
use std::thread;
use std::time::{Duration, Instant, SystemTime};

use rtrb::RingBuffer;

use crate::control::output_command::OutputCommand;
use crate::output::{Output, OutputReport};
use crate::rt::serving::ServingReport;
use crate::wakes::{WakeLog, Wakes};

/// Commands to one output: 2 s of pointer moves at 100 Hz, with room for
/// the actions of a burst of matches.
pub const OUTPUT_RING: usize = 256;
/// How long an output's thread sleeps when there is nothing to do.
const IDLE_SLEEP: Duration = Duration::from_millis(1);

/// Which commands an output serves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Serves {
    /// The keyboard and pointer: keys, clicks, the button, pointer moves,
    /// letting go.
    Computer,
    /// Home events.
    Home,
}

impl Serves {
    /// Whether `command` is for this kind of output. RT-safe.
    pub fn wants(self, command: &OutputCommand) -> bool {
        match self {
            Serves::Computer => command.is_for_computer(),
            Serves::Home => command.is_for_home(),
        }
    }
}

/// The wall-clock time of the loop's tick 0, once the control thread
/// knows it (after its real-time set-up, which may take tens of ms): a
/// command's tick becomes a time from it (a home event's match time).
#[derive(Debug, Clone, Default)]
pub struct TickZero(Arc<OnceLock<SystemTime>>);

impl TickZero {
    /// Not known yet: the control loop sets it.
    pub fn new() -> TickZero {
        TickZero::default()
    }

    /// Known already (a loop that is not timed by the wall clock).
    pub fn known(at: SystemTime) -> TickZero {
        let zero = TickZero::new();
        zero.set(at);
        zero
    }

    /// Tick 0 is at `at`. The first call wins. Called once, before the
    /// loop's first deadline.
    pub fn set(&self, at: SystemTime) {
        let _ = self.0.set(at);
    }

    /// Tick 0's time, if known.
    pub fn get(&self) -> Option<SystemTime> {
        self.0.get().copied()
    }
}

/// The control thread's end of one output's ring. RT-safe to push into.
pub struct OutputLane {
    serves: Serves,
    ring: rtrb::Producer<OutputCommand>,
    dropped: Arc<AtomicU64>,
}

impl OutputLane {
    /// Hands `command` on if the output serves it; a full ring drops it
    /// (counted in the output's report). RT-safe: never blocks.
    pub fn offer(&mut self, command: &OutputCommand) {
        if self.serves.wants(command) && self.ring.push(*command).is_err() {
            self.dropped.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// One output on its own thread, until the control thread's end of its
/// ring goes.
pub struct OutputThread {
    handle: thread::JoinHandle<(OutputReport, Option<Wakes>)>,
    describe: String,
    has_deadlines: bool,
}

impl OutputThread {
    /// Starts `output`'s thread; returns it and the lane the control
    /// thread pushes into. Commands are given times from `tick_zero`: the
    /// thread begins the output once it is known (or the loop never ran).
    pub fn start(
        serves: Serves,
        output: Box<dyn Output>,
        tick_zero: TickZero,
    ) -> std::io::Result<(OutputThread, OutputLane)> {
        Self::start_with_ring(serves, output, tick_zero, OUTPUT_RING)
    }

    /// [`OutputThread::start`] with a ring of `capacity` commands.
    pub fn start_with_ring(
        serves: Serves,
        mut output: Box<dyn Output>,
        tick_zero: TickZero,
        capacity: usize,
    ) -> std::io::Result<(OutputThread, OutputLane)> {
        let (ring, mut commands) = RingBuffer::new(capacity);
        let dropped = Arc::new(AtomicU64::new(0));
        let lane = OutputLane {
            serves,
            ring,
            dropped: dropped.clone(),
        };
        let describe = output.describe();
        let has_deadlines = output.has_deadlines();
        let handle = thread::Builder::new()
            .name(format!("output {}", short_name(&describe)))
            .spawn(move || {
                // A thread a person waits on keeps its wake-ups and page
                // faults, for the report.
                let mut log = has_deadlines.then(|| {
                    let mut log = WakeLog::start();
                    log.due_on("the end of its 1 ms sleep");
                    log
                });
                let zero = loop {
                    if let Some(zero) = tick_zero.get() {
                        break zero;
                    }
                    if commands.is_abandoned() {
                        break SystemTime::now(); // the loop never started
                    }
                    thread::sleep(IDLE_SLEEP);
                };
                output.begin(zero);
                loop {
                    let mut worked = false;
                    while let Ok(command) = commands.pop() {
                        output.apply(&command);
                        worked = true;
                    }
                    if commands.is_abandoned() && commands.is_empty() {
                        break;
                    }
                    output.idle();
                    if !worked {
                        let asleep = Instant::now();
                        thread::sleep(IDLE_SLEEP);
                        if let Some(log) = log.as_mut() {
                            let late = asleep.elapsed().saturating_sub(IDLE_SLEEP);
                            log.woke(late.as_nanos() as u64);
                        }
                    }
                }
                let wakes = log.map(WakeLog::finish);
                let mut report = output.close();
                report.dropped += dropped.load(Ordering::Relaxed);
                (report, wakes)
            })?;
        Ok((
            OutputThread {
                handle,
                describe,
                has_deadlines,
            },
            lane,
        ))
    }

    /// Its thread and that thread's name, if a person waits on what it
    /// does ([`Output::has_deadlines`]): for the run to give it its
    /// real-time priority.
    pub fn deadline_thread(&self) -> Option<(String, libc::pthread_t)> {
        use std::os::unix::thread::JoinHandleExt;
        self.has_deadlines.then(|| {
            let name = self.handle.thread().name().unwrap_or("output").to_string();
            (name, self.handle.as_pthread_t())
        })
    }

    /// Waits for the output to close (its lane must be gone) and returns
    /// its report, and a deadline thread's wake-ups and page faults; a
    /// thread that died says so.
    pub fn join(self) -> (OutputReport, Option<ServingReport>) {
        let name = self.handle.thread().name().unwrap_or("output").to_string();
        match self.handle.join() {
            Ok((report, wakes)) => (report, wakes.map(|w| ServingReport::new(&name, w))),
            Err(_) => (
                OutputReport {
                    output: self.describe.clone(),
                    notes: vec![format!(
                        "the output's thread died: {} may not have let go of what it held",
                        self.describe
                    )],
                    ..OutputReport::default()
                },
                None,
            ),
        }
    }
}

/// The first word of an output's description (a thread's name is short).
fn short_name(describe: &str) -> &str {
    describe.split_whitespace().next().unwrap_or("output")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An output that only counts what it is given, and its idle calls.
    struct Counting {
        deadlines: bool,
        applied: u64,
        idles: Arc<AtomicU64>,
    }

    impl Output for Counting {
        fn describe(&self) -> String {
            "counting".into()
        }
        fn apply(&mut self, _command: &OutputCommand) {
            self.applied += 1;
        }
        fn idle(&mut self) {
            self.idles.fetch_add(1, Ordering::Relaxed);
        }
        fn has_deadlines(&self) -> bool {
            self.deadlines
        }
        fn close(&mut self) -> OutputReport {
            OutputReport {
                output: self.describe(),
                applied: self.applied,
                ..OutputReport::default()
            }
        }
    }

    /// Runs an output's thread with one command, for three of its sleeps
    /// (each between two idle calls).
    fn serve(deadlines: bool) -> (OutputReport, Option<ServingReport>) {
        let idles = Arc::new(AtomicU64::new(0));
        let output = Box::new(Counting {
            deadlines,
            applied: 0,
            idles: idles.clone(),
        });
        let (thread, mut lane) =
            OutputThread::start(Serves::Computer, output, TickZero::known(SystemTime::now()))
                .unwrap();
        lane.offer(&OutputCommand::Button { down: true });
        while idles.load(Ordering::Relaxed) < 4 {
            thread::sleep(Duration::from_millis(1));
        }
        drop(lane);
        thread.join()
    }

    #[test]
    fn an_output_a_person_waits_on_reports_its_wake_ups_and_page_faults() {
        let (report, wakes) = serve(true);
        assert_eq!(report.applied, 1);
        let wakes = wakes.expect("a deadline thread keeps its wake-ups");
        assert_eq!(wakes.thread, "output counting");
        assert_eq!(wakes.due, Some("the end of its 1 ms sleep"));
        assert!(wakes.wake.len() >= 3, "{}", wakes.wake.len());
    }

    #[test]
    fn a_network_output_keeps_no_wake_ups() {
        let (report, wakes) = serve(false);
        assert_eq!(report.applied, 1);
        assert!(wakes.is_none());
    }
}
