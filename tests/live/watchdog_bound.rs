//! The watchdog that bounds every process a test starts: past its bound
//! the child is killed and its test fails saying what it was doing.

use std::process::Command;
use std::time::Duration;

use crate::watchdog::{spawn, wait, watch};

/// A child past its bound is killed, and its test fails saying what it
/// was and what its threads were doing; a child that ends in time is left
/// alone.
#[test]
fn a_child_past_its_bound_is_killed_and_described() {
    const STUCK: &str = "`sleep 1000`, stuck on purpose by the watchdog's own test";
    let mut stuck = Command::new("sleep");
    stuck.arg("1000");
    let mut stuck = spawn(&mut stuck);
    watch(&stuck, STUCK, Duration::from_millis(300));
    let why = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| wait(&mut stuck)))
        .expect_err("the test fails")
        .downcast::<String>()
        .expect("a message");
    // Reaped by that wait: its status is kept.
    let status = stuck.wait().unwrap();
    assert_eq!(
        std::os::unix::process::ExitStatusExt::signal(&status),
        Some(libc::SIGKILL)
    );
    for part in [
        "WATCHDOG: `sleep 1000`, stuck on purpose by the watchdog's own test (pid ",
        "did not exit within its bound; killed",
        "command: sleep 1000",
        "\"sleep\" state S waiting in ",
    ] {
        assert!(why.contains(part), "{part:?} in {why}");
    }

    let mut quick = Command::new("true");
    let mut quick = spawn(&mut quick);
    assert!(wait(&mut quick).success());
}
