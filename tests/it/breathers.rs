//! Simulated people with known breathing: their calibration sessions
//! follow the protocol's structure and timings, every breath is as strong
//! and as long as the breather's truth says, and a detector set at the
//! true crossings reads each one at exactly its true length.

use sipnpuff::config::Config;
use sipnpuff::control::action::Breath;
use sipnpuff::control::detector::{Burst, BurstDetector, DetectorEvent};
use sipnpuff::control::sample::Sample;
use sipnpuff::fit::protocol::{Ask, Protocol};
use sipnpuff::sim::breather::{
    Breather, HOLD_VARIATION, PRACTICE_SEQUENCE_GAP_MS, PROTOCOL_BLOCK_GAP_MS,
    PROTOCOL_BREATH_GAP_MS, PROTOCOL_START_MS, ProtocolBreath, VARIATION, practice_session,
    protocol_session,
};
use sipnpuff::sim::sensor_model::{DEFAULT_RAMP_MS, Step};

use crate::scratch::Scratch;

/// Most samples the ramps add to a rest between two breaths: the fall of
/// one and the rise of the next, each at most a whole ramp.
const RAMPS: u64 = 2 * DEFAULT_RAMP_MS.1 as u64 + 2;

/// The protocol with holds, each block 8 breaths.
fn with_holds() -> Protocol {
    Protocol::new(8, 3)
}

/// The bursts a detector at the breather's true crossings reads.
fn read(breather: &Breather, samples: impl Iterator<Item = f64>) -> Vec<Burst> {
    let mut detector = BurstDetector::new(&breather.true_detector());
    samples
        .enumerate()
        .filter_map(
            |(t, v)| match detector.step(t as u64, Sample::Volts(v)).event {
                Some(DetectorEvent::Burst(b)) => Some(b),
                _ => None,
            },
        )
        .collect()
}

fn is_long(ask: Ask) -> bool {
    match ask {
        Ask::Breath(action) => action.is_long(),
        Ask::Hold(_) => true,
    }
}

#[test]
fn a_protocol_session_follows_the_protocol() {
    let protocol = with_holds();
    for breather in Breather::all() {
        for seed in 0..3 {
            let s = protocol_session(breather, &protocol, seed);
            let what = format!("{} seed {seed}", breather.name);
            let asks: Vec<Ask> = s.breaths.iter().map(|b| b.ask).collect();
            assert_eq!(asks, protocol.prompts().collect::<Vec<_>>(), "{what}");
            // The script's breaths are the truth's, in order.
            let scripted: Vec<(Breath, u32)> = s
                .script
                .iter()
                .filter_map(|step| match *step {
                    Step::Breath { breath, ms } => Some((breath, ms)),
                    _ => None,
                })
                .collect();
            let truth: Vec<(Breath, u32)> =
                s.breaths.iter().map(|b| (b.ask.breath(), b.ms)).collect();
            assert_eq!(scripted, truth, "{what}");
            // A rest of at least 5 s first (its samples at the rest level).
            let first = s.breaths[0].start;
            assert!(first >= u64::from(PROTOCOL_START_MS.0), "{what}: {first}");
            assert!(first <= u64::from(PROTOCOL_START_MS.1) + RAMPS, "{what}");
            let rest: Vec<f64> = s.signal().take(PROTOCOL_START_MS.0 as usize).collect();
            let level = rest.iter().sum::<f64>() / rest.len() as f64;
            assert!((2.0..=3.0).contains(&level), "{what}: {level}");
            assert!(
                (level - breather.rest_volts).abs() <= breather.drift_volts + 0.005,
                "{what}: {level}"
            );
            // 1–2 s between the breaths of a block, 3–4 s between blocks
            // (the rest, plus whatever of the ramps lies outside the
            // breaths' true spans).
            for pair in s.breaths.windows(2) {
                let gap = pair[1].start - (pair[0].start + u64::from(pair[0].ms));
                let range = if pair[0].ask == pair[1].ask {
                    PROTOCOL_BREATH_GAP_MS
                } else {
                    PROTOCOL_BLOCK_GAP_MS
                };
                assert!(
                    gap >= u64::from(range.0) && gap <= u64::from(range.1) + RAMPS,
                    "{what}: {gap} ms after {:?}",
                    pair[0]
                );
            }
            // Each length within its spread of the breather's mean.
            for b in &s.breaths {
                let spread = if matches!(b.ask, Ask::Hold(_)) {
                    HOLD_VARIATION
                } else {
                    VARIATION
                };
                let mean = f64::from(breather.mean_ms(b.ask));
                let ms = f64::from(b.ms);
                assert!(
                    ms >= (mean * (1.0 - spread)).floor() && ms <= (mean * (1.0 + spread)).ceil(),
                    "{what}: {b:?}"
                );
            }
            // Within the rails; on them only for a spike.
            if breather.spike_every_ms == 0 {
                assert!(s.signal().all(|v| v > 0.0 && v < 5.0), "{what}");
            } else {
                assert!(s.signal().all(|v| (0.0..=5.0).contains(&v)), "{what}");
            }
            assert_eq!(s.signal().count() as u64, s.ticks);
        }
    }
    // Blocks of the counts asked for.
    let s = protocol_session(&Breather::all()[0], &Protocol::new(5, 0), 1);
    assert_eq!(s.breaths.len(), 20);
    let b = Breather::named("short_capacity").unwrap();
    let s = protocol_session(&b, &Protocol::new(50, 0), 2);
    assert!(s.breaths.iter().all(|b| b.ms <= 780));
}

