//! `gestures record --from` and `gestures check` end to end: the IMU
//! recordings read, the set made or read, checked, and written only when
//! everything before it succeeded (written whole or not at all:
//! [`write_whole`]).

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};

use crate::config::Config;
use crate::control::Tick;
use crate::control::core_config::CoreConfig;
use crate::control::gesture::GestureConfig;
use crate::control::head::GestureSetup;
use crate::control::imu::ImuSample;
use crate::gestures::check::{self, Check, Ordinary};
use crate::gestures::protocol::Span;
use crate::gestures::record::{self, Recorded};
use crate::gestures::report;
use crate::gestures::set::GestureSet;
use crate::gestures::setup;
use crate::tools::imu_csv::{ImuRecording, read_imu_csv};
use crate::tools::output_file::write_whole;

/// A set recorded from a file, and its check.
#[derive(Debug)]
pub struct RecordedSet {
    /// The set, what it was made from and how.
    pub recorded: Recorded,
    /// Its check on the recording's own ordinary movement.
    pub check: Check,
}

/// Reads an IMU recording: its error is one line naming file and line.
fn read(path: &Path) -> anyhow::Result<ImuRecording> {
    read_imu_csv(path).map_err(|e| anyhow::anyhow!("{e}"))
}

/// The samples of `samples` from `span.start` to `span.end`.
fn within(samples: &[(Tick, ImuSample)], span: Span) -> &[(Tick, ImuSample)] {
    let from = samples.partition_point(|(t, _)| *t < span.start);
    let to = samples.partition_point(|(t, _)| *t <= span.end);
    samples.get(from..to).unwrap_or_default()
}

/// Makes the set for `names` from the protocol recording `from` and
/// writes it to `out`; the set's header says how each threshold was
/// chosen and what the check found.
pub fn record_from(from: &Path, names: &[String], out: &Path) -> anyhow::Result<RecordedSet> {
    record::check_names(names).map_err(|e| anyhow::anyhow!(e))?;
    let recording = read(from)?;
    let recorded = record::record(
        &recording.samples,
        recording.channels,
        names,
        GestureConfig::default(),
        Some(from.display().to_string()),
    )
    .map_err(|e| anyhow::anyhow!("{}: {e}", from.display()))?;
    let ordinary = Ordinary {
        source: format!("{} (ordinary stretch)", from.display()),
        samples: within(&recording.samples, recorded.cut.ordinary),
    };
    let check = check::check(&recorded.set, &[ordinary]);
    let made_from = format!("{} ({})", from.display(), recording.channels);
    write_set(out, names, &recorded, &check, &made_from)?;
    Ok(RecordedSet { recorded, check })
}

/// Writes `recorded`'s set for `names` to `out` (whole or not at all),
/// its header saying what it was made from (`made_from`), what `check`
/// found and how each threshold was chosen.
pub fn write_set(
    out: &Path,
    names: &[String],
    recorded: &Recorded,
    check: &Check,
    made_from: &str,
) -> anyhow::Result<()> {
    let mut header = vec![
        format!(
            "sipnpuff gesture set: {} gestures × 5 examples from {made_from}",
            names.len()
        ),
        format!(
            "leave-one-out {}/{} right; ordinary movement {:.0} s: {} activations",
            check.right,
            check.examples,
            check.ordinary_hours * 3600.0,
            check.activations.len()
        ),
    ];
    header.extend(report::choices(names, &recorded.choices));
    let text = recorded.set.to_toml(&header);
    write_whole(out, |w| Ok(w.write_all(text.as_bytes())?))
}

/// Reads the set at `path`: every problem at once, each with its line.
pub fn read_set(path: &Path) -> anyhow::Result<GestureSet> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    GestureSet::from_toml(&text).map_err(|problems| {
        anyhow::anyhow!(
            "{}: {}",
            path.display(),
            problems.join(&format!("\n{}: ", path.display()))
        )
    })
}

/// Checks the set at `set_path` on the ordinary movement of `recordings`,
/// or, with none, on the ordinary stretch of the recording it was made
/// from (when that file is still there).
pub fn check_set(set_path: &Path, recordings: &[PathBuf]) -> anyhow::Result<Check> {
    let set = read_set(set_path)?;
    let mut read_ones = Vec::with_capacity(recordings.len());
    for path in recordings {
        let recording = read(path)?;
        if !recording.channels.covers(set.channels) {
            bail!(
                "{}: has {} but the set {} was recorded with {}: a set from another sensor's channels",
                path.display(),
                recording.channels,
                set_path.display(),
                set.channels
            );
        }
        read_ones.push((path.display().to_string(), recording));
    }
    if read_ones.is_empty()
        && let Some(source) = set.recording.as_deref()
    {
        let path = Path::new(source);
        if path.exists() {
            let recording = read(path)?;
            // The ordinary stretch: everything after the last example (as
            // the protocol's cut and a guided session's labels place it).
            let last_example = set
                .gestures
                .iter()
                .flat_map(|g| g.examples.iter().map(|e| e.end))
                .max()
                .unwrap_or(0);
            let last = recording.samples.last().map_or(last_example, |(t, _)| *t);
            let span = Span {
                start: last_example,
                end: last,
            };
            let ordinary = within(&recording.samples, span).to_vec();
            let samples = ImuRecording {
                channels: recording.channels,
                samples: ordinary,
            };
            read_ones.push((format!("{source} (ordinary stretch)"), samples));
        }
    }
    let ordinary: Vec<Ordinary<'_>> = read_ones
        .iter()
        .map(|(source, recording)| Ordinary {
            source: source.clone(),
            samples: &recording.samples,
        })
        .collect();
    Ok(check::check(&set, &ordinary))
}

/// The core for a replay fed by the IMU alone: `config`'s, with the
/// gesture set its `[gestures] set` names ([`load_setup`]), and no breath
/// sensor.
pub fn imu_core(config: &Config) -> anyhow::Result<CoreConfig> {
    let setup = load_setup(config.core())?;
    Ok(config.clone().for_imu(setup).core().clone())
}

/// The gesture set `core`'s `[gestures] set` names, read and checked
/// against its library; an error says what to give without one.
pub fn load_setup(core: &CoreConfig) -> anyhow::Result<GestureSetup> {
    let Some(path) = core.gesture_set_file() else {
        bail!(
            "an IMU needs the person's gestures: give a --config with [gestures] set = \"FILE\" (made by `sipnpuff gestures record`) and library entries that name them"
        );
    };
    setup::load(core, path).map_err(anyhow::Error::msg)
}
