//! Checks shared by the integration tests.

use sipnpuff::config::Config;
use sipnpuff::control::Tick;
use sipnpuff::control::action::Breath;
use sipnpuff::control::event::Event;
use sipnpuff::control::mode::Mode;
use sipnpuff::control::motion::MotionEvent;
use sipnpuff::control::pipeline::Pipeline;
use sipnpuff::control::sample::Sample;
use sipnpuff::control::tick::{ArmInput, ArmPose, TickInput, TickOutput};
use sipnpuff::sim::sensor_model::Step;

/// The core driven one tick at a time, each tick's output returned: how
/// the tests call `Pipeline::step`.
pub trait TickByTick {
    /// Tick `t` with a sample of `volts`.
    fn tick(&mut self, t: Tick, volts: f64) -> TickOutput;
    /// Tick `t` with `sample` (a sample, none, or the device gone).
    fn tick_with(&mut self, t: Tick, sample: Sample) -> TickOutput;
    /// Tick `t` with a sample of `volts` and what the arm said since the
    /// last tick.
    fn tick_after(&mut self, t: Tick, volts: f64, arm: ArmInput) -> TickOutput;
    /// Tick `input.tick` with its whole input.
    fn tick_input(&mut self, input: &TickInput) -> TickOutput;
}

impl TickByTick for Pipeline {
    fn tick(&mut self, t: Tick, volts: f64) -> TickOutput {
        self.tick_with(t, Sample::Volts(volts))
    }

    fn tick_with(&mut self, t: Tick, sample: Sample) -> TickOutput {
        self.tick_input(&TickInput::new(t, sample))
    }

    fn tick_after(&mut self, t: Tick, volts: f64, arm: ArmInput) -> TickOutput {
        self.tick_input(&TickInput {
            arm,
            ..TickInput::volts(t, volts)
        })
    }

    fn tick_input(&mut self, input: &TickInput) -> TickOutput {
        let mut out = TickOutput::default();
        self.step(input, &mut out);
        out
    }
}

/// The arm's news: it starts at `pose` (a measuring arm, first tick).
pub fn arm_starts_at(pose: nalgebra::Isometry3<f64>) -> ArmInput {
    ArmInput {
        pose: Some((ArmPose::Start, pose)),
        link_lost: false,
    }
}

/// The arm's news: it measured `pose`.
pub fn arm_measured(pose: nalgebra::Isometry3<f64>) -> ArmInput {
    ArmInput {
        pose: Some((ArmPose::Measured, pose)),
        link_lost: false,
    }
}

/// Runs `samples` through a fresh core and checks it against the script
/// that made them: every scripted breath detected exactly once, in order,
/// as the right sip or puff, within `tolerance_ms` of its scripted length
/// and in the right length class (unless it lies within the tolerance of
/// the boundary); every selected mode matched, in order; no reset, no
/// fault, no burst invented. Returns the number of samples.
pub fn assert_session(
    config: &Config,
    samples: impl Iterator<Item = f64>,
    script: &[Step],
    modes: &[Mode],
    tolerance_ms: u64,
) -> u64 {
    let mut core: Pipeline = Pipeline::new(config.core());
    let mut bursts = Vec::new();
    let mut matched = Vec::new();
    let mut n = 0;
    for (t, v) in samples.enumerate() {
        for event in core.tick(t as u64, v).events.iter() {
            match event {
                Event::Burst(b) => bursts.push(*b),
                Event::Match { target, .. } => matched.extend(target.mode()),
                Event::Reset { .. }
                | Event::Fault { .. }
                | Event::Recovered
                | Event::Rezeroed { .. }
                | Event::ArmFault { .. }
                | Event::Gesture { .. }
                | Event::GestureRejected { .. }
                | Event::Motion(MotionEvent::TrajectoryError) => {
                    panic!("unexpected {event:?} at tick {t}")
                }
                Event::Detection { .. } | Event::Highlight { .. } | Event::Motion(_) => {}
            }
        }
        n += 1;
    }
    let scripted: Vec<(Breath, u64)> = script
        .iter()
        .filter_map(|s| match *s {
            Step::Breath { breath, ms } => Some((breath, u64::from(ms))),
            _ => None,
        })
        .collect();
    let long = u64::from(config.core().detector().long_burst_ms);
    assert_eq!(bursts.len(), scripted.len(), "bursts detected vs scripted");
    for (b, &(breath, ms)) in bursts.iter().zip(&scripted) {
        assert_eq!(b.action.breath(), breath, "{b:?}");
        assert!(
            b.duration_ms().abs_diff(ms) <= tolerance_ms,
            "{b:?} scripted {ms} ms"
        );
        if ms.abs_diff(long) > tolerance_ms {
            assert_eq!(b.action.is_long(), ms >= long, "{b:?} scripted {ms} ms");
        }
    }
    assert_eq!(matched, modes);
    n
}

