//! The breaths found, matched to the protocol's prompts: which block each
//! breath answers, which were of the wrong kind, which blocks came short.
//!
//! The protocol alternates kinds in runs (puffs, sips, then the holds'
//! puffs and sips); within a run, blocks are split at the longest pause
//! nearest the expected count (between blocks the user rests at least
//! 3 s, between breaths 1–2 s).

use crate::control::action::Breath;
use crate::fit::breaths::{Found, Region};
use crate::fit::protocol::{Ask, BETWEEN_BLOCKS_MS, Protocol};
use crate::fit::signal::FitError;

/// A breath found and what it answered.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Answer {
    /// What the prompt asked for.
    pub ask: Ask,
    /// The breath.
    pub region: Region,
}

/// A session's breaths sorted by prompt.
#[derive(Debug, Clone, PartialEq)]
pub struct Answers {
    /// The breaths that answered a prompt, in time order.
    pub answers: Vec<Answer>,
    /// Breaths of the other kind inside a block (a sip when puffs were
    /// asked for): not counted.
    pub wrong_kind: Vec<Answer>,
    /// Breaths after the protocol's last block: not counted.
    pub extra: Vec<Region>,
    /// Plain-words notes on what did not follow the protocol.
    pub notes: Vec<String>,
}

impl Answers {
    /// The breaths that answered `ask`.
    pub fn of(&self, ask: Ask) -> impl Iterator<Item = &Region> + '_ {
        self.answers
            .iter()
            .filter(move |a| a.ask == ask)
            .map(|a| &a.region)
    }
}

/// A pause at least this long separates blocks, ms (the protocol asks for
/// ≥ 3 s; the stretches found end inside a breath's fall).
const BLOCK_PAUSE_MS: usize = (BETWEEN_BLOCKS_MS as usize) * 5 / 6;
/// Why no breath was found, with the rest's swing and the strongest
/// stretch after it, and what to try.
fn no_breath(found: &Found) -> FitError {
    let rest = &found.rest;
    let swing = found.opening_swing;
    let ms = crate::fit::breaths::MIN_BREATH_MS;
    if found.strongest > swing + 3.0 * rest.white_sd + 0.01 {
        FitError::new(format!(
            "no breath stands clear of the rest: at rest the signal swings up to {swing:.2} V from {:.2} V (noise sd {:.3} V; a tremor or hum shows as a swing far above it), and the strongest breath after it reached {:.2} V, too close to the swing to tell apart. Try a stronger breath, a more sensitive sensor, or head gestures instead of sip and puff",
            rest.level, rest.white_sd, found.strongest
        ))
    } else {
        FitError::new(format!(
            "no breath found after the rest: the signal stayed within {:.2} V of {:.2} V throughout (the rest swings up to {swing:.2} V; a breath must stay {:.2} V from it for {ms} ms). If the person breathed, check the tube and the sensor; if their breaths are this weak, try a more sensitive sensor or head gestures",
            found.strongest, rest.level, found.outside
        ))
    }
}

/// Fewer breaths than this in a block cannot be fitted.
pub const MIN_PER_BLOCK: usize = 3;

