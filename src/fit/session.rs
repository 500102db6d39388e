//! The breaths found, matched to the protocol's blocks: which block each
//! breath answers, which were not what their block asked for, which
//! blocks came short or long.
//!
//! Blocks are told apart by the pauses between them (the protocol rests
//! at least 3 s between blocks, 1–2 s between breaths). When the pauses
//! do not give one stretch per block, the breaths are read in runs of one
//! kind (puffs, sips, then the holds' puffs and sips), each run cut into
//! blocks at the block pause nearest the expected count.
//!
//! What can be fitted honestly is: a block between clear pauses holding
//! more or fewer breaths than asked, all of the kind and length asked (a
//! note); a breath of the other kind or length that the person made up
//! for, as the live guide asks them to (left out, a note). A wrong breath
//! not made up for, or a miscount with no pause to show where the block
//! lies, is an error naming the block and the breath.

use crate::control::action::Breath;
use crate::fit::breaths::{Found, Region};
use crate::fit::protocol::{Ask, BETWEEN_BLOCKS_MS, Block, Protocol};
use crate::fit::signal::FitError;
use crate::fit::stats;

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
    /// Breaths inside a block that were not what it asked for (a sip
    /// where puffs were asked, a short breath where long ones were), made
    /// up for by the block's other breaths: not counted.
    pub wrong: Vec<Answer>,
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
/// Short and long breaths of a kind are told apart only when their
/// blocks' typical lengths are at least this far apart (a ratio): closer
/// than that, their overlap is the fit's to measure, not an error.
const LENGTHS_APART: f64 = 2.5;

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

/// One block's breaths as found.
struct Placed {
    /// Every breath found in the block, of any kind, in time order.
    regions: Vec<Region>,
    /// Whether a block pause, a change of kind or the session's edge
    /// marks both its ends.
    bounded: bool,
}

/// Matches the breaths found to the protocol's blocks.
pub fn answers(protocol: &Protocol, found: &Found) -> Result<Answers, FitError> {
    if found.regions.is_empty() {
        return Err(no_breath(found));
    }
    let (placed, extra) = match by_pauses(protocol, &found.regions) {
        Some(placed) => (placed, Vec::new()),
        None => by_runs(protocol, found)?,
    };
    let mut out = Answers {
        answers: Vec::new(),
        wrong: Vec::new(),
        extra,
        notes: Vec::new(),
    };
    for (i, (block, here)) in protocol.blocks.iter().zip(&placed).enumerate() {
        let boundary = boundary(protocol, &placed, i);
        check_block(i, block, here, boundary, &mut out)?;
    }
    if !out.extra.is_empty() {
        out.notes.push(format!(
            "{} breaths after the protocol's end were left out",
            out.extra.len()
        ));
    }
    Ok(out)
}

/// Sorts one block's breaths into answers and wrong ones, or says why
/// the block cannot be fitted. `boundary`: the length between this
/// kind's short and long breaths, ms, when they stand apart.
fn check_block(
    i: usize,
    block: &Block,
    here: &Placed,
    boundary: Option<f64>,
    out: &mut Answers,
) -> Result<(), FitError> {
    let named = format!("block {} ({}s)", i + 1, block.ask.words());
    let asked = block.count as usize;
    let mut right = Vec::new();
    let mut wrong = Vec::new();
    for (n, region) in here.regions.iter().enumerate() {
        match not_asked(block.ask, region, boundary, here) {
            Some(what) => wrong.push((n + 1, region, what)),
            None => right.push(*region),
        }
    }
    for (n, region, what) in &wrong {
        let said = format!(
            "{named}, breath {n} at {:.1} s: {what} where a {} was asked",
            seconds(region),
            block.ask.words()
        );
        if right.len() < asked {
            return Err(FitError::new(format!(
                "{said}, and without it the block has {} where {asked} were asked: record the calibration again",
                breaths(right.len(), &format!("{}s", block.ask.words()))
            )));
        }
        out.notes.push(format!(
            "{said}, left out (the block has its {asked} without it)"
        ));
        out.wrong.push(Answer {
            ask: block.ask,
            region: **region,
        });
    }
    let got = right.len();
    if got < MIN_PER_BLOCK {
        return Err(FitError::new(format!(
            "{named}: {} where {asked} were asked (at least {MIN_PER_BLOCK} are needed): record the calibration again, or check that those breaths pass the rest's noise",
            breaths(got, "breaths")
        )));
    }
    if got != asked {
        if !here.bounded {
            return Err(FitError::new(format!(
                "{named}: {} where {asked} were asked, and no pause of {} s marks where the block begins or ends: record the calibration again, resting {} s between blocks",
                breaths(got, "breaths"),
                BETWEEN_BLOCKS_MS / 1000,
                BETWEEN_BLOCKS_MS / 1000
            )));
        }
        out.notes.push(format!(
            "{named}: {} where {asked} were asked (fitted from the {got})",
            breaths(got, "breaths")
        ));
    }
    out.answers.extend(right.into_iter().map(|region| Answer {
        ask: block.ask,
        region,
    }));
    Ok(())
}

/// What `region` was, if not what `ask` asked for: "a sip", or "a short
/// puff (150 ms; the block's others 790–810 ms)".
fn not_asked(ask: Ask, region: &Region, boundary: Option<f64>, here: &Placed) -> Option<String> {
    if region.breath != ask.breath() {
        return Some(format!("a {}", breath_word(region.breath)));
    }
    let (Ask::Breath(action), Some(boundary)) = (ask, boundary) else {
        return None;
    };
    let long = ms(region) >= boundary;
    if long == action.is_long() {
        return None;
    }
    let others: Vec<f64> = (here.regions.iter())
        .filter(|r| r.breath == region.breath && (ms(r) >= boundary) == action.is_long())
        .map(ms)
        .collect();
    let range = match (
        others.iter().copied().reduce(f64::min),
        others.iter().copied().reduce(f64::max),
    ) {
        (Some(low), Some(high)) => format!("; the block's others {low:.0}–{high:.0} ms"),
        _ => String::new(),
    };
    Some(format!(
        "a {} {} ({:.0} ms{range})",
        if long { "long" } else { "short" },
        breath_word(region.breath),
        ms(region)
    ))
}