#[test]
fn each_breath_is_as_strong_as_its_breather_within_thirty_percent() {
    for breather in Breather::all() {
        let quiet = breather.noise_free();
        let mut peaks = [Vec::new(), Vec::new()];
        for seed in 0..3 {
            let s = protocol_session(&quiet, &with_holds(), seed);
            let samples: Vec<f64> = s.signal().collect();
            for b in &s.breaths {
                let span = &samples[b.start as usize..(b.start + u64::from(b.ms)) as usize];
                let sign = match b.ask.breath() {
                    Breath::Puff => 1.0,
                    Breath::Sip => -1.0,
                };
                let peak = span
                    .iter()
                    .map(|v| sign * (v - breather.rest_volts))
                    .fold(f64::MIN, f64::max);
                let mean = breather.mean_volts(b.ask.breath());
                assert!(
                    peak >= 0.99 * (1.0 - VARIATION) * mean
                        && peak <= (1.0 + VARIATION) * mean + breather.tremor_volts + 1e-9,
                    "{} seed {seed}: {peak} V in {b:?}",
                    breather.name
                );
                peaks[usize::from(sign > 0.0)].push(peak - breather.tremor_volts / 2.0);
            }
        }
        for (kind, peaks) in [Breath::Sip, Breath::Puff].into_iter().zip(peaks) {
            let average = peaks.iter().sum::<f64>() / peaks.len() as f64;
            let mean = breather.mean_volts(kind);
            assert!(
                (average / mean - 1.0).abs() < 0.1 + breather.tremor_volts / (2.0 * mean),
                "{} {kind:?}: {average} V on average",
                breather.name
            );
        }
    }
}

#[test]
fn a_detector_at_the_true_crossings_reads_each_protocol_breath_exactly() {
    for breather in Breather::all() {
        let quiet = breather.noise_free();
        for seed in 0..3 {
            let s = protocol_session(&quiet, &with_holds(), seed);
            let bursts = read(&quiet, s.signal());
            let what = format!("{} seed {seed}", breather.name);
            assert_eq!(bursts.len(), s.breaths.len(), "{what}");
            for (burst, truth) in bursts.iter().zip(&s.breaths) {
                let ProtocolBreath { ask, start, ms } = *truth;
                assert_eq!(burst.start, start, "{what}: {burst:?} for {truth:?}");
                assert_eq!(burst.duration_ms(), u64::from(ms), "{what}: {truth:?}");
                assert_eq!(burst.action.breath(), ask.breath(), "{what}");
                assert_eq!(burst.action.is_long(), is_long(ask), "{what}: {truth:?}");
            }
        }
    }
}

