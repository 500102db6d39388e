//! Real-time set-up of the control thread, once, before its loop. Every
//! step reports granted, or denied with the reason; nothing aborts, so a
//! run without privileges works and says what it lacks.

use std::fs::File;
use std::io::Write;

use crate::arm::ThreadRef;
use crate::wakes::{PREFAULT_BYTES, prefault_stack};

/// What to ask for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RtOptions {
    /// SCHED_FIFO priority (1–99); `None`: stay SCHED_OTHER.
    pub fifo_priority: Option<i32>,
    /// CPU to pin the control thread to; `None`: no pinning.
    pub cpu: Option<usize>,
    /// `mlockall(MCL_CURRENT | MCL_FUTURE)` before the threads start,
    /// heap kept resident, and every deadline thread's stack and heap
    /// touched before its loop.
    pub lock_memory: bool,
    /// `PR_SET_TIMERSLACK` of 1 ns (SCHED_OTHER threads get 50 µs).
    pub timer_slack: bool,
    /// Hold `/dev/cpu_dma_latency` at 0 while running.
    pub cpu_dma_latency: bool,
    /// The priorities of the threads that serve the control thread.
    pub serving: ServingPriorities,
    /// Their CPUs; empty: every CPU but the control thread's.
    pub serving_cpus: Vec<usize>,
}

/// This machine's CPUs, as the scheduler numbers them (empty if unknown).
pub fn machine_cpus() -> Vec<usize> {
    core_affinity::get_core_ids()
        .unwrap_or_default()
        .into_iter()
        .map(|c| c.id)
        .collect()
}

/// SCHED_FIFO priorities of the threads the control loop waits on, each
/// below it: the sensor's reader (a sample late by `stale_ms` is a
/// fault), the arm's streamer (an arm stops about 0.1 s after its last
/// command) and the outputs a person waits on (uinput). `None`:
/// SCHED_OTHER. The telemetry, display, recorder and network outputs
/// stay SCHED_OTHER.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ServingPriorities {
    /// The sensor's reader threads.
    pub sensor: Option<i32>,
    /// The arm's streamer thread.
    pub arm: Option<i32>,
    /// The outputs with deadlines (uinput).
    pub output: Option<i32>,
}

impl ServingPriorities {
    /// All SCHED_OTHER.
    pub const NONE: ServingPriorities = ServingPriorities {
        sensor: None,
        arm: None,
        output: None,
    };

    /// Below a control thread at `control`: 10, 20 and 30 lower, at
    /// least 1; none when the control thread asks for none.
    pub fn below(control: Option<i32>) -> ServingPriorities {
        let step = |down: i32| control.map(|p| (p - down).max(1));
        ServingPriorities {
            sensor: step(10),
            arm: step(20),
            output: step(30),
        }
    }
}

impl RtOptions {
    /// Asks for nothing: for simulated runs and tests that share the machine.
    pub const NONE: RtOptions = RtOptions {
        fifo_priority: None,
        cpu: None,
        lock_memory: false,
        timer_slack: false,
        cpu_dma_latency: false,
        serving: ServingPriorities::NONE,
        serving_cpus: Vec::new(),
    };

    /// The CPUs of the threads that serve the control thread: those of
    /// `serving_cpus`, or else every CPU but the control thread's; `None`
    /// when the control thread is not pinned and none are given.
    pub fn serving_cpu_list(&self) -> Option<Vec<usize>> {
        if !self.serving_cpus.is_empty() {
            return Some(self.serving_cpus.clone());
        }
        let control = self.cpu?;
        let others: Vec<usize> = machine_cpus()
            .into_iter()
            .filter(|&id| id != control)
            .collect();
        (!others.is_empty()).then_some(others)
    }
}

impl Default for RtOptions {
    /// What cyclictest does: FIFO 80, last CPU, memory locked, 1 ns slack,
    /// CPU DMA latency 0; the serving threads at 70, 60 and 50.
    fn default() -> Self {
        RtOptions {
            fifo_priority: Some(80),
            cpu: machine_cpus().last().copied(),
            lock_memory: true,
            timer_slack: true,
            cpu_dma_latency: true,
            serving: ServingPriorities::below(Some(80)),
            serving_cpus: Vec::new(),
        }
    }
}

