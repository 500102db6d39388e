//! The periodic scheduler: absolute deadlines `start + k × period`, so a
//! late tick never shifts the ones after it (no cumulative drift).
//!
//! Overrun policy: if a wake-up comes a whole period or more after its
//! deadline (the tick or the one before it overran, or the machine stalled),
//! the deadline is counted as missed and the loop skips to the latest
//! period that has begun; the skipped ticks are counted and the tick number
//! jumps, so the core, which measures time in ticks, keeps its timers true.
//! Always: ticks run + ticks skipped = periods elapsed.
//!
//! Optional hybrid wait: sleep until `spin_margin` before the deadline, then
//! spin on the clock (trades CPU for wake-up latency; never spins longer
//! than the margin, since a SCHED_FIFO thread that spins is throttled).

use crate::clock::Clock;
use crate::control::Tick;

/// One wake-up of the loop.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Wake {
    /// The tick to run now.
    pub tick: Tick,
    /// Ticks skipped before it (0 normally).
    pub skipped: u64,
    /// When the loop woke, ns.
    pub woke_ns: u64,
    /// Wake-up latency: `woke_ns` minus the deadline it waited for, ns.
    pub latency_ns: u64,
}

/// Counts kept by the scheduler.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct SchedulerStats {
    /// Ticks run.
    pub ticks_run: u64,
    /// Wake-ups that came a whole period late or more.
    pub missed_deadlines: u64,
    /// Ticks skipped over those.
    pub skipped_ticks: u64,
}

/// Absolute-deadline periodic scheduler. RT-safe.
#[derive(Debug, Clone)]
pub struct Scheduler {
    start_ns: u64,
    period_ns: u64,
    spin_margin_ns: Option<u64>,
    next: Tick,
    stats: SchedulerStats,
}

impl Scheduler {
    /// Tick 0's deadline is `start_ns`.
    pub fn new(start_ns: u64, period_ns: u64, spin_margin_ns: Option<u64>) -> Self {
        Scheduler {
            start_ns,
            period_ns: period_ns.max(1),
            spin_margin_ns,
            next: 0,
            stats: SchedulerStats::default(),
        }
    }

    /// The counts so far.
    pub fn stats(&self) -> SchedulerStats {
        self.stats
    }

    /// The deadline of tick `tick`, ns.
    pub fn deadline_ns(&self, tick: Tick) -> u64 {
        self.start_ns + tick * self.period_ns
    }

    /// Drift at a wake-up: periods begun by `woke_ns` according to the
    /// clock, minus ticks run and skipped. 0 for absolute deadlines; a loop
    /// that slept relative times would fall behind here.
    pub fn drift_ticks(&self, woke_ns: u64) -> i64 {
        let elapsed = woke_ns.saturating_sub(self.start_ns) / self.period_ns + 1;
        let accounted = self.stats.ticks_run + self.stats.skipped_ticks;
        elapsed as i64 - accounted as i64
    }

