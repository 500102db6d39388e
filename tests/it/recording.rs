//! Session recordings (`replay DIR`, `bench replay`): a recording of a
//! real run (`fixtures/recording-built-in-user`) replays bit for bit, to
//! events and trace files too; a damaged one is named by file and offset,
//! a changed event by its line; the binary format round-trips any input.
//! Real runs recorded are the second tier's (`tests/live/recorded_runs.rs`).

use std::path::{Path, PathBuf};

use proptest::prelude::*;
use serde_json::Value;
use sipnpuff::control::motion::stream::ArmCommand;
use sipnpuff::control::sample::Sample;
use sipnpuff::control::tick::TickInput;
use sipnpuff::tools::recording::format::commands::{CommandDecoder, CommandEncoder, CommandItem};
use sipnpuff::tools::recording::format::samples::{SampleDecoder, SampleEncoder, SampleItem};
use sipnpuff::tools::recording::format::{Stream, StreamFile};

use crate::common::fixture;
use crate::recordings::{copy_recording, json, replay, sipnpuff, text};
use crate::scratch::Scratch;

/// A recording of 3 s of the built-in user, made by a real run (its
/// skipped ticks and its safe stop included): its first bursts.
fn short_recording() -> PathBuf {
    fixture("recording-built-in-user")
}

/// A copy of the short recording, in `rec` in a fresh scratch directory
/// (removed when the copy is dropped).
fn copy_of_short_recording() -> (Scratch, PathBuf) {
    let scratch = Scratch::new();
    let dir = scratch.join("rec");
    copy_recording(&short_recording(), &dir);
    (scratch, dir)
}

/// A copy of the short recording, `damage` done to it, replayed: the
/// error.
fn damaged(name: &str, damage: impl FnOnce(&Path)) -> String {
    let (_copy, dir) = copy_of_short_recording();
    damage(&dir);
    let (code, events, stderr) = replay(&dir);
    assert_eq!(code, 1, "{name}: {stderr}");
    assert!(events.is_empty(), "{name}: replayed before the check");
    stderr
}

