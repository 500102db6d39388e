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
    /// Starts the log on the calling thread, after touching its stack,
    /// heap ([`prefault_stack`], [`warm_heap`]) and the clock: the faults
    /// of their first use come before the thread's loop. Its page faults count
    /// from here.
    pub fn start() -> WakeLog {
        prefault_stack();
        warm_heap();
        // The clock's pages (the vDSO's data), which no lock maps.
        std::hint::black_box(std::time::Instant::now());
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

/// Bytes of stack a deadline thread touches before its loop: more than
/// any of them uses.
pub const PREFAULT_BYTES: usize = 256 * 1024;

/// Bytes of heap a deadline thread allocates and touches before its loop:
/// more than any backend's first sends take (the ROS 2 writer's: about
/// 70 pages).
const WARM_HEAP_BYTES: usize = 1024 * 1024;

/// Below the allocator's smallest threshold for a block of its own mapping.
const WARM_BLOCK: usize = 16 * 1024;

/// Touches [`PREFAULT_BYTES`] of the calling thread's stack, a page at a
/// time, so its loop never faults on it (the memory lock then keeps it).
#[inline(never)]
pub fn prefault_stack() {
    let mut buffer = [0u8; PREFAULT_BYTES];
    for i in (0..PREFAULT_BYTES).step_by(4096) {
        buffer[i] = 1;
    }
    std::hint::black_box(&buffer);
}

/// Allocates [`WARM_HEAP_BYTES`] in blocks, touches and frees them: the
/// calling thread's allocator arena is made and grown before its loop,
/// and with [`keep_heap_resident`] stays so.
fn warm_heap() {
    let blocks: Vec<Vec<u8>> = (0..WARM_HEAP_BYTES / WARM_BLOCK)
        .map(|_| vec![1u8; WARM_BLOCK])
        .collect();
    std::hint::black_box(&blocks);
}

/// Makes heap memory, once touched, stay: glibc's allocator stops giving
/// freed memory back (`M_TRIM_THRESHOLD`) and serves large blocks from
/// its heap instead of fresh mappings (`M_MMAP_MAX` 0), so under a memory
/// lock no later allocation faults on memory already used. For the whole
/// process: called once, before the threads start.
pub fn keep_heap_resident() -> Result<String, String> {
    #[cfg(target_env = "gnu")]
    {
        // SAFETY: mallopt only sets the allocator's parameters.
        let kept = unsafe {
            libc::mallopt(libc::M_TRIM_THRESHOLD, i32::MAX) == 1
                && libc::mallopt(libc::M_MMAP_MAX, 0) == 1
        };
        if kept {
            Ok(String::new())
        } else {
            Err("mallopt refused".into())
        }
    }
    #[cfg(not(target_env = "gnu"))]
    {
        Err("not glibc's allocator".into())
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
