//! `fit --from` on input it cannot trust: a block breathed one breath
//! short or long, a breath of the other kind or length, a CSV at another
//! rate, settings and a recording on different scales, a guided
//! recording fitted with another protocol. Each is one line naming the
//! block, the breath or the key, and nothing is written; a miscount the
//! fit can still read honestly is fitted and said.

use std::path::{Path, PathBuf};

use sipnpuff::control::detector::DetectorConfig;
use sipnpuff::control::tick::TickInput;
use sipnpuff::fit::protocol::Protocol;
use sipnpuff::sim::sensor_model::{SignalGenerator, SignalParams, Step};
use sipnpuff::tools::recording::format::samples::SampleEncoder;
use sipnpuff::tools::recording::format::{Stream, StreamFile};

use crate::common::{assert_exit, fixture, puff, rest, sip, sipnpuff_output};
use crate::recordings::copy_recording;
use crate::scratch::Scratch;

/// The default protocol's four blocks as asked: 8 short puffs (150 ms),
/// 8 long puffs (800 ms), 8 short sips, 8 long sips. A test changes a
/// block's breaths before [`calibration`] breathes them.
fn asked() -> Vec<Vec<Step>> {
    [puff(150), puff(800), sip(150), sip(800)]
        .map(|breath| vec![breath; 8])
        .to_vec()
}

/// `blocks` breathed after 6 s at rest: 1.5 s between breaths, and
/// `between_blocks[i]` ms after block `i + 1` (the protocol rests at
/// least 3 s).
fn calibration(blocks: &[Vec<Step>], between_blocks: [u32; 4]) -> Vec<f64> {
    let mut script = vec![rest(6000)];
    for (block, pause) in blocks.iter().zip(between_blocks) {
        for &breath in block {
            script.extend([breath, rest(1500)]);
        }
        script.push(rest(pause.saturating_sub(1500)));
    }
    let params = SignalParams::clean(&DetectorConfig::default(), 1).with_noise(0.01);
    SignalGenerator::new(params, &script).collect()
}

/// 3.5 s after every block.
const PAUSED: [u32; 4] = [3500; 4];

/// `volts` as a `tick,volts` CSV at 1 kHz in `dir`.
fn csv(dir: &Path, name: &str, volts: &[f64]) -> PathBuf {
    let path = dir.join(name);
    let rows: String = volts
        .iter()
        .enumerate()
        .map(|(tick, v)| format!("{tick},{v:.4}\n"))
        .collect();
    std::fs::write(&path, format!("tick,volts\n{rows}")).unwrap();
    path
}

/// `fit --from FROM --out DIR/profile.toml ARGS…` as it ended: its
/// status, stdout and stderr, the profile's path, and the files under
/// `dir` before and after.
struct Fitted {
    status: std::process::ExitStatus,
    stdout: String,
    stderr: String,
    profile: PathBuf,
    files: (usize, usize),
}

fn fit(dir: &Path, from: &Path, args: &[&str]) -> Fitted {
    let profile = dir.join("profile.toml");
    let mut all = vec![
        "fit",
        "--from",
        from.to_str().unwrap(),
        "--out",
        profile.to_str().unwrap(),
    ];
    all.extend_from_slice(args);
    let before = files_under(dir);
    let out = sipnpuff_output(&all);
    Fitted {
        status: out.status,
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        profile,
        files: (before, files_under(dir)),
    }
}

/// Files under `dir`, at any depth.
fn files_under(dir: &Path) -> usize {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|entry| {
            let path = entry.unwrap().path();
            if path.is_dir() { files_under(&path) } else { 1 }
        })
        .sum()
}

impl Fitted {
    /// Refused with exit status `code` and `line` alone on stderr:
    /// nothing on stdout, no profile, no file written anywhere.
    fn refused(&self, code: i32, line: &str) {
        assert_exit(self.status, &self.stderr, code, "fit");
        assert_eq!(self.stderr, format!("{line}\n"));
        assert_eq!(self.stdout, "");
        assert!(!self.profile.exists());
        assert_eq!(self.files.0, self.files.1, "a file was written");
    }

