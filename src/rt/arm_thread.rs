//! The arm thread: takes the core's 100 Hz commands from their ring and
//! sends them to the arm, paced by the same absolute-deadline scheduler as
//! the control loop (a 10 ms period), and ends the stream with a zero
//! command on every way out.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::arm::{Arm, ArmError, ArmState, end_stream};
use crate::control::motion::stream::ArmCommand;
use crate::rt::clock::{Clock, MonotonicClock};
use crate::rt::scheduler::Scheduler;

/// The arm's cycle: 10 ms.
pub const ARM_PERIOD_NS: u64 = 10_000_000;

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
}

/// Runs until the command ring is abandoned (the control loop ended) and
/// drained. On an error from the arm: ends the stream at once (zero
/// command, stop), sets `stop` so the control loop stops safely, and
/// sends nothing more.
pub fn run_arm(
    arm: &mut dyn Arm,
    commands: &mut rtrb::Consumer<ArmCommand>,
    stop: &Arc<AtomicBool>,
) -> ArmReport {
    let mut clock = MonotonicClock;
    let mut scheduler = Scheduler::new(clock.now_ns() + ARM_PERIOD_NS, ARM_PERIOD_NS, None);
    let mut report = ArmReport {
        state: arm.feedback(),
        commands: 0,
        ended_with_zero: false,
        error: None,
    };
    let mut last: Option<ArmCommand> = None;
    loop {
        scheduler.wait(&mut clock);
        // Checked before draining: whatever was pushed before the loop
        // ended is sent.
        let abandoned = commands.is_abandoned();
        while let Ok(command) = commands.pop() {
            report.commands += 1;
            if report.error.is_some() {
                continue;
            }
            match arm.send(&command) {
                Ok(()) => last = Some(command),
                Err(error) => {
                    report.ended_with_zero = end_stream(arm, last.as_ref()).is_ok();
                    report.error = Some(error);
                    stop.store(true, Ordering::Relaxed);
                }
            }
        }
        if let Some(state) = arm.feedback() {
            report.state = Some(state);
        }
        if abandoned {
            break;
        }
    }
    if report.error.is_none() {
        match end_stream(arm, last.as_ref()) {
            Ok(()) => report.ended_with_zero = true,
            Err(error) => report.error = Some(error),
        }
        if let Some(state) = arm.feedback() {
            report.state = Some(state);
        }
    }
    report
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    /// What a test arm was told, in order.
    #[derive(Debug, Clone, PartialEq)]
    enum Call {
        Send(ArmCommand),
        Stop,
    }

    /// An arm that records every call and refuses the `fail_at`-th send.
    struct RecordingArm {
        calls: Arc<Mutex<Vec<Call>>>,
        sends: usize,
        fail_at: Option<usize>,
    }

    impl Arm for RecordingArm {
        fn describe(&self) -> String {
            "recording".into()
        }
        fn connect(&mut self) -> Result<(), ArmError> {
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

    /// Runs the arm thread over `commands` pushed before the control side
    /// goes away (mid-motion: the last one moves).
    fn run(commands: &[ArmCommand], fail_at: Option<usize>) -> (Vec<Call>, ArmReport, bool) {
        let calls = Arc::new(Mutex::new(Vec::new()));
        let mut arm = RecordingArm {
            calls: calls.clone(),
            sends: 0,
            fail_at,
        };
        let (mut tx, mut rx) = rtrb::RingBuffer::new(64);
        for c in commands {
            tx.push(*c).unwrap();
        }
        drop(tx);
        let stop = Arc::new(AtomicBool::new(false));
        let report = run_arm(&mut arm, &mut rx, &stop);
        let calls = calls.lock().unwrap().clone();
        (calls, report, stop.load(Ordering::Relaxed))
    }

    #[test]
    fn a_stream_cut_mid_motion_ends_with_a_zero_command_then_stop() {
        let commands: Vec<ArmCommand> = (0..5).map(moving).collect();
        let (calls, report, stopped) = run(&commands, None);
        let sent: Vec<Call> = commands.iter().map(|c| Call::Send(*c)).collect();
        assert_eq!(calls[..5], sent[..]);
        let zero = ArmCommand {
            seq: 5,
            tick: 59,
            ..ArmCommand::default()
        };
        assert_eq!(calls[5..], [Call::Send(zero), Call::Stop]);
        assert!(zero.is_zero());
        assert_eq!(report.commands, 5);
        assert!(report.ended_with_zero && report.error.is_none() && !stopped);
    }

    #[test]
    fn an_arm_error_ends_the_stream_at_once_and_asks_the_loop_to_stop() {
        let commands: Vec<ArmCommand> = (0..6).map(moving).collect();
        let (calls, report, stopped) = run(&commands, Some(3));
        // Two commands went through; the third was refused: a zero command
        // and stop, and nothing after it.
        let zero = ArmCommand {
            seq: 2,
            tick: 29,
            ..ArmCommand::default()
        };
        assert_eq!(
            calls,
            [
                Call::Send(commands[0]),
                Call::Send(commands[1]),
                Call::Send(zero),
                Call::Stop
            ]
        );
        assert!(matches!(report.error, Some(ArmError::Rejected { .. })));
        assert!(report.ended_with_zero);
        assert_eq!(report.commands, 6, "every command was taken off the ring");
        assert!(stopped, "the control loop is asked for a safe stop");
    }

    #[test]
    fn an_empty_stream_still_ends_with_a_zero_command() {
        let (calls, report, _) = run(&[], None);
        assert_eq!(calls, [Call::Send(ArmCommand::default()), Call::Stop]);
        assert!(report.ended_with_zero);
    }
}
