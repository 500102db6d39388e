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

use std::time::{Duration, Instant};

use serde::Serialize;

use crate::control::action::{Action, ActionSeq};
use crate::design::analysis::{Timing, entry_cost};
use crate::design::breathing::Breathing;

/// What to place and under which rules.
#[derive(Debug, Clone)]
pub struct Problem {
    /// Each entry's share of selections.
    pub usage: Vec<f64>,
    /// Entries that keep their sequence, by index.
    pub fixed: Vec<Option<ActionSeq>>,
    /// The sequences an entry may take.
    pub candidates: Vec<ActionSeq>,
    /// Whose breathing.
    pub who: Breathing,
    /// The times of an attempt.
    pub timing: Timing,
    /// When to stop branching and report the bound.
    pub time_limit: Duration,
}

/// Every sequence of `min..=max` bursts of the allowed kinds.
pub fn candidates(allowed: &[Action], min: usize, max: usize) -> Vec<ActionSeq> {
    let mut out = Vec::new();
    let mut layer: Vec<Vec<Action>> = vec![Vec::new()];
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
        if len >= min {
            out.extend(layer.iter().filter_map(|s| ActionSeq::from_slice(s)));
        }
    }
    out
}

/// The search's result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Found {
    /// Each entry's sequence, in the problem's order.
    #[serde(skip)]
    pub sequences: Vec<ActionSeq>,
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

impl Found {
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
pub fn cost(p: &Problem, sequences: &[ActionSeq]) -> f64 {
    let library: Vec<&[Action]> = sequences.iter().map(ActionSeq::as_slice).collect();
    (0..library.len())
        .map(|i| p.usage[i] * entry_cost(i, &library, &p.who, &p.timing, |_, _, _| {}).expected_ms)
        .sum()
}

/// Finds the cheapest library: exact if the time allows.
pub fn search(p: &Problem) -> Found {
    let started = Instant::now();
    let n = p.usage.len();
    // Most used first; fixed entries are placed from the start.
    let mut order: Vec<usize> = (0..n).filter(|i| p.fixed[*i].is_none()).collect();
    order.sort_by(|a, b| p.usage[*b].total_cmp(&p.usage[*a]).then(a.cmp(b)));
    let free: Vec<ActionSeq> = p
        .candidates
        .iter()
        .filter(|c| !p.fixed.iter().any(|f| f.as_ref() == Some(c)))
        .copied()
        .collect();
    let start = local_search(p, &order, &free);
    let mut state = Branch {
        p,
        order: &order,
        free: &free,
        best: start.clone(),
        best_cost: cost(p, &start),
        nodes: 0,
        deadline: started + p.time_limit,
        aborted: false,
        open_bound: f64::INFINITY,
    };
    let local_search_ms = state.best_cost;
    let mut placed: Vec<Option<ActionSeq>> = p.fixed.clone();
    let mut used = vec![false; free.len()];
    state.branch(0, &mut placed, &mut used, None);
    let bound_ms = if state.aborted {
        state.open_bound.min(state.best_cost)
    } else {
        state.best_cost
    };
    Found {
        cost_ms: state.best_cost,
        sequences: state.best,
        bound_ms,
        complete: !state.aborted,
        nodes: state.nodes,
        seconds: started.elapsed().as_secs_f64(),
        local_search_ms,
    }
}

struct Branch<'a> {
    p: &'a Problem,
    order: &'a [usize],
    free: &'a [ActionSeq],
    best: Vec<ActionSeq>,
    best_cost: f64,
    nodes: u64,
    deadline: Instant,
    aborted: bool,
    /// The least bound of the partial libraries left unexplored.
    open_bound: f64,
}

impl Branch<'_> {
    /// Places `order[depth..]`; `previous` is the candidate the entry
    /// before took.
    fn branch(
        &mut self,
        depth: usize,
        placed: &mut Vec<Option<ActionSeq>>,
        used: &mut [bool],
        previous: Option<usize>,
    ) {
        self.nodes += 1;
        if depth == self.order.len() {
            let sequences: Vec<ActionSeq> = placed.iter().map(|s| s.unwrap_or_default()).collect();
            let c = cost(self.p, &sequences);
            if c < self.best_cost {
                self.best_cost = c;
                self.best = sequences;
            }
            return;
        }
        let (placed_cost, mut candidate_costs) = self.partial(placed, used);
        candidate_costs.sort_by(|a, b| a.1.total_cmp(&b.1));
        let entry = self.order[depth];
        // The usages still to place after this entry, largest first.
        let rest: Vec<f64> = self.order[depth + 1..]
            .iter()
            .map(|i| self.p.usage[*i])
            .collect();
        let same_as_before =
            depth > 0 && self.p.usage[self.order[depth - 1]] == self.p.usage[entry];
        for (rank, &(c, c_cost)) in candidate_costs.iter().enumerate() {
            if same_as_before && previous.is_some_and(|p| c <= p) {
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
                + self.p.usage[entry] * c_cost
                + rest.iter().zip(others).map(|(u, c)| u * c).sum::<f64>();
            if bound >= self.best_cost * (1.0 - 1e-12) {
                continue;
            }
            if self.aborted || (self.nodes % 64 == 0 && Instant::now() >= self.deadline) {
                self.aborted = true;
                self.open_bound = self.open_bound.min(bound);
                continue;
            }
            placed[entry] = Some(self.free[c]);
            used[c] = true;
            self.branch(depth + 1, placed, used, Some(c));
            placed[entry] = None;
            used[c] = false;
        }
    }

    /// The placed entries' cost among themselves, and each unused
    /// candidate's cost as the next entry among them.
    fn partial(&self, placed: &[Option<ActionSeq>], used: &[bool]) -> (f64, Vec<(usize, f64)>) {
        let indices: Vec<usize> = (0..placed.len()).filter(|i| placed[*i].is_some()).collect();
        let mut library: Vec<&[Action]> = indices
            .iter()
            .filter_map(|i| placed[*i].as_ref().map(ActionSeq::as_slice))
            .collect();
        let p = self.p;
        let placed_cost: f64 = indices
            .iter()
            .enumerate()
            .map(|(k, i)| p.usage[*i] * entry_cost(k, &library, &p.who, &p.timing, |_, _, _| {}).expected_ms)
            .sum();
        let k = library.len();
        let mut costs = Vec::with_capacity(self.free.len());
        for (c, seq) in self.free.iter().enumerate() {
            if used[c] {
                continue;
            }
            library.push(seq.as_slice());
            costs.push((c, entry_cost(k, &library, &p.who, &p.timing, |_, _, _| {}).expected_ms));
            library.pop();
        }
        (placed_cost, costs)
    }
}

/// A greedy library (most used entry on the cheapest sequence left),
/// then swaps of two entries and moves to unused sequences while any
/// lowers the cost.
fn local_search(p: &Problem, order: &[usize], free: &[ActionSeq]) -> Vec<ActionSeq> {
    let mut sequences: Vec<ActionSeq> = p.fixed.iter().map(|f| f.unwrap_or_default()).collect();
    let mut taken = vec![false; free.len()];
    for &entry in order {
        let mut placed: Vec<&[Action]> = (0..sequences.len())
            .filter(|i| p.fixed[*i].is_some() || order.iter().take_while(|o| **o != entry).any(|o| o == i))
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
            for (c, seq) in free.iter().enumerate() {
                if sequences.contains(seq) {
                    continue;
                }
                let old = sequences[i];
                sequences[i] = *seq;
                let new = cost(p, &sequences);
                if new < current - 1e-9 {
                    current = new;
                    improved = true;
                    let _ = c;
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
