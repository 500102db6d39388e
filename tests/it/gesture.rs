//! The gesture front end on synthetic head motion: each scenario is a
//! short script of rests and moves (`sipnpuff::sim::head`), with the
//! sensor's and the world's noise, through the live path
//! (`Recognizer::step` on every tick, the last sample held between
//! samples).

use sipnpuff::control::Tick;
use sipnpuff::control::gesture::{
    Frame, GestureConfig, GestureEvent, GestureId, GestureTemplates, Recognizer, RejectReason,
    segments,
};
use sipnpuff::control::imu::ImuSample;
use sipnpuff::sim::head::{Head, HeadScript, Move, Noise};

const NOD: GestureId = GestureId(0);
const SHAKE: GestureId = GestureId(1);
const TILT_LEFT: GestureId = GestureId(2);
const TILT_RIGHT: GestureId = GestureId(3);
const LOOK_UP: GestureId = GestureId(4);

/// The gestures of the scenarios' person, by id.
const GESTURES: [(GestureId, Head); 5] = [
    (NOD, Head::Nod),
    (SHAKE, Head::Shake),
    (TILT_LEFT, Head::TiltLeft),
    (TILT_RIGHT, Head::TiltRight),
    (LOOK_UP, Head::LookUp),
];

/// The examples a person gives when fitting: ±30 % speed and amplitude.
const EXAMPLES: [(f64, f64); 5] = [(0.7, 0.7), (1.3, 1.3), (0.7, 1.3), (1.3, 0.7), (1.0, 1.0)];

fn config() -> GestureConfig {
    GestureConfig::default()
}

/// Samples every `every_ms` of `script` with typical noise.
fn recording(script: &HeadScript, every_ms: u64, seed: u64) -> Vec<(Tick, ImuSample)> {
    script.samples(every_ms, Noise::TYPICAL, seed)
}

/// The frames of one example of `m`, cut as the live core cuts them.
fn example(m: Move, seed: u64) -> Vec<Frame> {
    let script = HeadScript::new().rest(1000).then(m).rest(1000);
    let mut cut = segments(&config(), recording(&script, 10, seed));
    assert_eq!(cut.len(), 1, "{m:?}: {} segments", cut.len());
    cut.remove(0).frames
}

/// Five examples of each gesture (seeds apart from the scenarios'), and
/// each gesture's threshold: 1.25 times the furthest any of its examples is
/// from its nearest sibling.
pub fn templates() -> GestureTemplates {
    let mut set = GestureTemplates::new();
    for (id, head) in GESTURES {
        let frames: Vec<Vec<Frame>> = EXAMPLES
            .iter()
            .enumerate()
            .map(|(i, &(speed, amp))| example(Move::new(head).varied(speed, amp), 1000 + i as u64))
            .collect();
        for f in &frames {
            set.add(id, f).unwrap();
        }
        let spread = frames
            .iter()
            .enumerate()
            .map(|(i, a)| {
                frames
                    .iter()
                    .enumerate()
                    .filter(|&(j, _)| j != i)
                    .map(|(_, b)| dtw(a, b))
                    .fold(f64::INFINITY, f64::min)
            })
            .fold(0.0, f64::max);
        set.set_threshold(id, 1.25 * spread);
    }
    set
}

fn dtw(a: &[Frame], b: &[Frame]) -> f64 {
    let band = config().band_frames(b.len());
    sipnpuff::control::gesture::dtw_distance(a, b, band, f64::INFINITY)
}

fn recognizer() -> Recognizer {
    Recognizer::new(config(), templates()).unwrap()
}

/// Every event of `samples` through `recognizer`, stepping every tick.
fn events(recognizer: &mut Recognizer, samples: &[(Tick, ImuSample)]) -> Vec<GestureEvent> {
    let mut out = Vec::new();
    let mut next = samples.iter().peekable();
    let last = samples.last().map_or(0, |s| s.0);
    for tick in 0..=last {
        let sample = next.next_if(|s| s.0 == tick).map(|s| &s.1);
        out.extend(recognizer.step(tick, sample));
    }
    out
}

