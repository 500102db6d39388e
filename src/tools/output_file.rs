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