/// The length between block `i`'s breaths and its partner's (the same
/// kind, the other length), ms: the geometric mean of their blocks'
/// median lengths, when those are [`LENGTHS_APART`].
fn boundary(protocol: &Protocol, placed: &[Placed], i: usize) -> Option<f64> {
    let Ask::Breath(action) = protocol.blocks[i].ask else {
        return None;
    };
    let partner = protocol
        .blocks
        .iter()
        .position(|b| matches!(b.ask, Ask::Breath(a) if a.breath() == action.breath() && a.is_long() != action.is_long()))?;
    let typical = |j: usize| {
        let lengths: Vec<f64> = (placed.get(j)?.regions.iter())
            .filter(|r| r.breath == action.breath())
            .map(ms)
            .collect();
        (lengths.len() >= MIN_PER_BLOCK).then(|| stats::median(&lengths))
    };
    let (mine, theirs) = (typical(i)?, typical(partner)?);
    let (short, long) = if action.is_long() {
        (theirs, mine)
    } else {
        (mine, theirs)
    };
    (long >= LENGTHS_APART * short).then(|| (short * long).sqrt())
}

/// A breath's length as found, ms.
fn ms(region: &Region) -> f64 {
    (region.end - region.start) as f64
}

/// When a breath began, s from the session's start.
fn seconds(region: &Region) -> f64 {
    region.start as f64 / 1000.0
}

/// "1 breath", "7 long puffs".
fn breaths(n: usize, plural: &str) -> String {
    if n == 1 {
        format!("1 {}", plural.strip_suffix('s').unwrap_or(plural))
    } else {
        format!("{n} {plural}")
    }
}

fn breath_word(breath: Breath) -> &'static str {
    match breath {
        Breath::Puff => "puff",
        Breath::Sip => "sip",
    }
}

/// The blocks as the pauses show them: one stretch between block pauses
/// per block, each mostly of its block's kind; `None` otherwise.
fn by_pauses(protocol: &Protocol, regions: &[Region]) -> Option<Vec<Placed>> {
    let mut stretches: Vec<Vec<Region>> = Vec::new();
    for &r in regions {
        match stretches.last_mut() {
            Some(s) if !pause_before(&r, s.last()) => s.push(r),
            _ => stretches.push(vec![r]),
        }
    }
    let fits = stretches.len() == protocol.blocks.len()
        && (stretches.iter().zip(&protocol.blocks))
            .all(|(s, b)| 2 * s.iter().filter(|r| r.breath == b.ask.breath()).count() > s.len());
    fits.then(|| {
        stretches
            .into_iter()
            .map(|regions| Placed {
                regions,
                bounded: true,
            })
            .collect()
    })
}

/// Whether a block pause comes before `r` (after `before`).
fn pause_before(r: &Region, before: Option<&Region>) -> bool {
    before.is_none_or(|b| r.start.saturating_sub(b.end) >= BLOCK_PAUSE_MS)
}

/// The blocks as runs of one kind show them, each run cut at the pauses
/// nearest the expected counts, and the breaths after the last block.
fn by_runs(protocol: &Protocol, found: &Found) -> Result<(Vec<Placed>, Vec<Region>), FitError> {
    let (kept, strays) = strays(&found.regions);
    let runs = runs(&kept);
    let wanted = kind_runs(protocol);
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
    let mut placed: Vec<Placed> = Vec::new();
    for (run, (breath, blocks)) in runs.iter().zip(&wanted) {
        if run[0].breath != *breath {
            return Err(FitError::new(format!(
                "breaths at {:.1} s are {} where the protocol asks for {}: was the protocol breathed in its order?",
                seconds(&run[0]),
                kind_words(run[0].breath),
                kind_words(*breath)
            )));
        }
        let counts: Vec<usize> = blocks.iter().map(|b| b.count as usize).collect();
        let cuts = cuts(run, &counts);
        let mut from = 0;
        for i in 0..blocks.len() {
            let to = cuts.get(i).copied().unwrap_or(run.len());
            let at_pause =
                |at: usize| at == 0 || at >= run.len() || pause_before(&run[at], run.get(at - 1));
            placed.push(Placed {
                regions: run[from..to].to_vec(),
                bounded: at_pause(from) && at_pause(to),
            });
            from = to;
        }
    }
    // A stray belongs to the block of the breath before it.
    for stray in strays {
        let block = (placed.iter())
            .rposition(|p| p.regions.first().is_some_and(|r| r.start < stray.start))
            .unwrap_or(0);
        let regions = &mut placed[block].regions;
        regions.push(stray);
        regions.sort_by_key(|r| r.start);
    }
    let extra = runs.iter().skip(wanted.len()).flatten().copied().collect();
    Ok((placed, extra))
}

fn kind_words(breath: Breath) -> &'static str {
    match breath {
        Breath::Puff => "puffs",
        Breath::Sip => "sips",
    }
}

/// The protocol's blocks grouped into runs of one kind.
fn kind_runs(protocol: &Protocol) -> Vec<(Breath, Vec<Block>)> {
    let mut runs: Vec<(Breath, Vec<Block>)> = Vec::new();
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
