//! The tests' scratch folders: named after their test, removed when it
//! fails unless `SIPNPUFF_KEEP_SCRATCH=1` keeps them.

use crate::scratch::{KEEP, Scratch};

/// A test's scratch folder is named after the test, and removed when the
/// test fails (unless `SIPNPUFF_KEEP_SCRATCH=1` keeps it).
#[test]
fn a_failed_tests_scratch_folder_is_named_after_it_and_removed() {
    let failed = std::panic::catch_unwind(|| {
        let dir = Scratch::new();
        std::fs::write(dir.join("a-file"), "").unwrap();
        std::panic::panic_any(dir.to_path_buf());
    });
    let path = *failed
        .expect_err("the test fails")
        .downcast::<std::path::PathBuf>()
        .expect("the folder's path");
    let name = path.file_name().unwrap().to_string_lossy().into_owned();
    assert!(
        name.starts_with("sipnpuff-a_failed_tests_scratch_folder_is_named_after_it_and_removed-"),
        "{name}"
    );
    if std::env::var(KEEP).as_deref() == Ok("1") {
        assert!(path.join("a-file").exists(), "kept: {}", path.display());
        std::fs::remove_dir_all(&path).unwrap();
    } else {
        assert!(!path.exists(), "{}", path.display());
    }
}
