//! A file a tool writes (a generated signal, its truth, a replay's events
//! or trace): created before any work, so a bad path fails first, and
//! buffered, 1 MiB at a time (a trace of an hour is 635 MB).

use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

use anyhow::Context;

/// Creates `path` for writing, buffered.
pub fn create(path: &Path) -> anyhow::Result<BufWriter<File>> {
    let file = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    Ok(BufWriter::with_capacity(1 << 20, file))
}

/// Writes `path` whole or not at all: `write` fills `PATH.partial`
/// beside it, which is flushed, synced and renamed over `path` only if
/// every write succeeded (and removed if not), so a reader never meets
/// a half-written file.
pub fn write_whole(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let mut partial = path.as_os_str().to_owned();
    partial.push(".partial");
    let partial = std::path::PathBuf::from(partial);
    let result = create(&partial).and_then(|mut writer| {
        write(&mut writer)?;
        let file = writer
            .into_inner()
            .map_err(|e| e.into_error())
            .with_context(|| format!("cannot write {}", partial.display()))?;
        file.sync_all()
            .with_context(|| format!("cannot write {}", partial.display()))?;
        std::fs::rename(&partial, path)
            .with_context(|| format!("cannot rename {} to {}", partial.display(), path.display()))
    });
    if result.is_err() {
        // Best effort: the error says what went wrong.
        let _ = std::fs::remove_file(&partial);
    }
    result
}

#[cfg(test)]
mod tests {
    use std::io::Write;

    use super::*;

    #[test]
    fn a_failed_write_leaves_nothing_and_a_good_one_the_whole_file() {
        let dir = std::env::temp_dir().join(format!("sipnpuff-whole-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("imu.csv");
        let failed = write_whole(&path, |w| {
            w.write_all(b"tick,ax\n0,1\n")?;
            anyhow::bail!("stopped half way")
        });
        assert_eq!(failed.unwrap_err().to_string(), "stopped half way");
        assert!(std::fs::read_dir(&dir).unwrap().next().is_none());
        write_whole(&path, |w| Ok(w.write_all(b"tick,ax\n0,1\n")?)).unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "tick,ax\n0,1\n");
        let names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["imu.csv"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