    /// Fitted, the profile written, the report saying `note`.
    fn fitted_saying(&self, note: &str) {
        assert_exit(self.status, &self.stderr, 0, "fit");
        assert!(self.profile.exists());
        assert!(
            self.stdout.lines().any(|l| l == format!("note: {note}")),
            "{}",
            self.stdout
        );
    }
}

#[test]
fn a_block_one_breath_short_is_fitted_from_what_was_breathed_and_said() {
    let dir = Scratch::new();
    let mut blocks = asked();
    blocks[1].pop();
    let from = csv(&dir, "seven-long-puffs.csv", &calibration(&blocks, PAUSED));
    fit(&dir, &from, &[])
        .fitted_saying("block 2 (long puffs): 7 breaths where 8 were asked (fitted from the 7)");
}

#[test]
fn a_block_one_breath_long_is_fitted_from_what_was_breathed_and_said() {
    let dir = Scratch::new();
    let mut blocks = asked();
    blocks[2].push(sip(150));
    let from = csv(&dir, "nine-short-sips.csv", &calibration(&blocks, PAUSED));
    fit(&dir, &from, &[])
        .fitted_saying("block 3 (short sips): 9 breaths where 8 were asked (fitted from the 9)");
}

#[test]
fn a_miscounted_block_with_no_pause_to_mark_it_is_refused() {
    let dir = Scratch::new();
    let mut blocks = asked();
    blocks[1].pop();
    // No rest of 3 s between the short and the long puffs: which of the
    // 15 puffs was the missing one's block cannot be told.
    let between = [1500, 3500, 3500, 3500];
    let from = csv(&dir, "no-pause.csv", &calibration(&blocks, between));
    fit(&dir, &from, &[]).refused(
        1,
        &format!(
            "error: cannot fit {}: block 2 (long puffs): 7 breaths where 8 were asked, and no pause of 3 s marks where the block begins or ends: record the calibration again, resting 3 s between blocks",
            from.display()
        ),
    );
}

#[test]
fn a_sip_where_a_long_puff_was_asked_is_refused_naming_block_and_breath() {
    let dir = Scratch::new();
    let mut blocks = asked();
    blocks[1][2] = sip(800);
    let from = csv(&dir, "a-sip.csv", &calibration(&blocks, PAUSED));
    fit(&dir, &from, &[]).refused(
        1,
        &format!(
            "error: cannot fit {}: block 2 (long puffs), breath 3 at 26.3 s: a sip where a long puff was asked, and without it the block has 7 long puffs where 8 were asked: record the calibration again",
            from.display()
        ),
    );
}

#[test]
fn a_sip_made_up_for_by_another_puff_is_left_out_and_said() {
    // As the live guide asks ("that was a sip — again, a puff please"):
    // the block still holds its 8 long puffs.
    let dir = Scratch::new();
    let mut blocks = asked();
    blocks[1].insert(2, sip(800));
    let from = csv(
        &dir,
        "a-sip-then-the-puff.csv",
        &calibration(&blocks, PAUSED),
    );
    fit(&dir, &from, &[]).fitted_saying(
        "block 2 (long puffs), breath 3 at 26.3 s: a sip where a long puff was asked, left out (the block has its 8 without it)",
    );
}

#[test]
fn a_short_puff_where_a_long_puff_was_asked_is_refused_naming_block_and_breath() {
    let dir = Scratch::new();
    let mut blocks = asked();
    blocks[1][3] = puff(150);
    let from = csv(&dir, "a-short-puff.csv", &calibration(&blocks, PAUSED));
    fit(&dir, &from, &[]).refused(
        1,
        &format!(
            "error: cannot fit {}: block 2 (long puffs), breath 4 at 28.7 s: a short puff (182 ms; the block's others 817–839 ms) where a long puff was asked, and without it the block has 7 long puffs where 8 were asked: record the calibration again",
            from.display()
        ),
    );
}

#[test]
fn a_long_sip_where_a_short_sip_was_asked_is_refused_naming_block_and_breath() {
    let dir = Scratch::new();
    let mut blocks = asked();
    blocks[2][4] = sip(800);
    let from = csv(&dir, "a-long-sip.csv", &calibration(&blocks, PAUSED));
    fit(&dir, &from, &[]).refused(
        1,
        &format!(
            "error: cannot fit {}: block 3 (short sips), breath 5 at 49.3 s: a long sip (830 ms; the block's others 174–193 ms) where a short sip was asked, and without it the block has 7 short sips where 8 were asked: record the calibration again",
            from.display()
        ),
    );
}