/// The outcome of one step.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct RtSetting {
    /// What was asked, e.g. `SCHED_FIFO priority 80`.
    pub name: String,
    /// Whether it was granted.
    pub granted: bool,
    /// Why not, or a detail.
    pub detail: String,
}

/// The settings in force for a run. Keeps `/dev/cpu_dma_latency` open
/// (closing it restores the default).
#[derive(Debug, Default)]
pub struct RtSetup {
    /// Every step, in order.
    pub settings: Vec<RtSetting>,
    /// The kernel is PREEMPT_RT (`/sys/kernel/realtime` is 1).
    pub preempt_rt: bool,
    _dma_latency: Option<File>,
}

fn errno_text() -> String {
    std::io::Error::last_os_error().to_string()
}

impl RtSetup {
    /// Whether the setting whose name starts with `prefix` was granted.
    pub fn granted(&self, prefix: &str) -> bool {
        self.settings
            .iter()
            .any(|s| s.name.starts_with(prefix) && s.granted)
    }

    fn push(&mut self, name: impl Into<String>, result: Result<String, String>) {
        self.settings.push(RtSetting::from_result(name, result));
    }
}

impl RtSetting {
    /// `name`, granted with its detail (`Ok`) or denied with the reason.
    pub fn from_result(name: impl Into<String>, result: Result<String, String>) -> RtSetting {
        let (granted, detail) = match result {
            Ok(d) => (true, d),
            Err(d) => (false, d),
        };
        RtSetting {
            name: name.into(),
            granted,
            detail,
        }
    }
}

/// Locks the process's memory, present and future
/// (`mlockall(MCL_CURRENT | MCL_FUTURE)`): every mapping is made resident
/// now, and each later one (a thread's stack, the allocator's growth) as
/// it is made, by the thread that makes it.
pub fn lock_process_memory() -> RtSetting {
    let name = "mlockall(MCL_CURRENT | MCL_FUTURE)";
    if let Some(why) = memlock_refusal() {
        return RtSetting::from_result(name, Err(why));
    }
    // SAFETY: mlockall has no memory-safety preconditions.
    let rc = unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) };
    RtSetting::from_result(
        name,
        if rc == 0 {
            Ok(String::new())
        } else {
            Err(format!(
                "{} (needs root or an unlimited memlock limit)",
                errno_text()
            ))
        },
    )
}

/// Applies `options` to the calling thread (and the process, for memory
/// locking and DMA latency). Not RT-safe: call before the loop.
pub fn setup_current_thread(options: &RtOptions) -> RtSetup {
    let mut setup = RtSetup {
        preempt_rt: std::fs::read_to_string("/sys/kernel/realtime")
            .map(|s| s.trim() == "1")
            .unwrap_or(false),
        ..RtSetup::default()
    };
    let kernel = std::fs::read_to_string("/proc/sys/kernel/version").unwrap_or_default();
    setup.push(
        "PREEMPT_RT kernel",
        if setup.preempt_rt {
            Ok("/sys/kernel/realtime = 1".into())
        } else {
            Err(format!(
                "not an RT kernel ({}); latency tails will be longer",
                kernel.trim()
            ))
        },
    );

    // The process's memory is locked once, before any thread starts
    // (`lock_process_memory`, by `rt::threads::run`).
    if options.lock_memory {
        prefault_stack();
        setup.push(
            format!("pre-faulted stack ({} KiB)", PREFAULT_BYTES / 1024),
            Ok(String::new()),
        );
    }

    if let Some(cpu) = options.cpu {
        let pinned = core_affinity::set_for_current(core_affinity::CoreId { id: cpu });
        setup.push(
            format!("pinned to CPU {cpu}"),
            if pinned {
                Ok(String::new())
            } else {
                Err("sched_setaffinity refused".into())
            },
        );
    }

    if options.timer_slack {
        // SAFETY: PR_SET_TIMERSLACK takes one integer argument.
        let rc = unsafe { libc::prctl(libc::PR_SET_TIMERSLACK, 1 as libc::c_ulong, 0, 0, 0) };
        setup.push(
            "timer slack 1 ns",
            if rc == 0 {
                Ok(String::new())
            } else {
                Err(errno_text())
            },
        );
    }

    if options.cpu_dma_latency {
        let result = File::options()
            .write(true)
            .open("/dev/cpu_dma_latency")
            .and_then(|mut f| {
                f.write_all(&0i32.to_ne_bytes())?;
                Ok(f)
            });
        match result {
            Ok(file) => {
                setup._dma_latency = Some(file);
                setup.push("/dev/cpu_dma_latency = 0", Ok("held while running".into()));
            }
            Err(e) => setup.push("/dev/cpu_dma_latency = 0", Err(e.to_string())),
        }
    }

    if let Some(priority) = options.fifo_priority {
        setup.push(
            format!("SCHED_FIFO priority {priority}"),
            // SAFETY: pthread_self() is the calling thread, alive.
            unsafe { set_fifo(ThreadRef::Pthread(libc::pthread_self()), priority) },
        );
    }
    setup
}

