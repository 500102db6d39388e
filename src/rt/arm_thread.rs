//! The arm thread: takes the core's 100 Hz commands from their ring and
//! sends them to the arm, and ends the stream with a zero command on every
//! way out.
//!
//! Waking: only for work. The control thread wakes it when it hands over a
//! command ([`ArmHandoff`]), so a command reaches the arm within a wake-up
//! of the tick that made it; 10 ms without a command (the stream's
//! period) wakes it too. At each wake-up it asks the backend whether its
//! link stands ([`Arm::check_link`]) and for news of the measured pose
//! ([`Arm::feedback`]), which goes to the control thread through its own
//! ring when the backend measures the pose.
//! Commands are sent in order, all of them: each is 10 ms of the path the
//! core's pose estimate (and its workspace checks) assumed, so the arm
//! retraces that path even after a stall of this thread.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::Thread;
use std::time::Duration;

use hdrhistogram::Histogram;
use nalgebra::Isometry3;

use crate::arm::{Arm, ArmError, ArmState, ThreadRef, end_stream};
use crate::clock::{Clock, MonotonicClock};
use crate::control::motion::stream::ArmCommand;
use crate::rt::serving::ServingReport;
use crate::wakes::{WakeLog, histogram};

/// How long the thread waits for a command before it wakes anyway: the
/// stream's 10 ms.
pub const ARM_WAKE_NS: u64 = 10_000_000;

/// A command handed to the arm thread, with when the control tick that
/// made it woke (the arm thread's wake-up latency is measured from it).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Handed {
    /// The command.
    pub command: ArmCommand,
    /// When its control tick woke, ns on the monotonic clock.
    pub tick_woke_ns: u64,
}

/// The control thread's end of the command ring: each command pushed
/// wakes the arm thread. Neither allocates nor blocks.
pub struct ArmHandoff {
    ring: rtrb::Producer<Handed>,
    thread: Option<Thread>,
}

impl ArmHandoff {
    /// Hands over through `ring`; nobody is woken until [`Self::wakes`].
    pub fn new(ring: rtrb::Producer<Handed>) -> ArmHandoff {
        ArmHandoff { ring, thread: None }
    }

    /// Each command from here on wakes `thread`.
    pub fn wakes(&mut self, thread: Thread) {
        self.thread = Some(thread);
    }

    /// Hands `command` over and wakes the arm thread; a full ring gives
    /// the command back.
    pub fn hand(&mut self, command: ArmCommand, tick_woke_ns: u64) -> Result<(), ArmCommand> {
        let handed = Handed {
            command,
            tick_woke_ns,
        };
        let pushed = self.ring.push(handed).map_err(|_| command);
        if let Some(thread) = &self.thread {
            // A futex wake: it returns at once whether or not the thread
            // waits, and allocates nothing (the counting allocator still
            // checks). RealtimeSanitizer flags every raw `syscall`, so it
            // is told that this one is known not to block.
            let _known_nonblocking = rtsan_standalone::ScopedDisabler::default();
            thread.unpark();
        }
        pushed
    }
}

/// A connected arm whose stream must end with a zero command: done by
/// `ArmStream::end`, or, on any other way out (an early return, a panic),
/// when it is dropped.
pub struct ArmStream {
    arm: Box<dyn Arm>,
    last: Option<ArmCommand>,
    ended: bool,
}

impl ArmStream {
    /// Connects `arm`; from here on its stream ends with a zero command.
    pub fn connect(mut arm: Box<dyn Arm>) -> Result<ArmStream, ArmError> {
        arm.connect()?;
        Ok(ArmStream {
            arm,
            last: None,
            ended: false,
        })
    }

    /// Whether the arm reports a measured pose.
    pub fn measures_pose(&self) -> bool {
        self.arm.measures_pose()
    }

    /// The backend's own threads that carry the stream ([`Arm::threads`]).
    pub fn backend_threads(&self) -> Vec<(String, ThreadRef)> {
        self.arm.threads()
    }

    /// The arm's newest state, if it has one (at start: where it is).
    pub fn feedback(&mut self) -> Option<ArmState> {
        self.arm.feedback()
    }

    /// Sends one command.
    fn send(&mut self, command: &ArmCommand) -> Result<(), ArmError> {
        self.arm.send(command)?;
        self.last = Some(*command);
        Ok(())
    }

    /// Ends the stream (once): a zero command, then stop.
    fn end(&mut self) -> Result<(), ArmError> {
        if self.ended {
            return Ok(());
        }
        self.ended = true;
        end_stream(self.arm.as_mut(), self.last.as_ref())
    }
}

impl Drop for ArmStream {
    fn drop(&mut self) {
        // Nothing to report to from here: the zero command is what counts.
        let _ = self.end();
    }
}