#[test]
fn a_practice_session_is_library_sequences_read_exactly_at_the_truth() {
    let config = Config::default();
    let library = config.core().sequences();
    for breather in Breather::all() {
        let quiet = breather.noise_free();
        let s = practice_session(&quiet, library, 90, 7);
        let what = breather.name;
        assert_eq!(s.signal().count(), 90_000, "{what}");
        // The breaths are the selected sequences' actions, in order.
        let meant: Vec<_> = s
            .modes
            .iter()
            .flat_map(|m| {
                let entry = library
                    .iter()
                    .find(|e| e.target.mode() == Some(*m))
                    .unwrap();
                entry.breaths().unwrap().as_slice().to_vec()
            })
            .collect();
        let actions: Vec<_> = s.breaths.iter().map(|b| b.action).collect();
        assert_eq!(actions, meant, "{what}");
        assert!(s.modes.len() >= 10, "{what}: {} sequences", s.modes.len());
        // Gaps: the breather's within a sequence, 1.5–3 s between them.
        let mut within = 0;
        for pair in s.breaths.windows(2) {
            let gap = pair[1].start - (pair[0].start + u64::from(pair[0].ms));
            let low = (f64::from(quiet.gap_ms) * (1.0 - VARIATION)).floor() as u64;
            let high = (f64::from(quiet.gap_ms) * (1.0 + VARIATION)).ceil() as u64 + RAMPS;
            if gap <= high {
                assert!(gap >= low, "{what}: {gap}");
                within += 1;
            } else {
                assert!(
                    gap >= u64::from(PRACTICE_SEQUENCE_GAP_MS.0),
                    "{what}: {gap}"
                );
                assert!(gap <= u64::from(PRACTICE_SEQUENCE_GAP_MS.1) + RAMPS);
            }
        }
        assert_eq!(within, s.breaths.len() - s.modes.len(), "{what}");
        let bursts = read(&quiet, s.signal());
        assert_eq!(bursts.len(), s.breaths.len(), "{what}");
        for (burst, truth) in bursts.iter().zip(&s.breaths) {
            assert_eq!(
                (burst.action, burst.start, burst.duration_ms()),
                (truth.action, truth.start, u64::from(truth.ms)),
                "{what}"
            );
        }
    }
}

#[test]
fn generate_writes_a_breathers_protocol_and_its_truth() {
    let dir = Scratch::new();
    let (csv, json) = (dir.join("weak.csv"), dir.join("weak.json"));
    let mut command = crate::common::sipnpuff();
    command.args([
        "generate",
        "--protocol",
        "--holds",
        "--breather",
        "weak",
        "--seed",
        "3",
        "--out",
        csv.to_str().unwrap(),
        "--truth",
        json.to_str().unwrap(),
    ]);
    let out = crate::watchdog::output(&mut command);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let breather = Breather::named("weak").unwrap();
    let session = protocol_session(&breather, &with_holds(), 3);
    let text = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(text.lines().count() as u64, session.ticks + 1);
    assert!(text.starts_with("tick,volts\n0,"));
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(truth["breather"]["name"], "weak");
    assert_eq!(truth["breather"]["puff_volts"], 0.4);
    assert_eq!(truth["samples"], session.ticks);
    assert_eq!(
        truth["protocol"]["blocks"][5]["ask"],
        "longest comfortable sip"
    );
    let breaths = truth["breaths"].as_array().unwrap();
    assert_eq!(breaths.len(), 38);
    for (written, b) in breaths.iter().zip(&session.breaths) {
        assert_eq!(written["kind"], b.ask.words());
        assert_eq!(written["start_tick"], b.start);
        assert_eq!(written["ms"], b.ms);
    }

    // Ordinary use for --seconds; a name not built in is refused, naming
    // the built-ins.
    let mut command = crate::common::sipnpuff();
    command.args(["generate", "--breather", "slow", "--seconds", "5"]);
    command.args(["--out", csv.to_str().unwrap()]);
    assert!(crate::watchdog::output(&mut command).status.success());
    assert_eq!(std::fs::read_to_string(&csv).unwrap().lines().count(), 5001);
    let mut command = crate::common::sipnpuff();
    command.args(["generate", "--breather", "nobody", "--out", "/dev/null"]);
    let out = crate::watchdog::output(&mut command);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("typical, weak, short_capacity"), "{stderr}");
}
