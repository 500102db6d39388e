//! Each test's own scratch folder and its own name, both found without the
//! test writing either.

use std::path::{Path, PathBuf};

/// The environment variable that keeps a failed test's scratch folder.
pub const KEEP: &str = "SIPNPUFF_KEEP_SCRATCH";

/// The running test's name (its function's). libtest runs each test on a
/// thread named after the test's path (`arm_ros2::a_pose_from_…`), under
/// `cargo test` and `cargo nextest` alike; a thread a test starts for its
/// body is named after it too (see [`on_a_thread_of_this_test`]).
pub fn test_name() -> String {
    let thread = std::thread::current();
    let path = thread
        .name()
        .filter(|name| *name != "main")
        .expect("called on the thread the test harness runs the test on");
    path.rsplit("::").next().unwrap_or(path).to_string()
}

/// Runs `body` on a new thread named as this one (so [`test_name`] holds
/// there), `prepare`d first; returns what `body` returns, or fails as it
/// failed.
pub fn on_a_thread_of_this_test<T: Send>(
    prepare: impl FnOnce() + Send,
    body: impl FnOnce() -> T + Send,
) -> T {
    let name = std::thread::current().name().map(String::from);
    std::thread::scope(|scope| {
        let mut thread = std::thread::Builder::new();
        if let Some(name) = name {
            thread = thread.name(name);
        }
        thread
            .spawn_scoped(scope, || {
                prepare();
                body()
            })
            .expect("a thread for the test")
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
    })
}

/// A test's scratch folder under the system's temporary folder, named
/// after the test. Dropped, it is removed, whether the test passed or
/// failed; a failing test says where it was, and with
/// `SIPNPUFF_KEEP_SCRATCH=1` keeps it to be looked at.
pub struct Scratch(Option<tempfile::TempDir>);

impl Scratch {
    /// A new empty folder.
    pub fn new() -> Scratch {
        let dir = tempfile::Builder::new()
            .prefix(&format!("sipnpuff-{}-", test_name()))
            .tempdir()
            .expect("a scratch folder");
        Scratch(Some(dir))
    }
}

impl Scratch {
    /// The folder, kept for the rest of the test process (for what several
    /// tests share) and removed when the process exits.
    pub fn until_exit(mut self) -> PathBuf {
        let path = self.0.take().expect("a scratch folder").keep();
        let mut folders = UNTIL_EXIT.lock().unwrap_or_else(|e| e.into_inner());
        if folders.is_empty() {
            // SAFETY: registers a function that takes no arguments and
            // neither panics nor unwinds.
            unsafe { libc::atexit(remove_at_exit) };
        }
        folders.push(path.clone());
        path
    }
}

/// The folders [`Scratch::until_exit`] keeps.
static UNTIL_EXIT: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

extern "C" fn remove_at_exit() {
    let folders = UNTIL_EXIT.lock().unwrap_or_else(|e| e.into_inner());
    for folder in folders.iter() {
        let _ = std::fs::remove_dir_all(folder);
    }
}

impl std::ops::Deref for Scratch {
    type Target = Path;

    fn deref(&self) -> &Path {
        self.0.as_ref().map_or(Path::new(""), |dir| dir.path())
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let Some(dir) = self.0.take() else { return };
        if !std::thread::panicking() {
            return; // removed as `dir` drops
        }
        if std::env::var(KEEP).as_deref() == Ok("1") {
            eprintln!(
                "the failed test's scratch folder is kept: {}",
                dir.keep().display()
            );
        } else {
            eprintln!(
                "the failed test's scratch folder {} is removed ({KEEP}=1 keeps it)",
                dir.path().display()
            );
        }
    }
}

/// A file named `name` holding `contents`, in a new scratch folder.
pub fn scratch_file(name: &str, contents: &str) -> (Scratch, PathBuf) {
    let dir = Scratch::new();
    let path = dir.join(name);
    std::fs::write(&path, contents).unwrap();
    (dir, path)
}
