//! The library that costs a person least: each entry placed on a sequence
//! so that the usage-weighted expected time per selection (wrong
//! selections priced at the time to notice and undo them) is smallest.
//!
//! Branch and bound over every assignment: the entries are placed most
//! used first; a partial library's bound is the cost of the placed
//! entries among themselves plus, for the rest, the cheapest sequences
//! left paired with the largest usages (a sum no completion can beat,
//! since adding entries only adds waits and confusions). Entries of equal
//! usage take sequences in one order only (swapping them changes
//! nothing). A greedy start improved by swaps and moves (local search)
//! gives the first incumbent; if time runs out first, the search says how
//! far the best library found can be from the best there is.

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use serde::Serialize;

use crate::design::analysis::{AttemptTiming, entry_cost, entry_cost_of};
use crate::design::breathing::Breathing;
use crate::design::reading::SequenceReading;
use crate::design::symbol::{Symbol, SymbolSeq};

/// What to place and under which rules.
#[derive(Debug, Clone)]
pub struct Problem {
    /// Each entry's share of selections.
    pub usage: Vec<f64>,
    /// Entries that keep their sequence, by index.
    pub fixed: Vec<Option<SymbolSeq>>,
    /// The sequences an entry may take.
    pub candidates: Vec<SymbolSeq>,
    /// Whose breathing.
    pub who: Breathing,
    /// The times of an attempt.
    pub timing: AttemptTiming,
    /// When to stop branching and report the bound.
    pub time_limit: Duration,
}

/// Every sequence of up to `max` of the allowed bursts and gestures, at
/// least `min` long if it is bursts alone: a cough or sigh is a burst,
/// while a gesture is a deliberate movement the recognizer checks, so
/// one gesture alone may select.
pub fn candidates(allowed: &[Symbol], min: usize, max: usize) -> Vec<SymbolSeq> {
    let mut out = Vec::new();
    let mut layer: Vec<Vec<Symbol>> = vec![Vec::new()];
    for len in 1..=max {
        layer = layer
            .iter()
            .flat_map(|s| {
                allowed.iter().map(move |a| {
                    let mut s = s.clone();
                    s.push(*a);
                    s
                })
            })
            .collect();
        out.extend(
            layer
                .iter()
                .filter(|s| len >= min || s.iter().any(|x| x.action().is_none()))
                .filter_map(|s| SymbolSeq::from_slice(s)),
        );
    }
    out
}

/// The search's result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SearchResult {
    /// Each entry's sequence, in the problem's order.
    #[serde(skip)]
    pub sequences: Vec<SymbolSeq>,
    /// Its cost: usage-weighted expected ms per selection.
    pub cost_ms: f64,
    /// No library costs less than this, ms.
    pub bound_ms: f64,
    /// The whole space was searched (the cost is the least there is).
    pub complete: bool,
    /// Partial libraries looked at.
    pub nodes: u64,
    /// How long it took, s.
    pub seconds: f64,
    /// The cost of the greedy start improved by local search, ms.
    pub local_search_ms: f64,
}

impl SearchResult {
    /// How far the cost can be above the best there is, percent.
    pub fn gap_pct(&self) -> f64 {
        if self.cost_ms > 0.0 {
            100.0 * (self.cost_ms - self.bound_ms).max(0.0) / self.cost_ms
        } else {
            0.0
        }
    }
}

/// The library's cost: usage-weighted expected ms per selection.
pub fn cost(p: &Problem, sequences: &[SymbolSeq]) -> f64 {
    let library: Vec<&[Symbol]> = sequences.iter().map(SymbolSeq::as_slice).collect();
    (0..library.len())
        .map(|i| p.usage[i] * entry_cost(i, &library, &p.who, &p.timing, |_, _, _| {}).expected_ms)
        .sum()
}

/// Threads the branching runs on.
const THREADS: usize = 2;

/// The sequences the search places and each one's readings, computed once.
struct Space<'a> {
    p: &'a Problem,
    /// The free candidates, then each fixed entry's sequence.
    sequences: Vec<SymbolSeq>,
    readings: Vec<Vec<SequenceReading>>,
    /// How many of `sequences` are free candidates.
    free: usize,
    /// Entries placed most used first (fixed ones excluded).
    order: Vec<usize>,
    /// Whether a thread took each job (a branch of the second entry).
    jobs: Vec<AtomicBool>,
}

