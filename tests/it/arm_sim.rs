//! The simulated JACO2 (`arm::sim`): where its commands take it, and
//! when it says it left the workspace.

use sipnpuff::control::motion::stream::{ARM_STREAM_PERIOD_TICKS, ArmCommand};

use sipnpuff::arm::sim::*;
use sipnpuff::config::Config;

fn along_z(speed: f64) -> ArmCommand {
    ArmCommand {
        linear: [0.0, 0.0, speed],
        ..ArmCommand::default()
    }
}

/// Drives `arm` for `cycles` 10 ms cycles of `command`, still
/// milliseconds (skipped ones too) between them.
fn drive(arm: &mut SimulatedJaco, command: &ArmCommand, cycles: usize) {
    for _ in 0..cycles {
        arm.command(command);
        for _ in 0..ARM_STREAM_PERIOD_TICKS + 5 {
            arm.advance_ms();
        }
    }
}

#[test]
fn it_says_when_it_leaves_the_workspace_and_when_it_is_back() {
    let config = Config::default();
    let mut arm = SimulatedJaco::new(config.core());
    assert!(arm.inside_workspace(), "home is inside");
    // From z = 0.48 m down at 1 m/s: 60 cycles is 0.6 m, below the
    // table (z = 0).
    drive(&mut arm, &along_z(-1.0), 60);
    assert!(arm.state().pose.translation.vector.z < 0.0);
    assert!(!arm.inside_workspace());
    drive(&mut arm, &ArmCommand::default(), 3); // standing still
    assert!(!arm.inside_workspace());
    drive(&mut arm, &along_z(1.0), 20);
    assert!(arm.inside_workspace());
    // Put outside the reach, and back home.
    let mut far = arm.state().pose;
    far.translation.vector.x = 2.0;
    arm.move_to(far);
    assert!(!arm.inside_workspace());
    arm.move_to(config.core().home().pose());
    assert!(arm.inside_workspace());
    // The fingers past their closed end.
    let close = ArmCommand {
        fingers: 10_000.0,
        ..ArmCommand::default()
    };
    drive(&mut arm, &close, 100);
    assert!(!arm.inside_workspace(), "fingers at {}", arm.fingers());
}