/// A sip of `ms` for a script.
pub const fn sip(ms: u32) -> Step {
    Step::Breath {
        breath: Breath::Sip,
        ms,
    }
}

/// A puff of `ms` for a script.
pub const fn puff(ms: u32) -> Step {
    Step::Breath {
        breath: Breath::Puff,
        ms,
    }
}

/// `ms` at rest for a script.
pub const fn rest(ms: u32) -> Step {
    Step::Rest { ms }
}

/// The text report's line after a safe stop: the arm commanded to rest.
pub const STOPPED_AT_REST: &str = "final commanded velocity: linear (0, 0, 0) m/s, angular (0, 0, 0) rad/s, fingers 0 units/s; last arm command zero: true";

/// The text report's line after a safe stop: the arm got the zero command.
pub const ENDED_WITH_ZERO: &str = "stream ended with a zero command and the arm stopped: true";

/// The text report's line of a control loop that allocated nothing.
pub const NO_ALLOCATIONS: &str = "control thread heap allocations after start: 0";

/// A port free now on 127.0.0.1 (for a peer or a server the test starts).
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

/// A file in `fixtures/`.
pub fn fixture(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
}

/// The paper's example library (with prefixes) and its settings.
pub fn paper_config() -> Config {
    Config::from_file(&fixture("paper-example.toml")).expect("the paper's example config")
}

/// The real binary, without the display (tests run in parallel: they
/// would all want its port); a test of the display removes the variable.
pub fn sipnpuff() -> std::process::Command {
    let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_sipnpuff"));
    command.env("SIPNPUFF_NO_DISPLAY", "1");
    command
}

/// `sipnpuff ARGS…` run to its end under the watchdog.
pub fn sipnpuff_output(args: &[&str]) -> std::process::Output {
    let mut command = sipnpuff();
    command.args(args);
    crate::watchdog::output(&mut command)
}

/// A process a test runs (sipnpuff or a peer): its stdout lines arrive on
/// a channel, its stderr is collected (neither pipe can fill and stall
/// it); killed if still running when dropped.
pub struct Running {
    /// The process.
    pub child: std::process::Child,
    /// Its stdout, line by line.
    pub lines: std::sync::mpsc::Receiver<String>,
    /// The lines read so far.
    pub seen: Vec<String>,
    /// Its whole stderr, once it closes.
    stderr: Option<std::thread::JoinHandle<String>>,
    /// Its command line, for the watchdog's reports.
    what: String,
}

impl Running {
    /// Starts `sipnpuff` with `args`.
    pub fn spawn(args: &[&str]) -> Running {
        let mut command = sipnpuff();
        command.args(args);
        Running::start(command)
    }