#[test]
fn a_csv_at_500_hz_is_refused_naming_both_rates() {
    let dir = Scratch::new();
    let volts = calibration(&asked(), PAUSED);
    let path = dir.join("500hz.csv");
    let rows: String = (volts.iter().step_by(2).enumerate())
        .map(|(row, v)| format!("{},{v:.4}\n", 2 * row))
        .collect();
    std::fs::write(&path, format!("tick,volts\n{rows}")).unwrap();
    fit(&dir, &path, &[]).refused(
        1,
        &format!(
            "error: {}: its ticks are 500 Hz (1000 rows over 1998 ms), where fit reads 1000 Hz (one row per 1 ms tick): resample it to 1 kHz and fit again",
            path.display()
        ),
    );
}

#[test]
fn a_profile_in_adc_counts_is_refused_against_a_recording_in_volts() {
    let dir = Scratch::new();
    let from = csv(&dir, "volts.csv", &calibration(&asked(), PAUSED));
    let profile = dir.join("counts.toml");
    std::fs::write(&profile, "[detector]\nneutral_volts = 512\n").unwrap();
    fit(&dir, &from, &["--config", profile.to_str().unwrap()]).refused(
        2,
        &format!(
            "error: {}: detector.neutral_volts = 512 looks like ADC counts, but {} is in volts (its rest is at 2.50 V): the settings are volts at the sensor (0–5 V); give a profile fitted with this sensor, or none",
            profile.display(),
            from.display()
        ),
    );
}

#[test]
fn a_recording_in_adc_counts_is_refused_against_settings_in_volts() {
    let dir = Scratch::new();
    let counts: Vec<f64> = (calibration(&asked(), PAUSED).iter())
        .map(|v| (v / 5.0 * 1023.0).round())
        .collect();
    let from = csv(&dir, "counts.csv", &counts);
    fit(&dir, &from, &[]).refused(
        1,
        &format!(
            "error: {}: its rest is at 512, which looks like ADC counts, but detector.neutral_volts is 2.5 V (built-in): the settings are volts at the sensor (0–5 V); convert the recording to volts (counts / full scale × 5)",
            from.display()
        ),
    );
}

/// A guided session's recording at `dir`: `volts` as a run records
/// them, and `protocol` as the guide leaves it (`calibration.json`).
fn guided_recording(dir: &Path, protocol: &Protocol, volts: &[f64]) -> PathBuf {
    copy_recording(&fixture("recording-built-in-user"), dir);
    let file = std::fs::File::create(dir.join("samples.bin")).unwrap();
    let mut file = StreamFile::start(std::io::BufWriter::new(file), Stream::Samples).unwrap();
    let (mut encoder, mut ops) = (SampleEncoder::default(), Vec::new());
    for (tick, &v) in volts.iter().enumerate() {
        encoder.input(&mut ops, &TickInput::volts(tick as u64, v));
    }
    encoder.flush(&mut ops);
    file.write(&ops).unwrap();
    file.end().unwrap();
    let json = serde_json::to_string_pretty(protocol).unwrap();
    std::fs::write(dir.join("calibration.json"), json).unwrap();
    dir.to_path_buf()
}

#[test]
fn a_guided_recording_fitted_with_another_count_is_refused_naming_the_option() {
    let dir = Scratch::new();
    let blocks: Vec<Vec<Step>> = asked().into_iter().map(|b| b[..3].to_vec()).collect();
    let recording = guided_recording(
        &dir.join("session"),
        &Protocol::new(3, 0),
        &calibration(&blocks, PAUSED),
    );
    fit(&dir, &recording, &[]).refused(
        2,
        &format!(
            "error: {}: the session was guided through 3 breaths a block (calibration.json), where fit asks for 8 breaths a block (--count 8): fit it with --count 3",
            recording.display()
        ),
    );
    // With the protocol it was guided through, it fits.
    let fitted = fit(&dir, &recording, &["--count", "3"]);
    assert_exit(fitted.status, &fitted.stderr, 0, "fit --count 3");
}