/// `m` alone between rests, as the recognizer decides it.
fn decide(m: Move, seed: u64) -> Vec<GestureEvent> {
    let script = HeadScript::new().rest(1000).then(m).rest(1000);
    events(&mut recognizer(), &recording(&script, 10, seed))
}

fn recognised(events: &[GestureEvent]) -> Vec<GestureId> {
    events
        .iter()
        .filter_map(|e| match e {
            GestureEvent::Recognised { gesture, .. } => Some(*gesture),
            GestureEvent::Rejected { .. } => None,
        })
        .collect()
}

#[test]
fn gesture_nod_and_tilt_are_recognised_as_themselves() {
    for (speed, amp) in [(1.0, 1.0), (0.8, 1.2), (1.2, 0.8)] {
        let nod = decide(Move::new(Head::Nod).varied(speed, amp), 7);
        assert_eq!(recognised(&nod), [NOD], "{speed} {amp}: {nod:?}");
        let tilt = decide(Move::new(Head::TiltLeft).varied(speed, amp), 8);
        assert_eq!(recognised(&tilt), [TILT_LEFT], "{speed} {amp}: {tilt:?}");
    }
}

#[test]
fn gesture_every_one_of_the_set_is_told_apart() {
    let recognizer = recognizer();
    for (id, head) in GESTURES {
        let script = HeadScript::new()
            .rest(1000)
            .then(Move::new(head))
            .rest(1000);
        let cut = segments(&config(), recording(&script, 10, 42));
        assert_eq!(cut.len(), 1, "{head:?}");
        let found = recognizer.classify(&cut[0].frames);
        assert_eq!(found.nearest.map(|n| n.0), Some(id), "{head:?}: {found:?}");
    }
}

#[test]
fn gesture_a_tilt_held_for_a_second_and_a_half_is_one_segment() {
    let tilt = Move::new(Head::TiltRight).held(1500);
    let script = HeadScript::new().rest(1000).then(tilt).rest(1000);
    let cut = segments(&config(), recording(&script, 10, 3));
    assert_eq!(cut.len(), 1, "{cut:?}");
    let (start, end) = (1000, 1000 + tilt.duration_ms());
    // The segment starts and ends where the smoothed rate passes the
    // thresholds: within the ramps (300 ms each), the start up to the
    // lead frames (2 × 60 ms) earlier, the end up to the smoothing's
    // tail (3 × 60 ms) later.
    assert!(
        cut[0].start + 120 >= start && cut[0].start < start + 300,
        "{}",
        cut[0].start
    );
    assert!(
        cut[0].end > end - 300 && cut[0].end <= end + 200,
        "{}",
        cut[0].end
    );
    assert!(!cut[0].too_long);
}

#[test]
fn gesture_a_twitch_is_ignored() {
    let script = HeadScript::new()
        .rest(1000)
        .then(Move::new(Head::Twitch).varied(1.0, 4.0))
        .rest(1000);
    assert_eq!(segments(&config(), recording(&script, 10, 4)), []);
    assert_eq!(events(&mut recognizer(), &recording(&script, 10, 4)), []);
}

#[test]
fn gesture_looking_around_is_rejected_never_recognised() {
    let mut recognizer = recognizer();
    let mut script = HeadScript::new().rest(1000);
    for (speed, amp) in [(1.0, 1.0), (1.5, 0.7), (2.0, 1.0), (0.8, 1.2)] {
        script = script
            .then(Move::new(Head::LookAround).varied(speed, amp))
            .rest(800);
    }
    let out = events(&mut recognizer, &recording(&script, 10, 5));
    assert!(!out.is_empty());
    assert_eq!(recognised(&out), [], "{out:?}");
}