    /// Waits for the next deadline and says which tick to run.
    pub fn wait(&mut self, clock: &mut impl Clock) -> Wake {
        let deadline = self.deadline_ns(self.next);
        match self.spin_margin_ns {
            Some(margin) if margin > 0 => {
                clock.sleep_until_ns(deadline.saturating_sub(margin));
                while clock.now_ns() < deadline {
                    std::hint::spin_loop();
                }
            }
            _ => clock.sleep_until_ns(deadline),
        }
        let woke = clock.now_ns();
        let latency = woke.saturating_sub(deadline);
        let mut tick = self.next;
        let mut skipped = 0;
        if latency >= self.period_ns {
            let latest = (woke - self.start_ns) / self.period_ns;
            skipped = latest - self.next;
            tick = latest;
            self.stats.missed_deadlines += 1;
            self.stats.skipped_ticks += skipped;
        }
        self.next = tick + 1;
        self.stats.ticks_run += 1;
        Wake {
            tick,
            skipped,
            woke_ns: woke,
            latency_ns: latency,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::SimClock;

    const P: u64 = 1_000_000;

    #[test]
    fn on_time_ticks_follow_the_deadlines() {
        let mut clock = SimClock::default();
        let mut s = Scheduler::new(0, P, None);
        clock.lateness.extend([30_000, 10_000, 900_000]);
        let w: Vec<Wake> = (0..4).map(|_| s.wait(&mut clock)).collect();
        assert_eq!(w.iter().map(|w| w.tick).collect::<Vec<_>>(), [0, 1, 2, 3]);
        assert_eq!(
            w.iter().map(|w| w.latency_ns).collect::<Vec<_>>(),
            [30_000, 10_000, 900_000, 0]
        );
        // A late wake-up does not move the next deadline.
        assert_eq!(w[3].woke_ns, 3 * P);
        assert_eq!(s.stats().skipped_ticks, 0);
    }

    #[test]
    fn a_stall_skips_to_the_current_period_and_counts() {
        let mut clock = SimClock::default();
        let mut s = Scheduler::new(0, P, None);
        s.wait(&mut clock); // tick 0 at 0
        clock.lateness.push_back(3 * P + 500_000); // tick 1's wake: 4.5 ms
        let w = s.wait(&mut clock);
        assert_eq!((w.tick, w.skipped, w.latency_ns), (4, 3, 3 * P + 500_000));
        let w = s.wait(&mut clock);
        assert_eq!((w.tick, w.skipped, w.woke_ns), (5, 0, 5 * P));
        let st = s.stats();
        assert_eq!(
            (st.ticks_run, st.missed_deadlines, st.skipped_ticks),
            (3, 1, 3)
        );
        assert_eq!(st.ticks_run + st.skipped_ticks, 6, "ticks 0..=5");
        assert_eq!(s.drift_ticks(w.woke_ns), 0);
    }

    #[test]
    fn an_overrunning_tick_is_a_missed_deadline() {
        let mut clock = SimClock::default();
        let mut s = Scheduler::new(0, P, None);
        s.wait(&mut clock);
        clock.advance(2 * P + 100); // tick 0's work takes 2 periods
        let w = s.wait(&mut clock); // tick 1's deadline long gone
        assert_eq!((w.tick, w.skipped), (2, 1));
        // Work just under a period: late, but no skip.
        clock.advance(P - 200);
        let w = s.wait(&mut clock);
        assert_eq!((w.tick, w.skipped), (3, 0));
    }

    #[test]
    fn accounting_holds_over_random_lateness() {
        let mut clock = SimClock::default();
        let mut s = Scheduler::new(7, P, None);
        let mut x = 12345u64;
        for _ in 0..100_000 {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            // Mostly tens of µs late; one in 16 stalls up to 5 periods.
            let late = if x >> 60 == 0 {
                (x >> 20) % (5 * P)
            } else {
                (x >> 40) % 50_000
            };
            clock.lateness.push_back(late);
            let w = s.wait(&mut clock);
            assert_eq!(w.tick, (w.woke_ns - 7) / P, "runs the period it woke in");
            assert_eq!(s.drift_ticks(w.woke_ns), 0);
            clock.advance((x >> 30) % 200_000); // the tick's work
        }
        let st = s.stats();
        assert!(st.missed_deadlines > 1000 && st.skipped_ticks >= st.missed_deadlines);
    }

    #[test]
    fn hybrid_wait_spins_only_the_margin() {
        let mut clock = SimClock {
            read_ns: 1000,
            ..SimClock::default()
        };
        let mut s = Scheduler::new(0, P, Some(50_000));
        s.wait(&mut clock);
        // The sleep targets deadline − margin; the spin reaches the deadline.
        let w = s.wait(&mut clock);
        assert_eq!(w.tick, 1);
        assert!(w.woke_ns >= P && w.latency_ns <= 2000, "{w:?}");
    }
}
