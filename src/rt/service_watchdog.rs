//! The run's life told to systemd (`Type=notify`, `WatchdogSec=`):
//! `READY=1` once the control loop runs, `WATCHDOG=1` only while it keeps
//! its deadlines, `STOPPING=1` when it ends. A loop that stalls (a thread
//! stopped, starved or stuck) goes unpetted and systemd restarts the
//! service; the arm's own stream watchdog has stopped the arm by then.
//! Outside systemd (no `NOTIFY_SOCKET`) nothing is sent.
//!
//! The judgement is [`Liveness`]: pure, on the ticks' own wake-up times.

use std::time::Duration;

use sd_notify::NotifyState;

/// The share of a window's ticks the loop must have run (not skipped as
/// overrun) to be petted: a loaded machine's odd late tick passes, a loop
/// that falls behind does not.
pub const MIN_RUN_FRACTION: f64 = 0.9;

/// How long since the newest tick's wake-up the loop still counts as
/// running: the telemetry drains every 5 ms.
pub const MAX_SILENCE_NS: u64 = 100_000_000;

/// Whether the control loop kept its deadlines between pets, from each
/// tick's number, wake-up time and the ticks it skipped.
#[derive(Debug, Default, Clone)]
pub struct Liveness {
    /// The tick and skipped count at the window's start.
    start: Option<(u64, u64)>,
    /// The newest tick, its wake-up (ns) and the skipped ticks so far.
    newest: Option<(u64, u64, u64)>,
}

impl Liveness {
    /// One tick seen: its number, wake-up (`CLOCK_MONOTONIC` ns) and the
    /// ticks skipped before it.
    pub fn tick(&mut self, tick: u64, woke_ns: u64, skipped: u64) {
        let total = self.newest.map_or(0, |(_, _, s)| s) + skipped;
        self.newest = Some((tick, woke_ns, total));
        self.start.get_or_insert((tick, total));
    }

    /// Whether the loop has run at all.
    pub fn running(&self) -> bool {
        self.newest.is_some()
    }

    /// At `now_ns`: whether the loop kept its deadlines since the last
    /// judgement (its newest tick recent, at least [`MIN_RUN_FRACTION`]
    /// of the window's ticks run); starts the next window.
    pub fn judge(&mut self, now_ns: u64) -> bool {
        let Some((tick, woke_ns, skipped)) = self.newest else {
            return false;
        };
        let (first, skipped_before) = self.start.unwrap_or((tick, skipped));
        self.start = Some((tick, skipped));
        let recent = now_ns.saturating_sub(woke_ns) <= MAX_SILENCE_NS;
        let advanced = tick.saturating_sub(first);
        let missed = skipped.saturating_sub(skipped_before);
        let ran = advanced.saturating_sub(missed) as f64;
        recent && advanced > 0 && ran >= MIN_RUN_FRACTION * advanced as f64
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
            liveness.tick(t, t * MS, 0);
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
    fn a_loop_that_skips_a_tenth_of_its_ticks_or_more_is_not() {
        let mut l = Liveness::default();
        run(&mut l, 0, 10);
        assert!(l.judge(10 * MS));
        // 500 ticks later, 40 of them skipped (8 %): alive.
        l.tick(470, 470 * MS, 40);
        l.tick(510, 510 * MS, 0);
        assert!(l.judge(510 * MS));
        // The next 500: 60 skipped (12 %): behind.
        l.tick(1010, 1010 * MS, 60);
        assert!(!l.judge(1010 * MS));
        // Back on time.
        run(&mut l, 1011, 1500);
        assert!(l.judge(1500 * MS));
    }
}