/// Puts `thread` in SCHED_FIFO at `priority`.
///
/// # Safety
/// `thread` must be a live thread of this process.
unsafe fn set_fifo(thread: ThreadRef, priority: i32) -> Result<String, String> {
    let param = libc::sched_param {
        sched_priority: priority,
    };
    // SAFETY: the caller keeps `thread` alive; `param` is a valid
    // sched_param.
    let rc = unsafe {
        match thread {
            ThreadRef::Pthread(thread) => {
                libc::pthread_setschedparam(thread, libc::SCHED_FIFO, &param)
            }
            ThreadRef::Task(tid) => match libc::sched_setscheduler(tid, libc::SCHED_FIFO, &param) {
                0 => 0,
                _ => std::io::Error::last_os_error().raw_os_error().unwrap_or(-1),
            },
        }
    };
    if rc == 0 {
        Ok(String::new())
    } else {
        Err(format!(
            "{} (needs root, CAP_SYS_NICE or an rtprio limit)",
            std::io::Error::from_raw_os_error(rc)
        ))
    }
}

/// Gives `thread`, a thread of this process called `name`, SCHED_FIFO
/// `priority` and the CPUs `cpus` (by default every CPU but the control
/// thread's, [`RtOptions::serving_cpu_list`]): on a loaded machine
/// ordinary work cannot starve it, and it does not take the control
/// thread's CPU. Each step reports granted or denied with the fix. Not
/// RT-safe: call before the loop.
pub fn setup_serving_thread(
    thread: ThreadRef,
    name: &str,
    priority: Option<i32>,
    cpus: Option<&[usize]>,
) -> Vec<RtSetting> {
    let mut setup = RtSetup::default();
    let Some(priority) = priority else {
        return setup.settings;
    };
    setup.push(
        format!("{name} thread: SCHED_FIFO priority {priority}"),
        // SAFETY: `thread` is a live thread of this process (its
        // JoinHandle, or its library, is held by the caller).
        unsafe { set_fifo(thread, priority) },
    );
    if let Some(cpus) = cpus.filter(|cpus| !cpus.is_empty()) {
        setup.push(
            format!("{name} thread: CPUs {cpus:?}"),
            set_affinity(thread, cpus),
        );
    }
    setup.settings
}

/// Restricts `thread` to `cpus`.
fn set_affinity(thread: ThreadRef, cpus: &[usize]) -> Result<String, String> {
    // SAFETY: cpu_set_t is plain data; all zeroes is the empty set.
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    for &cpu in cpus {
        // SAFETY: CPU_SET writes inside `set` for cpu < CPU_SETSIZE, which
        // every id core_affinity reports is.
        unsafe { libc::CPU_SET(cpu, &mut set) };
    }
    let size = std::mem::size_of::<libc::cpu_set_t>();
    // SAFETY: `thread` is live; `set` is a valid cpu_set_t of its size.
    let rc = unsafe {
        match thread {
            ThreadRef::Pthread(thread) => libc::pthread_setaffinity_np(thread, size, &set),
            ThreadRef::Task(tid) => match libc::sched_setaffinity(tid, size, &set) {
                0 => 0,
                _ => std::io::Error::last_os_error().raw_os_error().unwrap_or(-1),
            },
        }
    };
    if rc == 0 {
        Ok(String::new())
    } else {
        Err(format!(
            "{} (sched_setaffinity refused)",
            std::io::Error::from_raw_os_error(rc)
        ))
    }
}

