//! Helpers for the tests of session recordings, in both tiers: the
//! binary run with its output witnessed, `replay DIR`, a recording copied.

use std::path::Path;
use std::process::Output;

use serde_json::Value;

use crate::common::fixture;

pub fn sipnpuff(args: &[&str]) -> Output {
    let mut command = crate::common::sipnpuff();
    command.args(args);
    let output = crate::watchdog::output(&mut command);
    crate::common::witness(&text(&output.stdout));
    output
}

pub fn shared_machine() -> String {
    fixture("shared-machine.toml").to_str().unwrap().to_string()
}

pub fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

pub fn text(out: &[u8]) -> String {
    String::from_utf8_lossy(out).into_owned()
}

/// `replay DIR`: (exit code, events on stdout, stderr).
pub fn replay(dir: &Path) -> (i32, String, String) {
    let out = sipnpuff(&["replay", dir.to_str().unwrap()]);
    (
        out.status.code().unwrap_or(-1),
        text(&out.stdout),
        text(&out.stderr),
    )
}

/// `replay DIR` fails (exit 1) saying each of `parts`.
pub fn assert_replay_fails(dir: &Path, parts: &[&str]) {
    let (code, _, stderr) = replay(dir);
    assert_eq!(code, 1, "{stderr}");
    for part in parts {
        assert!(stderr.contains(part), "{part}: {stderr}");
    }
}

/// A copy of the recording in `from`, in `to`.
pub fn copy_recording(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, to.join(path.file_name().unwrap())).unwrap();
    }
}