fn edit_bytes(path: &Path, edit: impl FnOnce(&mut Vec<u8>)) {
    let mut bytes = std::fs::read(path).unwrap();
    edit(&mut bytes);
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn a_damaged_recording_is_an_error_naming_the_file_and_offset() {
    let (code, _, stderr) = replay(&short_recording());
    assert_eq!(code, 0, "{stderr}");

    let e = damaged("truncated", |dir| {
        edit_bytes(&dir.join("samples.bin"), |b| b.truncate(b.len() / 2));
    });
    assert!(
        e.contains("rec/samples.bin: offset ") && e.contains(": truncated"),
        "{e}"
    );
    let e = damaged("flipped", |dir| {
        edit_bytes(&dir.join("samples.bin"), |b| {
            let i = b.len() / 2;
            b[i] ^= 0x04;
        });
    });
    assert!(e.contains("rec/samples.bin: offset "), "{e}");
    let e = damaged("commands", |dir| {
        edit_bytes(&dir.join("commands.bin"), |b| b.truncate(b.len() - 3));
    });
    assert!(
        e.contains("rec/commands.bin: offset ") && e.contains("truncated"),
        "{e}"
    );
    let e = damaged("swapped", |dir| {
        std::fs::copy(dir.join("commands.bin"), dir.join("samples.bin")).unwrap();
    });
    assert!(
        e.contains("rec/samples.bin: offset 0: holds the commands stream"),
        "{e}"
    );
    let e = damaged("event", |dir| {
        let text = std::fs::read_to_string(dir.join("events.jsonl")).unwrap();
        std::fs::write(dir.join("events.jsonl"), format!("{text}{{\"tick\":")).unwrap();
    });
    assert!(e.contains("rec/events.jsonl: line "), "{e}");
    let e = damaged("meta", |dir| {
        std::fs::remove_file(dir.join("meta.json")).unwrap()
    });
    assert!(e.contains("rec/meta.json: missing"), "{e}");
    let e = damaged("config", |dir| {
        std::fs::write(dir.join("config.toml"), "[detector]\nmin_burst = 40\n").unwrap();
    });
    assert!(
        e.contains("rec/config.toml: ") && e.contains("detector.min_burst"),
        "{e}"
    );
    let e = damaged("count", |dir| {
        let meta = std::fs::read_to_string(dir.join("meta.json")).unwrap();
        let meta = meta.replacen("\"ticks\": ", "\"ticks\": 1", 1);
        std::fs::write(dir.join("meta.json"), meta).unwrap();
    });
    assert!(e.contains("rec/meta.json: says 1"), "{e}");
}

/// `bench replay` times the whole replay against the core alone through
/// the same inputs, and the core alone did the replay's work: its steps,
/// events and arm commands are the recording's. A damaged recording is
/// refused as `replay` refuses it.
#[test]
fn bench_replay_times_the_replay_against_the_core_alone() {
    let dir = short_recording();
    let out = sipnpuff(&[
        "bench",
        "replay",
        dir.to_str().unwrap(),
        "--rounds",
        "3",
        "--json",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let report: Value = serde_json::from_str(&text(&out.stdout)).unwrap();
    let meta = json(&dir.join("meta.json"));
    assert_eq!(report["ticks"], meta["ticks"], "{report}");
    assert_eq!(report["events"], meta["events"], "{report}");
    assert_eq!(report["arm_commands"], meta["arm_commands"], "{report}");
    assert_eq!(report["identical"], true);
    assert_eq!(report["rounds"], 3);
    // Figures as JSON gives them back: serde_json's parser may be an ulp
    // off the printed value, so they agree to rounding.
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
    let ticks = meta["ticks"].as_f64().unwrap();
    let recorded_s = report["recorded_s"].as_f64().unwrap();
    assert!(close(recorded_s, ticks / 1000.0), "{report}");
    let figure = |part: &str, key: &str| report[part][key].as_f64().unwrap();
    for part in ["whole_replay", "core_alone"] {
        let (median, min) = (figure(part, "median_ms"), figure(part, "min_ms"));
        assert!(min > 0.0 && min <= median, "{report}");
        let rate = ticks / 1000.0 / (median / 1e3);
        assert!(close(figure(part, "real_time"), rate), "{report}");
    }
    let share = figure("core_alone", "median_ms") / figure("whole_replay", "median_ms");
    assert!(
        close(report["core_share"].as_f64().unwrap(), share),
        "{report}"
    );
    let out = sipnpuff(&["bench", "replay", dir.to_str().unwrap(), "--rounds", "1"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let table = text(&out.stdout);
    assert!(
        table.contains("identical to the recording; 1 rounds of each")
            && table.contains("the core alone, stepped through the same inputs (the floor)"),
        "{table}"
    );

    let (_copy, damaged) = copy_of_short_recording();
    edit_bytes(&damaged.join("samples.bin"), |b| b.truncate(b.len() / 2));
    let out = sipnpuff(&["bench", "replay", damaged.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let e = text(&out.stderr);
    assert!(
        e.contains("rec/samples.bin: offset ") && e.contains(": truncated"),
        "{e}"
    );
    assert!(out.stdout.is_empty());
}

/// `--events` and `--trace` work for a recording as for a CSV signal:
/// the events are the recorded lines, the trace has a row per tick.
#[test]
fn a_recording_replays_to_events_and_trace_files() {
    let scratch = Scratch::new();
    let (events, trace) = (scratch.join("events.jsonl"), scratch.join("trace.csv"));
    let dir = short_recording();
    let out = sipnpuff(&[
        "replay",
        dir.to_str().unwrap(),
        "--events",
        events.to_str().unwrap(),
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(out.stdout.is_empty());
    assert_eq!(
        std::fs::read_to_string(&events).unwrap(),
        std::fs::read_to_string(dir.join("events.jsonl")).unwrap()
    );
    let trace = std::fs::read_to_string(&trace).unwrap();
    let meta = json(&dir.join("meta.json"));
    assert_eq!(
        trace.lines().count() as u64,
        meta["ticks"].as_u64().unwrap() + 1
    );
    assert!(trace.starts_with("tick,mode,vx,"), "{trace}");
    // With another configuration it is replayed, not compared.
    let paper = fixture("paper-example.toml");
    let out = sipnpuff(&[
        "replay",
        dir.to_str().unwrap(),
        "--config",
        paper.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    assert!(
        text(&out.stderr).contains("not compared: replayed with --config "),
        "{}",
        text(&out.stderr)
    );
}

#[test]
fn a_recorded_event_that_differs_is_named_with_its_line() {
    let (_copy, dir) = copy_of_short_recording();
    let events = std::fs::read_to_string(dir.join("events.jsonl")).unwrap();
    let first = events
        .lines()
        .next()
        .expect("an event in 1.5 s")
        .to_string();
    let changed = first.replacen("{\"tick\":", "{\"tick\":1", 1);
    std::fs::write(
        dir.join("events.jsonl"),
        events.replacen(&first, &changed, 1),
    )
    .unwrap();
    let (code, _, stderr) = replay(&dir);
    assert_eq!(code, 1);
    assert!(
        stderr.contains(&format!(
            "DIFFERENT from the recording: first difference: event 1 (line 1 of events.jsonl): recorded {changed}, replayed {first}"
        )),
        "{stderr}"
    );
}

/// A core input: a sample (any bits: NaN payloads, -0.0, the rails, a few
/// levels a sample-and-hold sensor repeats), none, or the device gone,
/// after a gap of skipped ticks, perhaps where the stop began.
fn inputs() -> impl Strategy<Value = Vec<(u64, Sample, bool)>> {
    let value = prop_oneof![
        3 => prop::sample::select(vec![2.5, 2.5, 4.0, -0.0, 0.0, 5.0]),
        2 => any::<f64>(),
        1 => any::<u64>().prop_map(f64::from_bits),
    ];
    let sample = prop_oneof![
        8 => value.prop_map(Sample::Volts),
        2 => Just(Sample::Missing),
        1 => Just(Sample::Lost),
    ];
    let gap = prop_oneof![6 => Just(0u64), 2 => 1u64..100, 1 => 0u64..u64::MAX / 4];
    prop::collection::vec((gap, sample, prop::bool::weighted(0.02)), 0..400)
}

proptest! {
    /// Any sequence of values, missing samples, ticks with the device
    /// gone, gaps, stops and losses comes back tick for tick and bit for
    /// bit.
    #[test]
    fn samples_round_trip(first in 0u64..5, items in inputs(), losses in prop::collection::vec((0usize..400, 1u64..1000), 0..3)) {
        let mut tick = first;
        let inputs: Vec<TickInput> = items
            .iter()
            .map(|&(gap, sample, stop)| {
                tick = tick.wrapping_add(gap);
                let input = TickInput {
                    tick,
                    sample,
                    stop,
                    ..TickInput::default()
                };
                tick = tick.wrapping_add(1);
                input
            })
            .collect();
        let mut file = StreamFile::start(Vec::new(), Stream::Samples).unwrap();
        let (mut enc, mut ops) = (SampleEncoder::default(), Vec::new());
        let mut expected = Vec::new();
        for (i, input) in inputs.iter().enumerate() {
            for &(at, n) in &losses {
                if at == i {
                    enc.lost(&mut ops, n);
                    expected.push(SampleItem::Lost(n));
                }
            }
            enc.input(&mut ops, input);
            expected.push(SampleItem::Input(*input));
            // Commit in pieces, as the writer does.
            if i % 37 == 0 {
                file.write(&ops).unwrap();
                ops.clear();
            }
        }
        enc.flush(&mut ops);
        file.write(&ops).unwrap();
        let bytes = file.end().unwrap();
        let mut dec = SampleDecoder::new(bytes.as_slice()).unwrap();
        let mut back = Vec::new();
        while let Some(item) = dec.next_item().unwrap() {
            back.push(item);
        }
        prop_assert_eq!(back.len(), expected.len());
        for (a, b) in back.iter().zip(&expected) {
            let bits = |item: &SampleItem| match *item {
                SampleItem::Input(TickInput { tick, sample, stop, .. }) => match sample {
                    Sample::Volts(v) => (0, tick, v.to_bits(), stop),
                    Sample::Missing => (1, tick, 0, stop),
                    Sample::Lost => (4, tick, 0, stop),
                },
                SampleItem::Lost(n) => (3, n, 0, false),
            };
            prop_assert_eq!(bits(a), bits(b));
        }
        // At most 9 bytes a tick, plus what gaps, stops and losses cost.
        let extra = items.iter().filter(|i| i.0 > 0 || i.2).count() + losses.len();
        prop_assert!(bytes.len() <= 15 + 9 * inputs.len() + 11 * extra + 11);
    }

    /// Any arm commands (numbers, ticks, any bits) come back exactly.
    #[test]
    fn commands_round_trip(commands in prop::collection::vec((0u64..3, 1u64..30, prop::collection::vec(prop_oneof![Just(0.0f64), any::<f64>()], 7)), 0..200)) {
        let (mut seq, mut tick) = (0u64, 0u64);
        let commands: Vec<ArmCommand> = commands
            .iter()
            .map(|(skip, dt, v)| {
                seq += skip;
                tick += dt;
                let c = ArmCommand { seq, tick, linear: [v[0], v[1], v[2]], angular: [v[3], v[4], v[5]], fingers: v[6] };
                seq += 1;
                c
            })
            .collect();
        let mut file = StreamFile::start(Vec::new(), Stream::Commands).unwrap();
        let (mut enc, mut ops) = (CommandEncoder::default(), Vec::new());
        for c in &commands {
            enc.command(&mut ops, c);
        }
        file.write(&ops).unwrap();
        let bytes = file.end().unwrap();
        let mut dec = CommandDecoder::new(bytes.as_slice()).unwrap();
        let mut back = Vec::new();
        while let Some(item) = dec.next_item().unwrap() {
            match item {
                CommandItem::Command(c) => back.push(c),
                CommandItem::Lost(n) => prop_assert!(false, "lost {}", n),
            }
        }
        let bits = |c: &ArmCommand| (c.seq, c.tick, [c.linear, c.angular].concat().iter().map(|v| v.to_bits()).collect::<Vec<_>>(), c.fingers.to_bits());
        prop_assert_eq!(back.iter().map(bits).collect::<Vec<_>>(), commands.iter().map(bits).collect::<Vec<_>>());
    }
}
