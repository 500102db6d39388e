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

/// Replays the calibration through the detector with `d` and reads each
/// prompted breath.
pub fn confusion(
    signal: &Signal,
    answers: &Answers,
    asks: &[Ask],
    d: &DetectorConfig,
) -> ConfusionMatrix {
    let (bursts, faults) = bursts(signal, d);
    let mut used = vec![false; bursts.len()];
    let mut rows: Vec<Row> = asks
        .iter()
        .map(|&ask| Row {
            ask,
            counts: [0; 6],
            right: 0,
            asked: 0,
        })
        .collect();
    for answer in &answers.answers {
        let (from, to) = (
            (answer.region.start as u64).saturating_sub(SLACK_MS),
            answer.region.end as u64 + SLACK_MS,
        );
        let mut mine = bursts
            .iter()
            .enumerate()
            .filter(|(_, b)| b.start < to && b.end > from);
        let read = match (mine.next(), mine.next()) {
            (None, _) => Read::Missed,
            (Some((i, b)), None) => {
                used[i] = true;
                Read::As(b.action)
            }
            (Some((i, _)), Some((j, _))) => {
                used[i] = true;
                used[j] = true;
                Read::Split
            }
        };
        if let Some(row) = rows.iter_mut().find(|r| r.ask == answer.ask) {
            row.counts[column(read)] += 1;
            row.asked += 1;
            row.right += usize::from(is_right(answer.ask, read));
        }
    }
    let wrong_kind: Vec<(u64, u64)> = answers
        .wrong_kind
        .iter()
        .map(|a| (a.region.start as u64, a.region.end as u64))
        .chain(answers.extra.iter().map(|r| (r.start as u64, r.end as u64)))
        .collect();
    let unprompted = bursts
        .iter()
        .zip(&used)
        .filter(|(b, used)| {
            !**used
                && !wrong_kind
                    .iter()
                    .any(|&(s, e)| b.start < e + SLACK_MS && b.end + SLACK_MS > s)
        })
        .count();
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