impl Space<'_> {
    /// The cost of `placed` (indices into `sequences`) among themselves:
    /// each placed entry's usage-weighted cost, and each unused free
    /// candidate's cost as the next entry.
    fn partial(&self, placed: &[Option<usize>], used: &[bool]) -> (f64, Vec<(usize, f64)>) {
        let p = self.p;
        let entries: Vec<(usize, usize)> = placed
            .iter()
            .enumerate()
            .filter_map(|(i, s)| s.map(|s| (i, s)))
            .collect();
        let mut library: Vec<&[Symbol]> = entries
            .iter()
            .map(|(_, s)| self.sequences[*s].as_slice())
            .collect();
        let placed_cost: f64 = entries
            .iter()
            .enumerate()
            .map(|(k, (i, s))| {
                p.usage[*i]
                    * entry_cost_of(
                        &self.readings[*s],
                        k,
                        &library,
                        &p.who,
                        &p.timing,
                        |_, _, _| {},
                    )
                    .expected_ms
            })
            .sum();
        let k = library.len();
        let mut costs = Vec::with_capacity(self.free);
        for (c, _) in used.iter().enumerate().filter(|(_, used)| !**used) {
            library.push(self.sequences[c].as_slice());
            let cost = entry_cost_of(
                &self.readings[c],
                k,
                &library,
                &p.who,
                &p.timing,
                |_, _, _| {},
            );
            costs.push((c, cost.expected_ms));
            library.pop();
        }
        (placed_cost, costs)
    }
}

/// Finds the cheapest library: exact if the time allows. Of libraries
/// of equal cost it gives the first in [`before`]'s order, so a complete
/// search gives the same library however its threads interleave.
pub fn search(p: &Problem) -> SearchResult {
    search_on(p, THREADS)
}

/// Whether library `a` of cost `a_cost` comes before `b`: cheaper, or as
/// cheap and its sequences first, entry by entry, burst by burst (a total
/// order, so the library kept does not depend on which is found first).
fn before(a_cost: f64, a: &[SymbolSeq], b_cost: f64, b: &[SymbolSeq]) -> bool {
    a_cost
        .total_cmp(&b_cost)
        .then_with(|| {
            a.iter()
                .map(SymbolSeq::as_slice)
                .cmp(b.iter().map(SymbolSeq::as_slice))
        })
        .is_lt()
}

/// A partial library is cut off when its bound is above the best cost by
/// more than this share: the bound sums the same terms in another order,
/// so a library as cheap as the best (a tie) is never cut off by
/// rounding.
const ROUNDING: f64 = 1e-9;

/// [`search`] on `threads` threads.
pub(crate) fn search_on(p: &Problem, threads: usize) -> SearchResult {
    let started = Instant::now();
    let n = p.usage.len();
    let mut order: Vec<usize> = (0..n).filter(|i| p.fixed[*i].is_none()).collect();
    order.sort_by(|a, b| p.usage[*b].total_cmp(&p.usage[*a]).then(a.cmp(b)));
    let mut sequences: Vec<SymbolSeq> = p
        .candidates
        .iter()
        .filter(|c| !p.fixed.iter().any(|f| f.as_ref() == Some(c)))
        .copied()
        .collect();
    let free = sequences.len();
    let mut placed: Vec<Option<usize>> = vec![None; n];
    for (i, f) in p.fixed.iter().enumerate() {
        if let Some(seq) = f {
            placed[i] = Some(sequences.len());
            sequences.push(*seq);
        }
    }
    let readings = sequences
        .iter()
        .map(|s| crate::design::reading::readings(s.as_slice(), &p.who))
        .collect();
    let space = Space {
        p,
        sequences,
        readings,
        free,
        order,
        jobs: (0..free * free).map(|_| AtomicBool::new(false)).collect(),
    };
    let start = local_search(p, &space.order, &space.sequences[..free]);
    let local_search_ms = cost(p, &start);
    let best = Shared {
        cost: AtomicU64::new(local_search_ms.to_bits()),
        library: Mutex::new(start),
    };
    let deadline = started + p.time_limit;
    let results: Vec<(u64, bool, f64)> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads.max(1))
            .map(|_| {
                let (space, best, placed) = (&space, &best, placed.clone());
                scope.spawn(move || {
                    let mut b = Branch {
                        space,
                        best,
                        nodes: 0,
                        deadline,
                        aborted: false,
                        open_bound: f64::INFINITY,
                        seen: 0,
                    };
                    let mut placed = placed;
                    let mut used = vec![false; space.free];
                    b.branch(0, &mut placed, &mut used, None);
                    (b.nodes, b.aborted, b.open_bound)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap_or((0, true, 0.0)))
            .collect()
    });
    let best_cost = f64::from_bits(best.cost.load(Ordering::Relaxed));
    let aborted = results.iter().any(|r| r.1);
    let open_bound = results.iter().map(|r| r.2).fold(f64::INFINITY, f64::min);
    let sequences = best
        .library
        .into_inner()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    SearchResult {
        cost_ms: best_cost,
        sequences,
        bound_ms: if aborted {
            open_bound.min(best_cost)
        } else {
            best_cost
        },
        complete: !aborted,
        nodes: results.iter().map(|r| r.0).sum(),
        seconds: started.elapsed().as_secs_f64(),
        local_search_ms,
    }
}