    /// Starts `command` (a `sipnpuff` or a peer set up by the test), stdout
    /// and stderr piped, bounded by the watchdog.
    pub fn start(mut command: std::process::Command) -> Running {
        let what = crate::watchdog::command_line(&command);
        let mut child = crate::watchdog::spawn(
            command
                .stdout(std::process::Stdio::piped())
                .stderr(std::process::Stdio::piped()),
        );
        let stdout = child.stdout.take().unwrap();
        let (tx, lines) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            use std::io::BufRead;
            for line in std::io::BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                witness(&line);
                if tx.send(line).is_err() {
                    break; // the test closed its end: stdout's reader is gone
                }
            }
        });
        let mut stderr = child.stderr.take().unwrap();
        let stderr = std::thread::spawn(move || {
            let mut text = String::new();
            let _ = std::io::Read::read_to_string(&mut stderr, &mut text);
            text
        });
        Running {
            child,
            lines,
            seen: Vec::new(),
            stderr: Some(stderr),
            what,
        }
    }

    /// Reads stdout until a line contains `text`.
    pub fn wait_for(&mut self, text: &str) {
        loop {
            let line = self.lines.recv().unwrap_or_else(|_| {
                panic!(
                    "`{}`: stdout ended before {text:?}:\n{}",
                    self.what,
                    self.text()
                )
            });
            let found = line.contains(text);
            self.seen.push(line);
            if found {
                return;
            }
        }
    }

    /// Waits until the arm is moving forward: `translate_x` selected, then
    /// 0.9 s into the scripted user's 1.5 s puff (it starts about 0.66 s
    /// after the match). `velocity_at_stop` in the report proves it.
    pub fn wait_until_moving(&mut self) {
        self.wait_for("\"mode\":\"translate_x\"");
        std::thread::sleep(std::time::Duration::from_millis(900));
    }

    /// Sends `signal`; after one that ends the process, it has
    /// [`crate::watchdog::AFTER_SIGNAL`] to exit.
    pub fn signal(&self, signal: libc::c_int) {
        if [
            libc::SIGINT,
            libc::SIGTERM,
            libc::SIGHUP,
            libc::SIGQUIT,
            libc::SIGKILL,
        ]
        .contains(&signal)
        {
            crate::watchdog::watch(
                &self.child,
                &format!("`{}` after signal {signal}", self.what),
                crate::watchdog::AFTER_SIGNAL,
            );
        }
        // SAFETY: kill with a valid pid and signal number has no memory effects.
        let rc = unsafe { libc::kill(self.child.id() as libc::pid_t, signal) };
        assert_eq!(rc, 0);
    }

    /// Stops the process for `pause` (SIGSTOP, as a debugger or a paused
    /// VM would), then lets it continue.
    pub fn pause(&self, pause: std::time::Duration) {
        self.signal(libc::SIGSTOP);
        std::thread::sleep(pause);
        self.signal(libc::SIGCONT);
    }

    /// Waits for the exit; returns (status, stdout lines, stderr).
    pub fn finish(mut self) -> (std::process::ExitStatus, Vec<String>, String) {
        let (status, stderr) = self.exit();
        let mut seen = std::mem::take(&mut self.seen);
        seen.extend(self.lines.iter());
        (status, seen, stderr)
    }

    /// Closes the test's end of stdout (as `head` exits), then waits for
    /// the exit; returns (status, stdout lines read, stderr).
    pub fn close_stdout(mut self) -> (std::process::ExitStatus, Vec<String>, String) {
        // Our receiver gone, the reader thread's next send fails and it
        // drops the pipe's read end.
        self.lines = std::sync::mpsc::channel().1;
        let (status, stderr) = self.exit();
        (status, std::mem::take(&mut self.seen), stderr)
    }

    /// Its exit status and whole stderr, once it has exited.
    fn exit(&mut self) -> (std::process::ExitStatus, String) {
        let stderr = self.stderr.take().map_or_else(String::new, |reader| {
            reader.join().expect("stderr's reader")
        });
        (crate::watchdog::wait(&mut self.child), stderr)
    }

    /// The stdout lines read so far.
    pub fn text(&self) -> String {
        self.seen.join("\n")
    }
}

