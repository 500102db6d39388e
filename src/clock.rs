//! Time for the runtime's loop and the sensors' timers: `CLOCK_MONOTONIC`
//! in nanoseconds, and absolute sleeps with `clock_nanosleep(TIMER_ABSTIME)`
//! (no drift: a late wake-up does not delay later deadlines). Behind a
//! trait so what waits on it can be tested on simulated time.

/// A monotonic clock that can sleep until an absolute time.
pub trait Clock {
    /// Nanoseconds since an arbitrary fixed point.
    fn now_ns(&mut self) -> u64;
    /// Returns at or after `deadline_ns` (at once if it has passed).
    fn sleep_until_ns(&mut self, deadline_ns: u64);
}

/// The real clock: `CLOCK_MONOTONIC`. RT-safe (no allocation; the sleep
/// is the loop's only blocking call).
#[derive(Debug, Default, Clone, Copy)]
pub struct MonotonicClock;

impl Clock for MonotonicClock {
    fn now_ns(&mut self) -> u64 {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: `ts` is a valid, writable timespec; CLOCK_MONOTONIC
        // always exists on Linux, so the call cannot fail.
        unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
        ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
    }

    fn sleep_until_ns(&mut self, deadline_ns: u64) {
        let ts = libc::timespec {
            tv_sec: (deadline_ns / 1_000_000_000) as libc::time_t,
            tv_nsec: (deadline_ns % 1_000_000_000) as libc::c_long,
        };
        loop {
            // SAFETY: `ts` is a valid timespec; the remaining-time pointer
            // may be null with TIMER_ABSTIME.
            let rc = unsafe {
                libc::clock_nanosleep(
                    libc::CLOCK_MONOTONIC,
                    libc::TIMER_ABSTIME,
                    &ts,
                    std::ptr::null_mut(),
                )
            };
            // Interrupted by a signal (SIGINT): sleep on to the same
            // absolute deadline.
            if rc != libc::EINTR {
                return;
            }
        }
    }
}

/// Simulated time for tests: sleeping jumps to the deadline plus a
/// programmable lateness; work advances time by hand.
#[derive(Debug, Default, Clone)]
pub struct SimClock {
    /// Current time, ns.
    pub now: u64,
    /// Lateness added to the next sleeps, in order (consumed one per sleep;
    /// 0 when empty).
    pub lateness: std::collections::VecDeque<u64>,
    /// Time each `now_ns` call takes (so a spin on the clock ends).
    pub read_ns: u64,
}

impl SimClock {
    /// Lets `ns` pass (the work of a tick).
    pub fn advance(&mut self, ns: u64) {
        self.now += ns;
    }
}

impl Clock for SimClock {
    fn now_ns(&mut self) -> u64 {
        self.now += self.read_ns;
        self.now
    }

    fn sleep_until_ns(&mut self, deadline_ns: u64) {
        let late = self.lateness.pop_front().unwrap_or(0);
        self.now = self.now.max(deadline_ns) + late;
    }
}