/// Matches the breaths found to the protocol's blocks.
pub fn answers(protocol: &Protocol, found: &Found) -> Result<Answers, FitError> {
    let (kept, wrong) = strays(&found.regions);
    let runs = runs(&kept);
    let wanted = kind_runs(protocol);
    let mut out = Answers {
        answers: Vec::new(),
        wrong_kind: Vec::new(),
        extra: Vec::new(),
        notes: Vec::new(),
    };
    if found.regions.is_empty() {
        return Err(no_breath(found));
    }
    if runs.len() < wanted.len() {
        let kinds: Vec<&str> = runs.iter().map(|r| kind_words(r[0].breath)).collect();
        return Err(FitError::new(format!(
            "the protocol asks for {} then {}, but the session has {}: was the whole protocol breathed, in its order?",
            wanted
                .iter()
                .take(wanted.len() - 1)
                .map(|(b, _)| kind_words(*b))
                .collect::<Vec<_>>()
                .join(", "),
            wanted.last().map_or("", |(b, _)| kind_words(*b)),
            kinds.join(" then ")
        )));
    }
    for (run, (breath, blocks)) in runs.iter().zip(&wanted) {
        if run[0].breath != *breath {
            return Err(FitError::new(format!(
                "breaths at {:.1} s are {} where the protocol asks for {}: was the protocol breathed in its order?",
                run[0].start as f64 / 1000.0,
                kind_words(run[0].breath),
                kind_words(*breath)
            )));
        }
        let counts: Vec<usize> = blocks.iter().map(|b| b.count as usize).collect();
        let cuts = cuts(run, &counts);
        let mut from = 0;
        for (i, block) in blocks.iter().enumerate() {
            let to = cuts.get(i).copied().unwrap_or(run.len());
            let got = to - from;
            if got != block.count as usize {
                out.notes.push(format!(
                    "{} {}s asked for, {got} found",
                    block.count,
                    block.ask.words()
                ));
            }
            if got < MIN_PER_BLOCK {
                return Err(FitError::new(format!(
                    "only {got} {}s found (at least {MIN_PER_BLOCK} are needed): breathe the block again, or check that those breaths pass the rest's noise",
                    block.ask.words()
                )));
            }
            out.answers
                .extend(run[from..to].iter().map(|&region| Answer {
                    ask: block.ask,
                    region,
                }));
            from = to;
        }
    }
    for run in runs.iter().skip(wanted.len()) {
        out.extra.extend(run.iter().copied());
    }
    if !out.extra.is_empty() {
        out.notes.push(format!(
            "{} breaths after the protocol's end were left out",
            out.extra.len()
        ));
    }
    for region in wrong {
        let ask = out
            .answers
            .iter()
            .rev()
            .find(|a| a.region.start < region.start)
            .or(out.answers.first())
            .map(|a| a.ask);
        if let Some(ask) = ask {
            out.notes.push(format!(
                "a {} at {:.1} s inside the {}s was left out",
                kind_words(region.breath),
                region.start as f64 / 1000.0,
                ask.words()
            ));
            out.wrong_kind.push(Answer { ask, region });
        }
    }
    Ok(out)
}

fn kind_words(breath: Breath) -> &'static str {
    match breath {
        Breath::Puff => "puffs",
        Breath::Sip => "sips",
    }
}

/// The protocol's blocks grouped into runs of one kind.
fn kind_runs(protocol: &Protocol) -> Vec<(Breath, Vec<crate::fit::protocol::Block>)> {
    let mut runs: Vec<(Breath, Vec<crate::fit::protocol::Block>)> = Vec::new();
    for block in &protocol.blocks {
        match runs.last_mut() {
            Some((breath, blocks)) if *breath == block.ask.breath() => blocks.push(*block),
            _ => runs.push((block.ask.breath(), vec![*block])),
        }
    }
    runs
}

/// Splits out breaths of the other kind that sit inside a run (one or two
/// of them with no block pause on either side): a wrong answer, not a new
/// block.
fn strays(regions: &[Region]) -> (Vec<Region>, Vec<Region>) {
    let mut kept: Vec<Region> = Vec::new();
    let mut wrong = Vec::new();
    let mut i = 0;
    while i < regions.len() {
        let r = regions[i];
        let mut j = i;
        while j < regions.len() && regions[j].breath == r.breath {
            j += 1;
        }
        let inside = i > 0
            && j < regions.len()
            && j - i <= 2
            && regions[i - 1].breath == regions[j].breath
            && regions[i].start - regions[i - 1].end < BLOCK_PAUSE_MS
            && regions[j].start - regions[j - 1].end < BLOCK_PAUSE_MS;
        if inside {
            wrong.extend_from_slice(&regions[i..j]);
        } else {
            kept.extend_from_slice(&regions[i..j]);
        }
        i = j;
    }
    (kept, wrong)
}

/// Consecutive breaths of one kind.
fn runs(regions: &[Region]) -> Vec<Vec<Region>> {
    let mut runs: Vec<Vec<Region>> = Vec::new();
    for &r in regions {
        match runs.last_mut() {
            Some(run) if run[0].breath == r.breath => run.push(r),
            _ => runs.push(vec![r]),
        }
    }
    runs
}

/// Where a run is cut into blocks of about `counts`: at each expected
/// boundary, the block pause nearest to it, or the count itself if there
/// is none.
fn cuts(run: &[Region], counts: &[usize]) -> Vec<usize> {
    let pauses: Vec<usize> = (1..run.len())
        .filter(|&i| run[i].start - run[i - 1].end >= BLOCK_PAUSE_MS)
        .collect();
    let mut cuts = Vec::new();
    let mut expected = 0;
    let mut previous = 0;
    for &count in counts.iter().take(counts.len().saturating_sub(1)) {
        expected += count;
        let cut = pauses
            .iter()
            .copied()
            .filter(|&p| p > previous)
            .min_by_key(|&p| p.abs_diff(expected))
            .unwrap_or(expected.min(run.len()))
            .max(previous);
        cuts.push(cut);
        previous = cut;
    }
    cuts
}
