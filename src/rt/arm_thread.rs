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