/// The best library so far, shared by the threads.
struct Shared {
    /// Its cost's bits (positive costs order as their bits do).
    cost: AtomicU64,
    library: Mutex<Vec<SymbolSeq>>,
}

struct Branch<'a> {
    space: &'a Space<'a>,
    best: &'a Shared,
    nodes: u64,
    deadline: Instant,
    aborted: bool,
    /// The least bound of the partial libraries left unexplored.
    open_bound: f64,
    /// Jobs this thread has passed.
    seen: usize,
}

impl Branch<'_> {
    /// Whether this thread takes the next job (no other thread has).
    fn take_job(&mut self) -> bool {
        let job = self.seen;
        self.seen += 1;
        self.space
            .jobs
            .get(job)
            .is_some_and(|taken| !taken.swap(true, Ordering::Relaxed))
    }

    fn best_cost(&self) -> f64 {
        f64::from_bits(self.best.cost.load(Ordering::Relaxed))
    }

    /// Places `order[depth..]`; `previous` is the candidate the entry
    /// before took.
    fn branch(
        &mut self,
        depth: usize,
        placed: &mut Vec<Option<usize>>,
        used: &mut [bool],
        previous: Option<usize>,
    ) {
        self.nodes += 1;
        let space = self.space;
        if depth == space.order.len() {
            let sequences: Vec<SymbolSeq> = placed
                .iter()
                .map(|s| s.map_or_else(SymbolSeq::default, |s| space.sequences[s]))
                .collect();
            let c = cost(space.p, &sequences);
            if c <= self.best_cost() {
                let mut library = self
                    .best
                    .library
                    .lock()
                    .unwrap_or_else(std::sync::PoisonError::into_inner);
                if before(c, &sequences, self.best_cost(), &library) {
                    self.best.cost.store(c.to_bits(), Ordering::Relaxed);
                    *library = sequences;
                }
            }
            return;
        }
        let (placed_cost, mut candidate_costs) = space.partial(placed, used);
        candidate_costs.sort_by(|a, b| a.1.total_cmp(&b.1));
        let entry = space.order[depth];
        // The usages still to place after this entry, largest first.
        let rest: Vec<f64> = space.order[depth + 1..]
            .iter()
            .map(|i| space.p.usage[*i])
            .collect();
        let same_as_before =
            depth > 0 && space.p.usage[space.order[depth - 1]] == space.p.usage[entry];
        for (rank, &(c, c_cost)) in candidate_costs.iter().enumerate() {
            if same_as_before && previous.is_some_and(|p| c <= p) {
                continue;
            }
            // The second entry's branches are the threads' jobs: every
            // thread walks the first level alike, so they number the jobs
            // alike, and each job goes to the first thread to reach it.
            if depth == 1 && !self.take_job() {
                continue;
            }
            // This entry on `c`, the rest on the cheapest others (adding
            // `c` can only make them and the placed entries dearer).
            let others = candidate_costs
                .iter()
                .enumerate()
                .filter(|(r, _)| *r != rank)
                .map(|(_, (_, cost))| *cost);
            let bound = placed_cost
                + space.p.usage[entry] * c_cost
                + rest.iter().zip(others).map(|(u, c)| u * c).sum::<f64>();
            if depth > 0 && bound > self.best_cost() * (1.0 + ROUNDING) {
                continue;
            }
            if self.aborted || (self.nodes.is_multiple_of(64) && Instant::now() >= self.deadline) {
                self.aborted = true;
                self.open_bound = self.open_bound.min(bound);
                continue;
            }
            placed[entry] = Some(c);
            used[c] = true;
            self.branch(depth + 1, placed, used, Some(c));
            placed[entry] = None;
            used[c] = false;
        }
    }
}

