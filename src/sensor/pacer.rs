//! The timer of a sensor that reads on a schedule (a recording played in
//! real time, an IIO device read through sysfs): each period ends at an
//! absolute deadline, slept to with `clock_nanosleep(TIMER_ABSTIME)`, so
//! a late wake-up never shifts the deadlines after it.

use crate::clock::Clock;

/// Deadlines one `period_ns` apart, the first one period from the start.
#[derive(Debug)]
pub struct Pacer<C: Clock> {
    clock: C,
    next_ns: u64,
    period_ns: u64,
    catch_up: bool,
}

impl<C: Clock> Pacer<C> {
    /// Deadlines every `period_ns` from now on `clock`. `catch_up`: after
    /// a late wake-up the deadlines owed come at once (a recording's rows,
    /// each one sample); otherwise they restart from the late wake-up (a
    /// device read now is as good as several).
    pub fn new(mut clock: C, period_ns: u64, catch_up: bool) -> Pacer<C> {
        let next_ns = clock.now_ns() + period_ns;
        Pacer {
            clock,
            next_ns,
            period_ns,
            catch_up,
        }
    }

    /// Returns at the next deadline (at once if it has passed), and how
    /// late after it, ns.
    pub fn wait(&mut self) -> u64 {
        let now = self.clock.now_ns();
        let due = self.next_ns;
        if due > now {
            self.clock.sleep_until_ns(due);
        } else if !self.catch_up {
            self.next_ns = now;
        }
        self.next_ns += self.period_ns;
        self.clock.now_ns().saturating_sub(due)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::SimClock;

    const MS: u64 = 1_000_000;

    /// The times `wait` returned at, with 5 ms of lateness on the 3rd.
    fn returns(catch_up: bool) -> Vec<u64> {
        let clock = SimClock {
            lateness: [0, 0, 5 * MS].into(),
            ..SimClock::default()
        };
        let mut pacer = Pacer::new(clock, MS, catch_up);
        (0..9)
            .map(|_| {
                pacer.wait();
                pacer.clock.now / MS
            })
            .collect()
    }

    #[test]
    fn a_recording_catches_up_after_a_late_wake_up_without_drifting() {
        assert_eq!(returns(true), [1, 2, 8, 8, 8, 8, 8, 8, 9]);
    }

    #[test]
    fn each_wait_says_how_late_it_returned() {
        let clock = SimClock {
            lateness: [0, 0, 5 * MS].into(),
            ..SimClock::default()
        };
        let mut pacer = Pacer::new(clock, MS, true);
        let late: Vec<u64> = (0..7).map(|_| pacer.wait() / MS).collect();
        // The third wake-up came 5 ms late; the rows owed after it were
        // due 4, 3, 2 and 1 ms before.
        assert_eq!(late, [0, 0, 5, 4, 3, 2, 1]);
    }

    #[test]
    fn a_device_restarts_its_deadlines_from_a_late_wake_up() {
        assert_eq!(returns(false), [1, 2, 8, 8, 9, 10, 11, 12, 13]);
    }
}