/// Why memory must not be locked here, if so. Under a finite
/// `RLIMIT_MEMLOCK` (without root), `MCL_FUTURE` can succeed while the
/// process is small and then make later allocations fail: refuse instead.
fn memlock_refusal() -> Option<String> {
    // SAFETY: geteuid has no preconditions.
    if unsafe { libc::geteuid() } == 0 {
        return None;
    }
    let mut limit = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: `limit` is a valid, writable rlimit.
    let rc = unsafe { libc::getrlimit(libc::RLIMIT_MEMLOCK, &mut limit) };
    if rc == 0 && limit.rlim_cur == libc::RLIM_INFINITY {
        return None;
    }
    Some(format!(
        "not root and the memlock limit is {} KiB: locking all future memory could make later allocations fail (set memlock unlimited, see README)",
        limit.rlim_cur / 1024
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_step_reports_and_nothing_aborts() {
        let options = RtOptions {
            fifo_priority: Some(10),
            cpu: Some(0),
            lock_memory: false,
            timer_slack: true,
            cpu_dma_latency: false,
            serving: ServingPriorities::NONE,
            serving_cpus: Vec::new(),
        };
        let handle = std::thread::spawn(move || setup_current_thread(&options));
        let setup = handle.join().unwrap();
        let names: Vec<&str> = setup.settings.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "PREEMPT_RT kernel",
                "pinned to CPU 0",
                "timer slack 1 ns",
                "SCHED_FIFO priority 10"
            ]
        );
        for s in &setup.settings {
            assert!(s.granted || !s.detail.is_empty(), "{s:?} says why not");
        }
    }

    /// The policy, priority and CPUs the calling thread runs with.
    fn own_scheduling() -> (i32, i32, Vec<usize>) {
        let mut policy = 0;
        let mut param = libc::sched_param { sched_priority: 0 };
        // SAFETY: both out-pointers are valid; pthread_self() is live.
        unsafe { libc::pthread_getschedparam(libc::pthread_self(), &mut policy, &mut param) };
        // SAFETY: an all-zero cpu_set_t is valid.
        let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
        // SAFETY: `set` is a valid cpu_set_t of this size; 0 is the
        // calling thread.
        unsafe { libc::sched_getaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &mut set) };
        let cpus = (0..libc::CPU_SETSIZE as usize)
            // SAFETY: cpu < CPU_SETSIZE.
            .filter(|&cpu| unsafe { libc::CPU_ISSET(cpu, &set) })
            .collect();
        (policy, param.sched_priority, cpus)
    }

    #[test]
    fn a_serving_thread_runs_with_what_was_granted_and_is_told_what_was_not() {
        use std::os::unix::thread::JoinHandleExt;
        let all = machine_cpus();
        let avoid = *all.last().unwrap();
        let (go, wait) = std::sync::mpsc::channel::<()>();
        let thread = std::thread::spawn(move || {
            wait.recv().unwrap();
            own_scheduling()
        });
        let options = RtOptions {
            cpu: Some(avoid),
            ..RtOptions::NONE
        };
        let cpus = options.serving_cpu_list();
        let settings = setup_serving_thread(
            ThreadRef::Pthread(thread.as_pthread_t()),
            "sensor",
            Some(10),
            cpus.as_deref(),
        );
        go.send(()).unwrap();
        let (policy, priority, cpus) = thread.join().unwrap();

        let fifo = &settings[0];
        assert_eq!(fifo.name, "sensor thread: SCHED_FIFO priority 10");
        if fifo.granted {
            assert_eq!((policy, priority), (libc::SCHED_FIFO, 10));
        } else {
            assert_eq!(policy, libc::SCHED_OTHER);
            assert!(fifo.detail.contains("rtprio"), "{fifo:?}");
        }
        if all.len() > 1 {
            let others: Vec<usize> = all.iter().copied().filter(|&c| c != avoid).collect();
            assert_eq!(settings[1].name, format!("sensor thread: CPUs {others:?}"));
            assert!(settings[1].granted, "{:?}", settings[1]);
            assert_eq!(cpus, others);
        } else {
            assert_eq!(settings.len(), 1, "one CPU: nothing to keep it off");
        }
    }

    #[test]
    fn serving_threads_sit_below_the_control_thread() {
        let p = ServingPriorities::below(Some(80));
        assert_eq!((p.sensor, p.arm, p.output), (Some(70), Some(60), Some(50)));
        let low = ServingPriorities::below(Some(15));
        assert_eq!(
            (low.sensor, low.arm, low.output),
            (Some(5), Some(1), Some(1))
        );
        assert_eq!(ServingPriorities::below(None), ServingPriorities::NONE);
    }
}
