//! Replays the recordings in `fixtures/` through the real pipeline and
//! compares the events with the golden files, then checks independently that
//! those goldens say what the paper and the scripts say.

use crate::common::{self, fixture, paper_config};

use serde_json::Value;
use sipnpuff::config::Config;
use sipnpuff::control::mode::Mode;
use sipnpuff::sensor::csv::CsvSignal;
use sipnpuff::sim::script::{demo_script, parse_sequences, sequences_script};
use sipnpuff::sim::sensor_model::{SignalGenerator, SignalParams, Step, write_csv};
use sipnpuff::tools::csv_replay::replay;

fn replay_events(csv: &str, config: &Config) -> Vec<Value> {
    let mut input = CsvSignal::open(&fixture(csv)).unwrap();
    let mut out = Vec::new();
    replay(config.core(), &mut input, &mut out, None).unwrap();
    String::from_utf8(out)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

fn golden(name: &str) -> Vec<Value> {
    std::fs::read_to_string(fixture(name))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

/// Regenerates a fixture's CSV in memory, as `generate` wrote it.
fn regenerate(params: SignalParams, script: &[Step], samples: usize) -> String {
    let mut out = Vec::new();
    write_csv(&mut out, SignalGenerator::new(params, script).take(samples)).unwrap();
    String::from_utf8(out).unwrap()
}

/// `generate --config fixtures/paper-example.toml --sequences "1,2,-1 1,2 2,1 2 1,2,1"
/// --seed 3 --noise-volts 0.02`
fn paper_fixture_script(config: &Config) -> (SignalParams, Vec<Step>) {
    let params = SignalParams::clean(config.core().detector(), 3).with_noise(0.02);
    let sequences = parse_sequences("1,2,-1 1,2 2,1 2 1,2,1").unwrap();
    (params, sequences_script(config, &sequences))
}

/// `generate --demo --seed 1 --noise-volts 0.03 --hum-volts 0.05
/// --drift-volts 0.1 --spike-every-ms 250`
fn demo_fixture_script(config: &Config) -> (SignalParams, Vec<Step>, Vec<Mode>) {
    let params = SignalParams::clean(config.core().detector(), 1)
        .with_noise(0.03)
        .with_hum(0.05)
        .with_drift(0.1)
        .with_spikes_every(250);
    let (script, modes) = demo_script(config);
    (params, script, modes)
}

#[test]
fn fixtures_are_what_the_generator_makes() {
    let config = paper_config();
    let (params, script) = paper_fixture_script(&config);
    let committed = std::fs::read_to_string(fixture("paper-example.csv")).unwrap();
    assert!(
        regenerate(params, &script, usize::MAX) == committed,
        "paper-example.csv differs"
    );

    let config = Config::default();
    let (params, script, _) = demo_fixture_script(&config);
    let committed = std::fs::read_to_string(fixture("demo.csv")).unwrap();
    assert!(
        regenerate(params, &script, usize::MAX) == committed,
        "demo.csv differs"
    );
}

/// `replay --trace`: the trace's header, one row per tick, numbers that
/// parse, the mode by name.
#[test]
fn trace_has_a_row_per_tick() {
    let config = Config::default();
    let mut input = CsvSignal::open(&fixture("demo.csv")).unwrap();
    let (mut events, mut trace) = (Vec::new(), Vec::new());
    let summary = replay(config.core(), &mut input, &mut events, Some(&mut trace)).unwrap();
    let text = String::from_utf8(trace).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("tick,mode,vx,vy,vz,wx,wy,wz,fingers_vel,x,y,z,rx,ry,rz,fingers")
    );
    let mut rows = 0u64;
    let mut modes = std::collections::BTreeSet::new();
    for (i, line) in lines.enumerate() {
        let fields: Vec<&str> = line.split(',').collect();
        assert_eq!(fields.len(), 16, "{line}");
        assert_eq!(fields[0].parse::<u64>().unwrap(), i as u64);
        modes.insert(fields[1].to_string());
        for f in &fields[2..] {
            assert!(f.parse::<f64>().unwrap().is_finite(), "{line}");
        }
        rows += 1;
    }
    assert_eq!(rows, summary.samples);
    assert_eq!(summary.ticks_outside_workspace, 0);
    for mode in [
        "detection",
        "translate_x",
        "rotate_z",
        "fingers",
        "goto_point",
    ] {
        assert!(modes.contains(mode), "{modes:?}");
    }
}

#[test]
fn paper_example_matches_golden() {
    assert_eq!(
        replay_events("paper-example.csv", &paper_config()),
        golden("paper-example.events.jsonl")
    );
}

#[test]
fn demo_matches_golden() {
    assert_eq!(
        replay_events("demo.csv", &Config::default()),
        golden("demo.events.jsonl")
    );
}

/// The paper's walk-through, as the recording enters it:
/// ⟨1,2,−1⟩ matches S1 at once; ⟨1,2⟩ waits and matches S2 exactly
/// `sequence_timeout_ms` after the end of its last burst; ⟨2,1⟩ matches S3;
/// ⟨2⟩ alone is reset at the timeout; ⟨1,2,1⟩ is reset on its third burst.
#[test]
fn paper_example_golden_tells_the_papers_story() {
    let events = golden("paper-example.events.jsonl");
    let decisions: Vec<(&str, Vec<i64>, &str)> = events
        .iter()
        .filter(|e| e["event"] == "match" || e["event"] == "reset")
        .map(|e| {
            let seq = e["sequence"]
                .as_array()
                .unwrap()
                .iter()
                .map(|c| c.as_i64().unwrap())
                .collect();
            let what = e["mode"].as_str().or(e["reason"].as_str()).unwrap();
            (e["event"].as_str().unwrap(), seq, what)
        })
        .collect();
    assert_eq!(
        decisions,
        [
            ("match", vec![1, 2, -1], "translate_x"),
            ("match", vec![1, 2], "translate_y"),
            ("match", vec![2, 1], "translate_z"),
            ("reset", vec![2], "timeout"),
            ("reset", vec![1, 2, 1], "no_match"),
        ]
    );

    // Immediate decisions land on the tick of the last burst; waiting ones
    // exactly sequence_timeout_ms after that burst's end.
    let timeout = u64::from(paper_config().core().matcher().sequence_timeout_ms);
    let waited = [false, true, false, true, false];
    let decided: Vec<usize> = (0..events.len())
        .filter(|&i| events[i]["event"] == "match" || events[i]["event"] == "reset")
        .collect();
    for (&i, waited) in decided.iter().zip(waited) {
        let burst = events[..i]
            .iter()
            .rev()
            .find(|b| b["event"] == "burst")
            .unwrap();
        let end = burst["start_tick"].as_u64().unwrap() + burst["duration_ms"].as_u64().unwrap();
        let expected = if waited {
            end + timeout
        } else {
            burst["tick"].as_u64().unwrap()
        };
        assert_eq!(
            events[i]["tick"].as_u64().unwrap(),
            expected,
            "{}",
            events[i]
        );
    }
    // Every match is followed by a return to detection mode.
    let detections = events.iter().filter(|e| e["event"] == "detection").count();
    assert_eq!(detections, 3);
}

/// Every burst the scripted user made is detected, with the right sip or
/// puff and length class, and every mode it selected is matched, in order;
/// nothing else is detected. 0.05 V of hum and 0.03 V of noise move each
/// crossing of a ~0.03 V/ms ramp by a few ms: far below what tells a short
/// breath from a long one.
#[test]
fn demo_detects_every_scripted_burst_and_mode() {
    let config = Config::default();
    let (_, script, modes) = demo_fixture_script(&config);
    let mut input = CsvSignal::open(&fixture("demo.csv")).unwrap();
    let samples = std::iter::from_fn(|| input.next_sample().unwrap());
    common::assert_session(&config, samples, &script, &modes, 10);
}