/// A test that fails mid-run leaves no process behind (its retry, or the
/// next test, would meet it).
impl Drop for Running {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// Checks `done` every `every` until it holds or `limit` has passed;
/// whether it held. For waiting on a peer, never for timing a test.
pub fn poll_until(
    limit: std::time::Duration,
    every: std::time::Duration,
    mut done: impl FnMut() -> bool,
) -> bool {
    let deadline = std::time::Instant::now() + limit;
    loop {
        if done() {
            return true;
        }
        if std::time::Instant::now() >= deadline {
            return false;
        }
        std::thread::sleep(every);
    }
}

/// Real-time runs that are measured (a peer timing the arm stream, a
/// scripted user whose breaths must come out right) never overlap the
/// tests that load both CPUs for long (the stress tests): under that load
/// this VM's real-time loop wakes late and skips ticks — measured: 1065 of
/// 10 037 ticks skipped, where two `yes` hogs cost 8 — and the scripted
/// user's breaths come out wrong. Real-time runs share the CPUs with each
/// other (a read lock); a heavy test has them to itself (the write lock).
static CPU: std::sync::RwLock<()> = std::sync::RwLock::new(());

/// Runs a measured real-time test (holding the shared lock), and runs it
/// again — at most twice more — only when an attempt failed while the
/// machine was demonstrably starved: the hypervisor took CPU from this VM
/// (steal time) or a run reported its loop stalled. A real-time test cannot
/// show anything about the code on a machine that did not run it (once a
/// loop stalled five times, 58 to 147 ms, in its first 4 s), while a failure
/// on a machine that ran it is never retried. Each retry says why.
pub fn real_time(test: impl Fn()) {
    const ATTEMPTS: u32 = 3;
    for attempt in 1..=ATTEMPTS {
        let outcome = {
            let _cpu = CPU.read().unwrap_or_else(|e| e.into_inner());
            let before = Starvation::now();
            let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(&test));
            outcome.map_err(|panic| (panic, before.since()))
        };
        match outcome {
            Ok(()) => return,
            Err((_, Some(why))) if attempt < ATTEMPTS => {
                eprintln!(
                    "RETRY: attempt {attempt} failed on a starved machine ({why}); running the test again"
                );
            }
            Err((panic, why)) => {
                if let Some(why) = why {
                    eprintln!(
                        "all {ATTEMPTS} attempts failed on a starved machine; the last: {why}"
                    );
                }
                std::panic::resume_unwind(panic);
            }
        }
    }
}

/// Loop stalls the runs of this test process reported (see [`witness`]).
static STALLS_SEEN: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// Counts a run's output line that reports its loop stalled: the run's own
/// evidence that the machine did not give it the CPU.
pub fn witness(line: &str) {
    if line.contains("the control loop stalled") {
        STALLS_SEEN.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    }
}

/// Evidence of a starved machine over a stretch of time.
struct Starvation {
    at: std::time::Instant,
    steal: Option<u64>,
    stalls: u64,
}

impl Starvation {
    /// More steal than this, in jiffies a second, is a starved machine:
    /// a calm one here shows 0.1 to 0.3, a contended one 7 and more.
    const STEAL_PER_S: f64 = 2.0;

    fn now() -> Starvation {
        Starvation {
            at: std::time::Instant::now(),
            steal: steal_jiffies(),
            stalls: STALLS_SEEN.load(std::sync::atomic::Ordering::Relaxed),
        }
    }

    /// Why the machine counts as starved since `self`, if it does.
    fn since(&self) -> Option<String> {
        let seconds = self.at.elapsed().as_secs_f64().max(1.0);
        let steal = match (self.steal, steal_jiffies()) {
            (Some(a), Some(b)) => b.saturating_sub(a),
            _ => 0,
        };
        let stalls = STALLS_SEEN.load(std::sync::atomic::Ordering::Relaxed) - self.stalls;
        let per_s = steal as f64 / seconds;
        (per_s > Self::STEAL_PER_S || stalls > 0).then(|| {
            format!(
                "steal {steal} jiffies in {seconds:.1} s ({per_s:.1}/s, over {} is starved); {stalls} loop stalls reported",
                Self::STEAL_PER_S
            )
        })
    }
}