#[test]
fn gesture_held_samples_at_100_hz_give_the_1_khz_events() {
    let mut script = HeadScript::new().rest(1000);
    for (_, head) in GESTURES {
        script = script.then(Move::new(head)).rest(700);
    }
    let slow = events(&mut recognizer(), &script.samples(10, Noise::NONE, 6));
    let fast = events(&mut recognizer(), &script.samples(1, Noise::NONE, 6));
    assert_eq!(recognised(&slow), GESTURES.map(|g| g.0));
    assert_eq!(recognised(&fast), GESTURES.map(|g| g.0));
    let frame = u64::from(config().frame_ms);
    for (a, b) in slow.iter().zip(&fast) {
        let (
            GestureEvent::Recognised {
                start: s1, end: e1, ..
            },
            GestureEvent::Recognised {
                start: s2, end: e2, ..
            },
        ) = (a, b)
        else {
            unreachable!()
        };
        assert!(
            s1.abs_diff(*s2) <= frame && e1.abs_diff(*e2) <= frame,
            "{a:?} {b:?}"
        );
    }
}

#[test]
fn gesture_same_input_gives_the_same_events_bit_for_bit() {
    let script = HeadScript::new()
        .rest(800)
        .then(Move::new(Head::Nod))
        .rest(500)
        .then(Move::new(Head::LookAround).varied(1.5, 1.0))
        .rest(800)
        .then(Move::new(Head::Shake).varied(1.2, 0.8))
        .rest(800);
    let samples = recording(&script, 10, 9);
    let a = events(&mut recognizer(), &samples);
    let mut again = recognizer();
    let b = events(&mut again, &samples);
    assert!(a.len() >= 3, "{a:?}");
    assert_eq!(format!("{a:?}"), format!("{b:?}"));
    again.reset();
    assert_eq!(
        format!("{:?}", events(&mut again, &samples)),
        format!("{a:?}")
    );
}

#[test]
fn gesture_classify_says_what_step_decided() {
    let mut recognizer = recognizer();
    let script = HeadScript::new()
        .rest(1000)
        .then(Move::new(Head::Shake).varied(0.8, 1.1))
        .rest(800)
        .then(Move::new(Head::LookAround).varied(1.5, 1.0))
        .rest(1000);
    let samples = recording(&script, 10, 11);
    let mut seen = 0;
    let mut next = samples.iter().peekable();
    for tick in 0..=samples.last().unwrap().0 {
        let sample = next.next_if(|s| s.0 == tick).map(|s| &s.1);
        let Some(event) = recognizer.step(tick, sample) else {
            continue;
        };
        let found = recognizer.classify(recognizer.frames());
        match event {
            GestureEvent::Recognised {
                gesture, distance, ..
            } => {
                assert_eq!(found.nearest, Some((gesture, distance)));
            }
            GestureEvent::Rejected {
                nearest,
                distance,
                why,
                ..
            } => {
                assert_ne!(why, RejectReason::TooLong);
                assert_eq!(found.nearest.map(|n| n.0), nearest);
                assert_eq!(found.nearest.map_or(f64::INFINITY, |n| n.1), distance);
            }
        }
        seen += 1;
    }
    assert!(seen >= 2, "{seen}");
}

#[test]
fn gesture_a_sensor_without_gyros_cuts_nods_and_tilts_from_gravity() {
    let script = HeadScript::new()
        .rest(1000)
        .then(Move::new(Head::Nod))
        .rest(1000)
        .then(Move::new(Head::TiltLeft).held(1000))
        .rest(1000)
        .then(Move::new(Head::Shake))
        .rest(1000);
    let mut samples = recording(&script, 10, 12);
    for (_, s) in &mut samples {
        s.values[3..].fill(0.0);
    }
    let cut = segments(&config(), samples);
    // The nod and the tilt, each once; the shake is a turn about the
    // vertical, which leaves the gravity where it is: unseen.
    assert_eq!(cut.len(), 2, "{cut:?}");
    let nod_end = 1000 + Move::new(Head::Nod).duration_ms();
    assert!(cut[0].start < nod_end && cut[1].start > nod_end, "{cut:?}");
}