/// What the arm thread did.
#[derive(Debug)]
pub struct ArmReport {
    /// The last state the arm reported, if it reports one.
    pub state: Option<ArmState>,
    /// Commands received from the core.
    pub commands: u64,
    /// The stream was ended with a zero command and the arm stopped.
    pub ended_with_zero: bool,
    /// The first error the arm gave, if any (the run was then stopped).
    pub error: Option<ArmError>,
    /// States the arm reported.
    pub reports: u64,
    /// Measured poses the control thread's full ring could not take
    /// (dropped and counted; the newest wins anyway).
    pub feedback_drops: u64,
    /// Its wake-ups for commands, from their tick's wake-up, and its page
    /// faults.
    pub serving: ServingReport,
    /// Time between one command's send and the next's, ns (nominally the
    /// stream's 10 ms: what the arm's own stream watchdog sees).
    pub send_gaps: Histogram<u64>,
}

/// Where the measured poses go: the control thread's ring, when the arm
/// measures its pose.
pub type FeedbackProducer = rtrb::Producer<Isometry3<f64>>;

/// Runs until the command ring is abandoned (the control loop ended) and
/// drained. On an error from the arm (a refused command, a lost link):
/// ends the stream at once (zero command, stop), sets `fault` so the
/// control loop stops safely, and sends nothing more. `state` is the
/// arm's state at the start; measured poses go to `measured`, if given.
pub fn run_arm(
    mut stream: ArmStream,
    commands: &mut rtrb::Consumer<Handed>,
    fault: &Arc<AtomicBool>,
    state: Option<ArmState>,
    mut measured: Option<FeedbackProducer>,
) -> ArmReport {
    let mut clock = MonotonicClock;
    let mut send_gaps = histogram();
    let mut log = WakeLog::start();
    log.due_on("its command's control tick");
    let mut report_state = state.or_else(|| stream.arm.feedback());
    let mut received = 0u64;
    let mut reports = 0u64;
    let mut feedback_drops = 0u64;
    let mut error: Option<ArmError> = None;
    let mut ended_with_zero = false;
    let mut last_send_ns: Option<u64> = None;
    let mut fail = |stream: &mut ArmStream, error: &mut Option<ArmError>, e: ArmError| {
        ended_with_zero = stream.end().is_ok();
        *error = Some(e);
        fault.store(true, Ordering::Relaxed);
    };
    let mut next_ns = clock.now_ns() + ARM_WAKE_NS;
    loop {
        // Woken by a handed command, or 10 ms after the last wake-up
        // without one (a spurious wake-up only drains an empty ring).
        let now = clock.now_ns();
        if next_ns > now {
            std::thread::park_timeout(Duration::from_nanos(next_ns - now));
        }
        let woke = clock.now_ns();
        let timed = woke >= next_ns;
        next_ns = woke + ARM_WAKE_NS;
        // Checked before draining: whatever was pushed before the loop
        // ended is sent.
        let abandoned = commands.is_abandoned();
        let mut sent = false;
        while let Ok(handed) = commands.pop() {
            received += 1;
            log.woke(woke.saturating_sub(handed.tick_woke_ns));
            if error.is_some() {
                continue;
            }
            match stream.send(&handed.command) {
                Ok(()) => {
                    sent = true;
                    let at = clock.now_ns();
                    if let Some(last) = last_send_ns.replace(at) {
                        send_gaps.saturating_record(at.saturating_sub(last).max(1));
                    }
                }
                Err(e) => fail(&mut stream, &mut error, e),
            }
        }
        if error.is_none()
            && let Err(e) = stream.arm.check_link()
        {
            fail(&mut stream, &mut error, e);
        }
        // The arm's state after each command sent, at the stream's period,
        // and at the end; a measured pose goes on to the control thread.
        if (measured.is_some() || sent || timed || abandoned)
            && let Some(state) = stream.arm.feedback()
        {
            report_state = Some(state);
            reports += 1;
            if error.is_none()
                && let Some(ring) = measured.as_mut()
                && ring.push(state.pose).is_err()
            {
                feedback_drops += 1;
            }
        }
        if abandoned {
            break;
        }
    }
    // The stream's end (a backend may start a thread to close its link)
    // is after the run, not in it.
    let serving = ServingReport::new("arm", log.finish());
    if error.is_none() {
        match stream.end() {
            Ok(()) => ended_with_zero = true,
            Err(e) => error = Some(e),
        }
        if let Some(state) = stream.arm.feedback() {
            report_state = Some(state);
        }
    }
    ArmReport {
        state: report_state,
        commands: received,
        ended_with_zero,
        error,
        reports,
        feedback_drops,
        serving,
        send_gaps,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    /// What a test arm was told, in order.
    #[derive(Debug, Clone, PartialEq)]
    enum Call {
        Connect,
        Send(ArmCommand),
        Stop,
    }

    /// An arm that records every call and refuses the `fail_at`-th send.
    struct RecordingArm {
        calls: Arc<Mutex<Vec<Call>>>,
        sends: usize,
        fail_at: Option<usize>,
    }

    impl RecordingArm {
        fn new(fail_at: Option<usize>) -> (Box<RecordingArm>, Arc<Mutex<Vec<Call>>>) {
            let calls = Arc::new(Mutex::new(Vec::new()));
            let arm = RecordingArm {
                calls: calls.clone(),
                sends: 0,
                fail_at,
            };
            (Box::new(arm), calls)
        }
    }

    impl Arm for RecordingArm {
        fn describe(&self) -> String {
            "recording".into()
        }
        fn connect(&mut self) -> Result<(), ArmError> {
            self.calls.lock().unwrap().push(Call::Connect);
            Ok(())
        }
        fn send(&mut self, command: &ArmCommand) -> Result<(), ArmError> {
            self.sends += 1;
            if Some(self.sends) == self.fail_at {
                return Err(ArmError::Rejected {
                    detail: "test".into(),
                });
            }
            self.calls.lock().unwrap().push(Call::Send(*command));
            Ok(())
        }
        fn feedback(&mut self) -> Option<ArmState> {
            None
        }
        fn stop(&mut self) -> Result<(), ArmError> {
            self.calls.lock().unwrap().push(Call::Stop);
            Ok(())
        }
    }

    fn moving(seq: u64) -> ArmCommand {
        ArmCommand {
            seq,
            tick: 10 * seq + 9,
            linear: [0.2, 0.0, 0.0],
            ..ArmCommand::default()
        }
    }

    /// The zero command that follows command `seq − 1`.
    fn zero_after(seq: u64) -> ArmCommand {
        ArmCommand {
            seq,
            tick: 10 * seq + 9,
            ..ArmCommand::default()
        }
    }

    /// Runs the arm thread over `commands` pushed before the control side
    /// goes away (mid-motion: the last one moves).
    fn run(commands: &[ArmCommand], fail_at: Option<usize>) -> (Vec<Call>, ArmReport, bool) {
        let (arm, calls) = RecordingArm::new(fail_at);
        let stream = ArmStream::connect(arm).unwrap();
        let (tx, mut rx) = rtrb::RingBuffer::new(64);
        let mut handoff = ArmHandoff::new(tx);
        for c in commands {
            handoff.hand(*c, 0).unwrap();
        }
        drop(handoff);
        let fault = Arc::new(AtomicBool::new(false));
        let report = run_arm(stream, &mut rx, &fault, None, None);
        let calls = calls.lock().unwrap().clone();
        (calls, report, fault.load(Ordering::Relaxed))
    }

    #[test]
    fn a_stream_cut_mid_motion_ends_with_a_zero_command_then_stop() {
        let commands: Vec<ArmCommand> = (0..5).map(moving).collect();
        let (calls, report, fault) = run(&commands, None);
        let mut expected = vec![Call::Connect];
        expected.extend(commands.iter().map(|c| Call::Send(*c)));
        expected.extend([Call::Send(zero_after(5)), Call::Stop]);
        assert_eq!(calls, expected);
        assert!(zero_after(5).is_zero());
        assert_eq!(report.commands, 5);
        assert!(report.ended_with_zero && report.error.is_none() && !fault);
    }

    #[test]
    fn an_arm_error_ends_the_stream_at_once_and_asks_the_loop_to_stop() {
        let commands: Vec<ArmCommand> = (0..6).map(moving).collect();
        let (calls, report, fault) = run(&commands, Some(3));
        // Two commands went through; the third was refused: a zero command
        // and stop, and nothing after it.
        assert_eq!(
            calls,
            [
                Call::Connect,
                Call::Send(commands[0]),
                Call::Send(commands[1]),
                Call::Send(zero_after(2)),
                Call::Stop
            ]
        );
        assert!(matches!(report.error, Some(ArmError::Rejected { .. })));
        assert!(report.ended_with_zero);
        assert_eq!(report.commands, 6, "every command was taken off the ring");
        assert!(fault, "the control loop is asked for a safe stop");
    }

    #[test]
    fn a_handed_command_wakes_the_parked_arm_thread() {
        let (tx, mut rx) = rtrb::RingBuffer::new(4);
        let mut handoff = ArmHandoff::new(tx);
        let taker = std::thread::spawn(move || {
            // Parks with no timeout: only the handoff can wake it.
            loop {
                if let Ok(handed) = rx.pop() {
                    break handed;
                }
                std::thread::park();
            }
        });
        handoff.wakes(taker.thread().clone());
        handoff.hand(moving(3), 42).unwrap();
        assert_eq!(
            taker.join().unwrap(),
            Handed {
                command: moving(3),
                tick_woke_ns: 42
            }
        );
    }

    #[test]
    fn an_empty_stream_still_ends_with_a_zero_command() {
        let (calls, report, _) = run(&[], None);
        let zero = ArmCommand::default();
        assert_eq!(calls, [Call::Connect, Call::Send(zero), Call::Stop]);
        assert!(report.ended_with_zero);
    }

    #[test]
    fn a_connected_arm_dropped_on_any_other_way_out_still_gets_its_zero() {
        let (arm, calls) = RecordingArm::new(None);
        let mut stream = ArmStream::connect(arm).unwrap();
        stream.send(&moving(0)).unwrap();
        drop(stream); // e.g. a run that fails to start its threads
        let calls = calls.lock().unwrap().clone();
        assert_eq!(
            calls,
            [
                Call::Connect,
                Call::Send(moving(0)),
                Call::Send(zero_after(1)),
                Call::Stop
            ]
        );
    }
}
