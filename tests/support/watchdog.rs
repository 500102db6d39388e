//! A bound on the processes the integration tests start (sipnpuff, the
//! peers, chromedriver; not the compiler or `ip`, which return at once). A
//! child that outlives its bound (a stop that hangs, in sipnpuff or in a
//! peer) is described (each thread's state, kernel wait channel and kernel
//! stack, and its user-space stacks when gdb is installed) and killed. The
//! test's own wait ([`wait`], [`wait_with_output`], [`output`]) then
//! returns and fails the test naming the process and where it hung,
//! instead of the whole test run waiting silently for CI's limit.
//!
//! One thread watches every registered child. It reports on the process's
//! stderr directly (not through the test harness's capture, which belongs
//! to whichever test started the thread), so CI's log always has it.

use std::collections::HashMap;
use std::io::Write;
use std::process::{Child, Command, ExitStatus, Output, Stdio};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

/// Longer than any test's child needs even on a loaded machine (the
/// longest run is 60 s of real time, the whole integration binary about
/// 4 minutes), short against CI's limit.
pub const LIMIT: Duration = Duration::from_secs(300);

/// How long a process told to end (SIGINT, SIGTERM) may take to exit:
/// sipnpuff's safe stop brakes for under a second and waits at most
/// 0.5 s for an acknowledgement; a peer deletes its participant.
pub const AFTER_SIGNAL: Duration = Duration::from_secs(60);

/// A process by pid and start time (a pid alone may be reused).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
struct Process {
    pid: u32,
    started: u64,
}

struct Watched {
    deadline: Instant,
    what: String,
}

#[derive(Default)]
struct State {
    watched: HashMap<Process, Watched>,
    /// Processes the watchdog killed, with what they were doing.
    hung: HashMap<Process, String>,
}

fn state() -> &'static Mutex<State> {
    static STATE: OnceLock<Mutex<State>> = OnceLock::new();
    STATE.get_or_init(|| {
        std::thread::Builder::new()
            .name("watchdog".into())
            .spawn(watch_loop)
            .expect("the watchdog thread starts");
        Mutex::new(State::default())
    })
}

fn lock() -> std::sync::MutexGuard<'static, State> {
    state().lock().unwrap_or_else(|e| e.into_inner())
}

/// Bounds `child` (described as `what`): it must have exited within
/// `limit` from now. Watching it again can only bring its bound closer
/// (and then describes it anew).
pub fn watch(child: &Child, what: &str, limit: Duration) {
    let Some(process) = process(child.id()) else {
        return; // already gone
    };
    let deadline = Instant::now() + limit;
    let mut state = lock();
    match state.watched.get_mut(&process) {
        Some(watched) if watched.deadline <= deadline => {}
        _ => {
            state.watched.insert(
                process,
                Watched {
                    deadline,
                    what: what.to_string(),
                },
            );
        }
    }
}

/// Spawns `command` bounded by [`LIMIT`] (described in reports as its
/// command line).
pub fn spawn(command: &mut Command) -> Child {
    let what = command_line(command);
    let child = command
        .spawn()
        .unwrap_or_else(|e| panic!("`{what}` does not start: {e}"));
    watch(&child, &format!("`{what}`"), LIMIT);
    child
}

/// Runs `command` to its end, its output captured, bounded by [`LIMIT`];
/// fails the test if it hung.
pub fn output(command: &mut Command) -> Output {
    let child = spawn(
        command
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped()),
    );
    wait_with_output(child)
}

/// A command as a person would type it: the program's name and its
/// arguments.
pub fn command_line(command: &Command) -> String {
    let program = std::path::Path::new(command.get_program());
    std::iter::once(program.file_name().unwrap_or(program.as_os_str()))
        .chain(command.get_args())
        .map(|a| a.to_string_lossy())
        .collect::<Vec<_>>()
        .join(" ")
}

/// [`Child::wait_with_output`], bounded as `child` was watched; fails the
/// test if it hung.
pub fn wait_with_output(child: Child) -> Output {
    let started = process(child.id());
    let output = child.wait_with_output().expect("waiting for a child");
    if let Some(process) = started {
        check_process(process);
    }
    output
}

/// Waits for `child`, bounded as it was watched; fails the test if it hung.
pub fn wait(child: &mut Child) -> ExitStatus {
    let started = process(child.id());
    let status = child.wait().expect("waiting for a child");
    if let Some(process) = started {
        check_process(process);
    }
    status
}

fn check_process(process: Process) {
    let hung = lock().hung.get(&process).cloned();
    if let Some(why) = hung {
        panic!("{why}");
    }
}