/// The machine's total steal time (`/proc/stat`, jiffies), if it has one.
fn steal_jiffies() -> Option<u64> {
    let stat = std::fs::read_to_string("/proc/stat").ok()?;
    let cpu = stat.lines().find(|l| l.starts_with("cpu "))?;
    cpu.split_whitespace().nth(8)?.parse().ok()
}

/// Held by a test that loads both CPUs for long: real-time tests wait.
pub fn cpu_heavy() -> std::sync::RwLockWriteGuard<'static, ()> {
    CPU.write().unwrap_or_else(|e| e.into_inner())
}

/// Whether the peer the running test needs is here (`missing` says what
/// is not): without it the test prints why and passes, unless
/// `SIPNPUFF_REQUIRE_PEERS=1` (CI), where a missing peer fails it.
pub fn have_peer(missing: Option<String>) -> bool {
    let Some(why) = missing else {
        return true;
    };
    let notice = format!("SKIPPED {}: {why}", crate::scratch::test_name());
    assert!(
        std::env::var("SIPNPUFF_REQUIRE_PEERS").as_deref() != Ok("1"),
        "{notice} (SIPNPUFF_REQUIRE_PEERS=1)"
    );
    eprintln!("{notice}");
    false
}

/// CLOCK_MONOTONIC, ns (the clock of the peers' receive times).
pub fn monotonic_ns() -> i64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: a valid clock id and a pointer to a timespec we own.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec * 1_000_000_000 + ts.tv_nsec
}

/// Whether a run's JSON report granted its real-time setting `name`
/// (a missing setting fails the test, naming what there was).
pub fn setting_granted(report: &serde_json::Value, name: &str) -> bool {
    let settings = report["settings"].as_array().unwrap();
    let setting = settings.iter().find(|s| s["name"] == name);
    setting.unwrap_or_else(|| panic!("no {name:?} in {settings:?}"))["granted"] == true
}

/// The rate at the receiver is 100 Hz ± 2 % of what the control loop ran:
/// a command every 10 of its ticks, so a loop that had to skip ticks (a
/// machine loaded by other tests) sends fewer — its report says how many.
/// On a loop that skipped none this is exactly 100 Hz ± 2 %.
pub fn assert_rate(rate: f64, report: &serde_json::Value) {
    let run = report["stats"]["ticks_run"].as_f64().unwrap();
    let skipped = report["stats"]["skipped_ticks"].as_f64().unwrap();
    let expected = 100.0 * run / (run + skipped);
    eprintln!(
        "rate at the receiver {rate:.2} Hz; the control loop skipped {skipped} of {} ticks: {expected:.2} Hz expected",
        run + skipped
    );
    assert!(
        (rate / expected - 1.0).abs() <= 0.02,
        "rate {rate:.2} Hz, {expected:.2} Hz expected"
    );
}

/// The command ended with exit status `code` without panicking (`what`
/// it was, for the message).
pub fn assert_exit(status: std::process::ExitStatus, stderr: &str, code: i32, what: &str) {
    assert_eq!(status.code(), Some(code), "{what}: {status}\n{stderr}");
    assert!(!stderr.contains("panicked"), "{what}: {stderr}");
}

/// Runs a command that must be refused before it starts anything: it
/// fails without panicking and prints nothing on stdout. Its standard
/// error.
pub fn refused(args: &[&str]) -> String {
    let out = sipnpuff_output(args);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{args:?} succeeded:\n{stderr}");
    assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    assert!(
        out.stdout.is_empty(),
        "{args:?} started before refusing:\n{}",
        String::from_utf8_lossy(&out.stdout)
    );
    stderr
}
