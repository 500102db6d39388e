//! A thread's record of its own timeliness: how late each wake-up came
//! after it was due, and the page faults it took while running (a thread
//! whose memory is locked and touched before it starts takes none; each
//! one is a stall of microseconds to milliseconds). Kept by the threads
//! the control loop waits on (the arm's, the sensors' readers) for the
//! run report.

use hdrhistogram::Histogram;

/// Upper bound of every latency histogram: 10 s in ns (`saturating_record`
/// clamps anything longer rather than fail).
const HISTOGRAM_MAX_NS: u64 = 10_000_000_000;

/// An empty latency histogram, 1 ns to 10 s at 3 significant digits.
pub fn histogram() -> Histogram<u64> {
    // Constant bounds that hdrhistogram accepts (low ≥ 1, high ≥ 2 × low,
    // 3 digits): it cannot fail (the unit tests build one).
    Histogram::new_with_bounds(1, HISTOGRAM_MAX_NS, 3).expect("constant bounds are valid")
}

/// A thread's wake-ups and page faults, built before its loop: recording
/// neither allocates nor blocks.
#[derive(Debug)]
pub struct WakeLog {
    wakes: Wakes,
    faults_before: u64,
}

/// What a [`WakeLog`] holds at the end.
#[derive(Debug, Clone)]
pub struct Wakes {
    /// What the wake-ups were due on (their lateness is measured from
    /// it); `None`: the thread has no due time to measure from.
    pub due: Option<&'static str>,
    /// How late each wake-up came, ns.
    pub late: Histogram<u64>,
    /// Page faults (minor and major) taken while the log ran.
    pub page_faults: u64,
}

impl WakeLog {
    /// Starts the log on the calling thread (its page faults count from
    /// here).
    pub fn start() -> WakeLog {
        WakeLog {
            wakes: Wakes {
                due: None,
                late: histogram(),
                page_faults: 0,
            },
            faults_before: own_page_faults(),
        }
    }

    /// The wake-ups are due on `due` (e.g. "its row's deadline").
    pub fn due_on(&mut self, due: &'static str) {
        self.wakes.due = Some(due);
    }

    /// A wake-up `late_ns` after it was due.
    pub fn woke(&mut self, late_ns: u64) {
        self.wakes.late.saturating_record(late_ns.max(1));
    }

    /// What the log holds, on the thread that started it.
    pub fn finish(mut self) -> Wakes {
        self.wakes.page_faults = own_page_faults().saturating_sub(self.faults_before);
        self.wakes
    }
}

/// Page faults (minor and major) the calling thread has taken so far.
pub fn own_page_faults() -> u64 {
    // SAFETY: `usage` is a valid, writable rusage for getrusage to fill.
    let usage = unsafe {
        let mut usage: libc::rusage = std::mem::zeroed();
        libc::getrusage(libc::RUSAGE_THREAD, &mut usage);
        usage
    };
    (usage.ru_minflt + usage.ru_majflt) as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn touching_new_memory_counts_as_the_threads_own_page_faults() {
        let wakes = std::thread::spawn(|| {
            let log = WakeLog::start();
            // 64 fresh pages of a new mapping (the allocator might reuse
            // pages already touched), each mapped on its first touch.
            let bytes = 64 * 4096;
            // SAFETY: a new private anonymous mapping, written only inside
            // its length and unmapped before the closure ends.
            unsafe {
                let pages = libc::mmap(
                    std::ptr::null_mut(),
                    bytes,
                    libc::PROT_READ | libc::PROT_WRITE,
                    libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
                    -1,
                    0,
                );
                assert_ne!(pages, libc::MAP_FAILED);
                for page in 0..64 {
                    std::ptr::write_volatile(pages.cast::<u8>().add(page * 4096), 1);
                }
                libc::munmap(pages, bytes);
            }
            log.finish()
        })
        .join()
        .unwrap();
        assert!(wakes.page_faults >= 64, "{}", wakes.page_faults);
        assert_eq!(wakes.late.len(), 0);
        assert_eq!(wakes.due, None);
    }

    #[test]
    fn each_wake_up_is_recorded_at_its_lateness() {
        let mut log = WakeLog::start();
        log.due_on("its deadline");
        for late_us in [10, 20, 30, 4000] {
            log.woke(late_us * 1000);
        }
        let wakes = log.finish();
        assert_eq!(wakes.due, Some("its deadline"));
        assert_eq!(wakes.late.len(), 4);
        assert_eq!(wakes.late.max(), wakes.late.highest_equivalent(4_000_000));
    }
}