/// A greedy library (most used entry on the cheapest sequence left),
/// then swaps of two entries and moves to unused sequences while any
/// lowers the cost.
fn local_search(p: &Problem, order: &[usize], free: &[SymbolSeq]) -> Vec<SymbolSeq> {
    let mut sequences: Vec<SymbolSeq> = p.fixed.iter().map(|f| f.unwrap_or_default()).collect();
    let mut taken = vec![false; free.len()];
    for &entry in order {
        let mut placed: Vec<&[Symbol]> = (0..sequences.len())
            .filter(|i| {
                p.fixed[*i].is_some() || order.iter().take_while(|o| **o != entry).any(|o| o == i)
            })
            .map(|i| sequences[i].as_slice())
            .collect();
        let k = placed.len();
        let mut best = (usize::MAX, f64::INFINITY);
        for (c, seq) in free.iter().enumerate() {
            if taken[c] {
                continue;
            }
            placed.push(seq.as_slice());
            let e = entry_cost(k, &placed, &p.who, &p.timing, |_, _, _| {}).expected_ms;
            placed.pop();
            if e < best.1 {
                best = (c, e);
            }
        }
        if best.0 != usize::MAX {
            taken[best.0] = true;
            sequences[entry] = free[best.0];
        }
    }
    let mut current = cost(p, &sequences);
    loop {
        let mut improved = false;
        for a in 0..order.len() {
            for b in a + 1..order.len() {
                let (i, j) = (order[a], order[b]);
                sequences.swap(i, j);
                let c = cost(p, &sequences);
                if c < current - 1e-9 {
                    current = c;
                    improved = true;
                } else {
                    sequences.swap(i, j);
                }
            }
            let i = order[a];
            for seq in free {
                if sequences.contains(seq) {
                    continue;
                }
                let old = sequences[i];
                sequences[i] = *seq;
                let new = cost(p, &sequences);
                if new < current - 1e-9 {
                    current = new;
                    improved = true;
                } else {
                    sequences[i] = old;
                }
            }
        }
        if !improved {
            return sequences;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;
    use crate::control::action::Action;
    use crate::control::detector::DetectorConfig;
    use crate::control::selection::SequenceEntry;
    use crate::sim::user::UserModel;
    use proptest::prelude::*;

    fn problem(usage: Vec<f64>, allowed: &[Action], min: usize, max: usize) -> Problem {
        let who = Breathing::of_model(&UserModel::POPULATION, &DetectorConfig::default(), "x");
        let timing = AttemptTiming::of(&who, &Config::default(), None);
        Problem {
            fixed: vec![None; usage.len()],
            usage,
            candidates: candidates(
                &allowed
                    .iter()
                    .map(|a| Symbol::burst(*a))
                    .collect::<Vec<_>>(),
                min,
                max,
            ),
            who,
            timing,
            time_limit: Duration::from_secs(600),
        }
    }

    /// The least cost over every assignment, by trying them all, and of
    /// the libraries that cost it the first in order.
    fn exhaustive(p: &Problem) -> (f64, Vec<SymbolSeq>) {
        fn place(p: &Problem, chosen: &mut Vec<SymbolSeq>, best: &mut (f64, Vec<SymbolSeq>)) {
            if chosen.len() == p.usage.len() {
                let c = cost(p, chosen);
                if before(c, chosen, best.0, &best.1) {
                    *best = (c, chosen.clone());
                }
                return;
            }
            for c in &p.candidates {
                if !chosen.contains(c) {
                    chosen.push(*c);
                    place(p, chosen, best);
                    chosen.pop();
                }
            }
        }
        let mut best = (f64::INFINITY, Vec::new());
        place(p, &mut Vec::new(), &mut best);
        best
    }

    #[test]
    fn branch_and_bound_finds_what_trying_every_library_finds() {
        let short_and_long_puffs = [Action::ShortPuff, Action::LongPuff, Action::ShortSip];
        // Short sips and puffs alone: every library has its mirror, sips
        // and puffs swapped, exactly as cheap; the first in order is kept.
        // (Elsewhere libraries equal in law differ by rounding, and the
        // cheaper by rounding is kept.)
        let short_only = [Action::ShortPuff, Action::ShortSip];
        for (usage, allowed, mirrored) in [
            (vec![0.4, 0.3, 0.2, 0.1], &short_and_long_puffs[..], false),
            (vec![0.25; 4], &short_and_long_puffs[..], false),
            (vec![0.4, 0.3, 0.2, 0.1], &short_only[..], true),
        ] {
            let p = problem(usage, allowed, 1, 2);
            let found = search(&p);
            assert!(found.complete);
            let (truth, library) = exhaustive(&p);
            assert!(
                (found.cost_ms - truth).abs() < 1e-9,
                "{} vs {truth}",
                found.cost_ms
            );
            if mirrored {
                assert_eq!(found.sequences, library);
            }
            assert_eq!(found.bound_ms, found.cost_ms);
        }
    }

    #[test]
    fn out_of_time_it_reports_a_bound_below_its_cost() {
        let mut p = problem(vec![1.0 / 12.0; 12], &Action::ALL, 2, 3);
        p.time_limit = Duration::ZERO;
        let found = search(&p);
        assert!(!found.complete);
        assert!(found.bound_ms < found.cost_ms, "{found:?}");
        assert!(found.gap_pct() > 0.0);
    }

    #[test]
    fn one_gesture_alone_is_a_sequence_one_burst_alone_is_not() {
        let nod = Symbol::gesture(0).unwrap();
        let allowed = [Action::ShortSip.into(), Action::ShortPuff.into(), nod];
        let found = candidates(&allowed, 2, 2);
        // The nod alone; then of two items, all nine (the four of bursts
        // alone among them).
        assert_eq!(found.len(), 1 + 9);
        assert_eq!(found[0].as_slice(), [nod]);
        assert!(found.iter().all(|s| s.len() == 2 || s.as_slice() == [nod]));
    }

    #[test]
    fn of_equally_cheap_libraries_the_first_in_order_is_kept() {
        use Action::{LongPuff, ShortPuff, ShortSip};
        let seq = |a: &[Action]| SymbolSeq::from_slice(a).unwrap();
        let a = [seq(&[ShortSip, ShortPuff]), seq(&[ShortPuff, ShortSip])];
        let b = [seq(&[ShortSip, LongPuff]), seq(&[ShortPuff, ShortSip])];
        assert_eq!(ShortSip.cmp(&ShortPuff), std::cmp::Ordering::Less);
        assert!(before(1430.0, &a, 1430.0, &b) != before(1430.0, &b, 1430.0, &a));
        assert!(!before(1430.0, &a, 1430.0, &a));
        assert!(before(1429.0, &b, 1430.0, &a));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(16))]
        /// Whatever the constraints, the library proposed is one the
        /// validator accepts: every sequence distinct, of allowed bursts
        /// and lengths, the fixed entries on their own.
        #[test]
        fn the_designer_proposes_only_valid_libraries(
            allowed in prop::sample::subsequence(Action::ALL.to_vec(), 2..=4),
            keep_first in any::<bool>(),
            max in 2usize..=3,
        ) {
            let config = Config::default();
            let library = config.core().sequences();
            let mut p = problem(vec![1.0 / 9.0; 9], &allowed, 2, max);
            p.time_limit = Duration::from_millis(200);
            let first = library[0].breaths().and_then(|b| SymbolSeq::from_slice(b.as_slice()));
            if keep_first {
                p.fixed[0] = first;
            }
            prop_assume!(p.candidates.len() >= 9);
            let found = search(&p);
            let designed: Vec<SequenceEntry> = library
                .iter()
                .zip(&found.sequences)
                .map(|(e, s)| SequenceEntry { actions: p.who.tokens(s), target: e.target })
                .collect();
            prop_assert!(config.clone().with_sequences(designed).is_ok());
            for (i, s) in found.sequences.iter().enumerate() {
                prop_assert!(found.sequences[..i].iter().all(|t| t != s));
                if keep_first && i == 0 {
                    prop_assert_eq!(Some(*s), first);
                } else {
                    prop_assert!((2..=max).contains(&s.len()));
                    prop_assert!(s.as_slice().iter().all(|a| a.action().is_some_and(|a| allowed.contains(&a))));
                }
            }
            prop_assert!(found.bound_ms <= found.cost_ms);
        }
    }
}
