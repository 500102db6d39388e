//! The run's life told to systemd (`Type=notify`, `WatchdogSec=`):
//! `READY=1` once the control loop runs, `WATCHDOG=1` only while its
//! ticks keep coming, `STOPPING=1` when it ends. A loop that stalls (a
//! thread stopped, starved or stuck) goes unpetted and systemd restarts
//! the service; the arm's own stream watchdog has stopped the arm by
//! then. A loop that runs late is not restarted: a restart takes the
//! person's control away for seconds and cures no load; its missed
//! deadlines are in the report. Outside systemd (no `NOTIFY_SOCKET`)
//! nothing is sent.
//!
//! The judgement is [`Liveness`]: pure, on the ticks' own wake-up times.

use std::time::Duration;

use sd_notify::NotifyState;

/// How long since the newest tick's wake-up the loop still counts as
/// running: the telemetry drains every 5 ms.
pub const MAX_SILENCE_NS: u64 = 100_000_000;

/// Whether the control loop kept running between pets, from each tick's
/// wake-up time.
#[derive(Debug, Default, Clone)]
pub struct Liveness {
    /// The newest tick's wake-up (ns).
    newest_ns: Option<u64>,
    /// The window's longest time between two ticks' wake-ups (ns).
    longest_gap_ns: u64,
    /// Whether a tick ran in the window.
    ticked: bool,
}

impl Liveness {
    /// One tick seen: its wake-up (`CLOCK_MONOTONIC` ns).
    pub fn tick(&mut self, woke_ns: u64) {
        if let Some(previous) = self.newest_ns {
            self.longest_gap_ns = self.longest_gap_ns.max(woke_ns.saturating_sub(previous));
        }
        self.newest_ns = Some(woke_ns);
        self.ticked = true;
    }

    /// Whether the loop has run at all.
    pub fn running(&self) -> bool {
        self.newest_ns.is_some()
    }

    /// At `now_ns`: whether the loop kept running since the last
    /// judgement (ticks since then, never [`MAX_SILENCE_NS`] apart, the
    /// newest no older); starts the next window.
    pub fn judge(&mut self, now_ns: u64) -> bool {
        let Some(newest) = self.newest_ns else {
            return false;
        };
        let silence = self.longest_gap_ns.max(now_ns.saturating_sub(newest));
        let alive = self.ticked && silence <= MAX_SILENCE_NS;
        self.longest_gap_ns = 0;
        self.ticked = false;
        alive
    }
}

/// The notifications of one run: silent unless systemd started it.
pub struct ServiceNotifier {
    /// Pet every this long (half `WatchdogSec`), when systemd watches.
    pet_every_ns: Option<u64>,
    last_pet_ns: u64,
    ready: bool,
}

impl ServiceNotifier {
    /// From the environment systemd gives a `Type=notify` service.
    pub fn from_environment() -> ServiceNotifier {
        let watched = std::env::var_os("NOTIFY_SOCKET").is_some();
        ServiceNotifier {
            pet_every_ns: sd_notify::watchdog_enabled()
                .filter(|_| watched)
                .map(|d| (d / 2).as_nanos().min(u128::from(u64::MAX)) as u64),
            last_pet_ns: 0,
            ready: false,
        }
    }

    /// The watchdog's pet interval, when systemd watches.
    pub fn pet_every(&self) -> Option<Duration> {
        self.pet_every_ns.map(Duration::from_nanos)
    }

    /// After each drain, at `now_ns`, with the ticks seen so far
    /// (`liveness`): `READY=1` at the first tick, then `WATCHDOG=1` each
    /// interval the loop kept its deadlines.
    pub fn tend(&mut self, now_ns: u64, liveness: &mut Liveness, status: &dyn Fn() -> String) {
        if !liveness.running() {
            return;
        }
        if !self.ready {
            self.ready = true;
            self.last_pet_ns = now_ns;
            let status = status();
            let _ = sd_notify::notify(&[NotifyState::Ready, NotifyState::Status(&status)]);
            return;
        }
        let Some(every) = self.pet_every_ns else {
            return;
        };
        if now_ns.saturating_sub(self.last_pet_ns) < every {
            return;
        }
        self.last_pet_ns = now_ns;
        if liveness.judge(now_ns) {
            let _ = sd_notify::notify(&[NotifyState::Watchdog]);
        }
    }

    /// The loop has ended: `STOPPING=1` with why.
    pub fn stopping(&self, why: &str) {
        if self.ready {
            let _ = sd_notify::notify(&[NotifyState::Stopping, NotifyState::Status(why)]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: u64 = 1_000_000;

    /// Ticks `from..to`, one a millisecond, none skipped.
    fn run(liveness: &mut Liveness, from: u64, to: u64) {
        for t in from..to {
            liveness.tick(t * MS);
        }
    }

    #[test]
    fn a_loop_on_time_is_alive_each_window() {
        let mut l = Liveness::default();
        assert!(!l.judge(0), "before the first tick");
        run(&mut l, 0, 500);
        assert!(l.judge(500 * MS));
        run(&mut l, 500, 1000);
        assert!(l.judge(1003 * MS));
    }

    #[test]
    fn a_loop_that_stops_is_not() {
        let mut l = Liveness::default();
        run(&mut l, 0, 500);
        assert!(l.judge(500 * MS));
        // Nothing since: its newest tick is 101 ms old.
        assert!(!l.judge(600 * MS));
        assert!(!l.judge(1000 * MS));
    }

    #[test]
    fn a_window_that_held_a_stall_is_not_alive_though_the_loop_runs_again() {
        let mut l = Liveness::default();
        run(&mut l, 0, 500);
        assert!(l.judge(500 * MS));
        // Stopped 600 ms (SIGSTOP), then on time again.
        run(&mut l, 1100, 1110);
        assert!(!l.judge(1110 * MS));
        run(&mut l, 1110, 1600);
        assert!(l.judge(1600 * MS));
    }

    #[test]
    fn a_late_loop_is_alive_while_its_ticks_keep_coming() {
        let mut l = Liveness::default();
        run(&mut l, 0, 10);
        assert!(l.judge(10 * MS));
        // The next 1000 ms: only 310 ticks run, 690 skipped as overrun
        // (an emulated controller's loop): late, reported, but running.
        for k in 0..310 {
            let t = 10 + 1 + k * 1000 / 310;
            l.tick(t * MS);
        }
        assert!(l.judge(1010 * MS));
        // Then nothing for 150 ms: stalled.
        assert!(!l.judge(1160 * MS));
    }
}
