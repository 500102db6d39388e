//! Validation by replay: the calibration's signal through the real burst
//! detector, and what it read for each prompted breath — the confusion
//! matrix of asked against detected.

use serde::Serialize;

use crate::control::action::Action;
use crate::control::detector::{Burst, BurstDetector, DetectorConfig, DetectorEvent};
use crate::fit::protocol::Ask;
use crate::fit::session::Answers;
use crate::fit::signal::Signal;

/// What the detector made of one prompted breath.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Read {
    /// One burst, of this action.
    As(Action),
    /// No burst.
    Missed,
    /// More than one burst (the breath was split).
    Split,
}

/// One row of the matrix: a prompt and how its breaths were read.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Row {
    /// What was asked.
    pub ask: Ask,
    /// Short puff, long puff, short sip, long sip, missed, split.
    pub counts: [usize; 6],
    /// Breaths read as asked (for a hold: a long breath of its kind).
    pub right: usize,
    /// Breaths asked.
    pub asked: usize,
}

/// The confusion matrix of a detector setting on a calibration.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConfusionMatrix {
    /// One row per prompt kind, in the protocol's order.
    pub rows: Vec<Row>,
    /// Bursts outside every prompted breath.
    pub unprompted: usize,
    /// Sensor faults the detector reported (a hold past `max_hold_ms` is
    /// one).
    pub faults: usize,
}

impl ConfusionMatrix {
    /// Breaths read right, of those asked.
    pub fn right(&self) -> (usize, usize) {
        self.rows
            .iter()
            .fold((0, 0), |(r, a), row| (r + row.right, a + row.asked))
    }
}

/// The columns' names.
pub const COLUMNS: [&str; 6] = [
    "short puff",
    "long puff",
    "short sip",
    "long sip",
    "missed",
    "split",
];

fn column(read: Read) -> usize {
    match read {
        Read::As(Action::ShortPuff) => 0,
        Read::As(Action::LongPuff) => 1,
        Read::As(Action::ShortSip) => 2,
        Read::As(Action::LongSip) => 3,
        Read::Missed => 4,
        Read::Split => 5,
    }
}

/// Whether `read` answers `ask` right.
fn is_right(ask: Ask, read: Read) -> bool {
    match (ask, read) {
        (Ask::Breath(a), Read::As(b)) => a == b,
        (Ask::Hold(breath), Read::As(b)) => b.breath() == breath && b.is_long(),
        _ => false,
    }
}

/// How far around a breath found its burst may lie, ms.
const SLACK_MS: u64 = 300;

/// Every burst and the number of faults `d` reports over `signal`.
pub fn bursts(signal: &Signal, d: &DetectorConfig) -> (Vec<Burst>, usize) {
    let mut detector = BurstDetector::new(d);
    let (mut bursts, mut faults) = (Vec::new(), 0);
    for (tick, &sample) in signal.samples.iter().enumerate() {
        match detector.step(tick as u64, sample).event {
            Some(DetectorEvent::Burst(b)) => bursts.push(b),
            Some(DetectorEvent::Fault(_)) => faults += 1,
            _ => {}
        }
    }
    (bursts, faults)
}

/// A breath found, as the matching sees it: its span, and which answer
/// it is (`None`: a breath not counted, of the wrong kind or extra).
struct Found {
    start: u64,
    end: u64,
    answer: Option<usize>,
}

/// The breath each burst reads: the one it overlaps most, or, if it
/// overlaps none, the nearest within [`SLACK_MS`]; `None` for a burst
/// near no breath. Matching by overlap, not by nearness alone, keeps a
/// sequence's breaths apart when they are closer than the slack.
fn owners(bursts: &[Burst], found: &[Found]) -> Vec<Option<usize>> {
    bursts
        .iter()
        .map(|b| {
            // `found` is in time order: only those that start before the
            // burst ends (with the slack) can be near it.
            let last = found.partition_point(|f| f.start < b.end + SLACK_MS);
            found[..last]
                .iter()
                .enumerate()
                .rev()
                .take_while(|(_, f)| f.end + 2 * SLACK_MS > b.start)
                .filter(|(_, f)| f.end + SLACK_MS > b.start)
                .map(|(i, f)| {
                    let overlap = b.end.min(f.end).saturating_sub(b.start.max(f.start));
                    let apart = f
                        .start
                        .saturating_sub(b.end)
                        .max(b.start.saturating_sub(f.end));
                    (i, overlap, apart)
                })
                .max_by(|x, y| x.1.cmp(&y.1).then(y.2.cmp(&x.2)))
                .map(|(i, _, _)| i)
        })
        .collect()
}

/// Replays the calibration through the detector with `d` and reads each
/// prompted breath: each burst reads the breath it overlaps most, so a
/// breath with no burst was missed and one with two or more was split.
pub fn confusion(
    signal: &Signal,
    answers: &Answers,
    asks: &[Ask],
    d: &DetectorConfig,
) -> ConfusionMatrix {
    let (bursts, faults) = bursts(signal, d);
    let mut found: Vec<Found> = answers
        .answers
        .iter()
        .enumerate()
        .map(|(i, a)| (Some(i), &a.region))
        .chain(answers.wrong.iter().map(|a| (None, &a.region)))
        .chain(answers.extra.iter().map(|r| (None, r)))
        .map(|(answer, r)| Found {
            start: r.start as u64,
            end: r.end as u64,
            answer,
        })
        .collect();
    found.sort_by_key(|f| f.start);
    let owners = owners(&bursts, &found);
    let mut read: Vec<Vec<Action>> = vec![Vec::new(); answers.answers.len()];
    let mut unprompted = 0;
    for (b, owner) in bursts.iter().zip(&owners) {
        match owner.map(|i| found[i].answer) {
            Some(Some(answer)) => read[answer].push(b.action),
            Some(None) => {}
            None => unprompted += 1,
        }
    }
    let mut rows: Vec<Row> = asks
        .iter()
        .map(|&ask| Row {
            ask,
            counts: [0; 6],
            right: 0,
            asked: 0,
        })
        .collect();
    for (answer, read) in answers.answers.iter().zip(&read) {
        let read = match read.as_slice() {
            [] => Read::Missed,
            [action] => Read::As(*action),
            _ => Read::Split,
        };
        if let Some(row) = rows.iter_mut().find(|r| r.ask == answer.ask) {
            row.counts[column(read)] += 1;
            row.asked += 1;
            row.right += usize::from(is_right(answer.ask, read));
        }
    }
    ConfusionMatrix {
        rows,
        unprompted,
        faults,
    }
}

/// How far a burst may lie outside the breath it reads, ms: a threshold
/// below the true one is crossed earlier on the rise (by at most part of
/// a ramp), and a sequence's breaths may be 200 ms apart.
const READ_SLACK_MS: u64 = 60;

/// Breaths read right: of the breaths meant (`(action, first tick, ms)`),
/// those one burst of the same action overlaps, and no other burst.
pub fn read_right(bursts: &[Burst], meant: &[(Action, u64, u64)]) -> usize {
    meant
        .iter()
        .filter(|&&(action, start, ms)| {
            let mut mine = bursts
                .iter()
                .filter(|b| b.start < start + ms + READ_SLACK_MS && b.end + READ_SLACK_MS > start);
            matches!((mine.next(), mine.next()), (Some(b), None) if b.action == action)
        })
        .count()
}