fn watch_loop() {
    loop {
        std::thread::sleep(Duration::from_millis(200));
        let now = Instant::now();
        let overdue: Vec<(Process, String)> = {
            let mut state = lock();
            // Forget the processes that ended.
            state.watched.retain(|p, _| alive(*p));
            state
                .watched
                .iter()
                .filter(|(_, w)| w.deadline <= now)
                .map(|(p, w)| (*p, w.what.clone()))
                .collect()
        };
        for (process, what) in overdue {
            let report = format!(
                "WATCHDOG: {what} (pid {}) did not exit within its bound; killed. What it was doing:\n{}",
                process.pid,
                describe(process.pid)
            );
            // Recorded before the kill: the test's wait returns as soon as
            // the process dies, and must find why. Checked alive (the same
            // start time: the same process) under the lock, after the
            // description: it may have ended meanwhile, and the test that
            // reaps it holds no lock, so a pid reused in the instant
            // between the check and the kill is the one race left.
            let mut state = lock();
            state.watched.remove(&process);
            if !alive(process) {
                continue;
            }
            state.hung.insert(process, report.clone());
            // SAFETY: kill(2) on a pid whose start time was just checked.
            unsafe { libc::kill(process.pid as libc::pid_t, libc::SIGKILL) };
            drop(state);
            let _ = std::io::stderr().write_all(format!("{report}\n").as_bytes());
        }
    }
}

/// `pid` with its start time, if it runs.
fn process(pid: u32) -> Option<Process> {
    let (_, started) = stat(&format!("/proc/{pid}/stat"))?;
    Some(Process { pid, started })
}

/// Whether `process` still runs (a zombie has exited: its parent has not
/// reaped it yet).
fn alive(process: Process) -> bool {
    stat(&format!("/proc/{}/stat", process.pid))
        .is_some_and(|(state, started)| state != 'Z' && started == process.started)
}

/// A process's or thread's state and start time, from its `stat` file:
/// the fields after the command name (which may hold spaces and
/// parentheses) begin with the state; the start time is the 20th after it.
fn stat(path: &str) -> Option<(char, u64)> {
    let stat = std::fs::read_to_string(path).ok()?;
    let mut fields = stat.get(stat.rfind(')')? + 2..)?.split(' ');
    let state = fields.next()?.chars().next()?;
    let started = fields.nth(18)?.parse().ok()?;
    Some((state, started))
}

/// Each thread of `pid`: name, state, kernel wait channel and stack; then
/// gdb's backtraces if gdb is installed.
fn describe(pid: u32) -> String {
    let read = |path: String| std::fs::read_to_string(path).unwrap_or_default();
    let mut text = format!(
        "  command: {}\n",
        read(format!("/proc/{pid}/cmdline")).replace('\0', " ")
    );
    let mut tasks: Vec<u32> = std::fs::read_dir(format!("/proc/{pid}/task"))
        .map(|dir| {
            dir.filter_map(|e| e.ok()?.file_name().to_str()?.parse().ok())
                .collect()
        })
        .unwrap_or_default();
    tasks.sort_unstable();
    for tid in tasks {
        let task = format!("/proc/{pid}/task/{tid}");
        let state = stat(&format!("{task}/stat")).map_or('?', |(state, _)| state);
        text += &format!(
            "  thread {tid} {:?} state {state} waiting in {}\n",
            read(format!("{task}/comm")).trim(),
            read(format!("{task}/wchan"))
        );
        for frame in read(format!("{task}/stack")).lines().take(8) {
            text += &format!("      {frame}\n");
        }
    }
    text + &gdb_backtraces(pid)
}

/// `gdb -batch -p PID -ex 'thread apply all bt'`, bounded, if gdb is here.
fn gdb_backtraces(pid: u32) -> String {
    let Ok(mut gdb) = Command::new("gdb")
        .args(["-batch", "-nx", "-p", &pid.to_string(), "-ex"])
        .arg("thread apply all bt 30")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
    else {
        return "  (no gdb here for user-space stacks)\n".into();
    };
    let read = |pipe: Option<Box<dyn std::io::Read + Send>>| {
        std::thread::spawn(move || {
            let mut text = String::new();
            if let Some(mut pipe) = pipe {
                let _ = pipe.read_to_string(&mut text);
            }
            text
        })
    };
    let reader = read(gdb.stdout.take().map(|p| Box::new(p) as _));
    let errors = read(gdb.stderr.take().map(|p| Box::new(p) as _));
    let deadline = Instant::now() + Duration::from_secs(60);
    while matches!(gdb.try_wait(), Ok(None)) && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(100));
    }
    let _ = gdb.kill();
    let _ = gdb.wait();
    let text = reader.join().unwrap_or_default();
    let errors = errors.join().unwrap_or_default();
    let frames: String = text
        .lines()
        .filter(|l| l.starts_with("Thread ") || l.starts_with('#'))
        .map(|l| format!("  {l}\n"))
        .collect();
    if frames.is_empty() {
        // It could not attach (no ptrace here?): say what it said.
        let said: Vec<&str> = errors.lines().rev().take(5).collect();
        let said: Vec<&str> = said.into_iter().rev().collect();
        return format!("  gdb gave no stacks: {}\n", said.join(" / "));
    }
    format!("  gdb:\n{frames}")
}
