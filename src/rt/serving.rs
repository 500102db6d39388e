//! What a thread the control loop waits on reports of itself: how late
//! each wake-up came after it was due, and the page faults it took while
//! serving (a thread whose memory is locked and touched before it starts
//! takes none; each one is a stall of microseconds to milliseconds).

use hdrhistogram::Histogram;
use serde::Serialize;

use crate::rt::telemetry::{as_percentiles, histogram};

/// One serving thread's timeliness, for the run report.
#[derive(Debug, Clone, Serialize)]
pub struct ServingReport {
    /// The thread's name.
    pub thread: String,
    /// What its wake-ups were due on (the latency is measured from it).
    pub due: &'static str,
    /// How late each wake-up came, ns.
    #[serde(rename = "wake_latency_ns", serialize_with = "as_percentiles")]
    pub wake: Histogram<u64>,
    /// Page faults (minor and major) taken while serving.
    pub page_faults: u64,
}

/// A serving thread's record of its wake-ups, built before its loop:
/// recording neither allocates nor blocks.
#[derive(Debug)]
pub struct WakeLog {
    wake: Histogram<u64>,
    faults_before: u64,
}

impl WakeLog {
    /// Starts the record on the calling thread (its page faults count from
    /// here).
    pub fn start() -> WakeLog {
        WakeLog {
            wake: histogram(),
            faults_before: own_page_faults(),
        }
    }

    /// A wake-up `late_ns` after it was due.
    pub fn woke(&mut self, late_ns: u64) {
        self.wake.saturating_record(late_ns.max(1));
    }

    /// The report of the calling thread, which must be the one that
    /// started the record.
    pub fn finish(self, thread: &str, due: &'static str) -> ServingReport {
        ServingReport {
            thread: thread.into(),
            due,
            wake: self.wake,
            page_faults: own_page_faults().saturating_sub(self.faults_before),
        }
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
        let handle = std::thread::spawn(|| {
            let log = WakeLog::start();
            // 64 fresh pages, mapped on first touch.
            let mut pages = vec![0u8; 64 * 4096];
            for page in pages.chunks_mut(4096) {
                page[0] = 1;
            }
            std::hint::black_box(&pages);
            log.finish("toucher", "test")
        });
        let report = handle.join().unwrap();
        assert!(report.page_faults >= 64, "{}", report.page_faults);
        assert_eq!(report.wake.len(), 0);
    }

    #[test]
    fn each_wake_up_is_recorded_at_its_lateness() {
        let mut log = WakeLog::start();
        for late_us in [10, 20, 30, 4000] {
            log.woke(late_us * 1000);
        }
        let report = log.finish("arm", "its tick");
        assert_eq!(report.wake.len(), 4);
        assert_eq!(report.wake.max(), report.wake.highest_equivalent(4_000_000));
    }
}
