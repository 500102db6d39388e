//! Banded dynamic time warping between two sequences of frames, its
//! lower bound, and early abandoning.
//!
//! * The cost of matching two frames is their squared Euclidean distance.
//! * Steps: diagonal weighs 2, horizontal and vertical 1 (and the first
//!   cell 2), so every path from the first cells to the last weighs
//!   exactly `n + m`: the weighted sum divided by `n + m` is a mean cost
//!   per step whatever the path, and [`dtw_distance`] returns its square
//!   root (an RMS distance in feature units).
//! * Sakoe–Chiba band: row `i` of `a` may match only the frames of `b`
//!   within `band` of the diagonal's point `round(i·(m−1)/(n−1))`, so on
//!   unequal lengths the band follows the diagonal's slope. The band is
//!   widened to the slope if needed so that a path always exists.
//! * LB_Keogh: each frame of `a` is at least as far from every frame of
//!   `b` in its band as from the band's envelope (per-feature min and
//!   max), and every row holds a cell of the path whose weight is at
//!   least 1; so the sum over rows, normalised the same way, is ≤ the DTW.

use crate::control::gesture::features::{FEATURES, Frame, MAX_FRAMES};

/// The per-feature lower and upper envelope of a template over a band:
/// `lower[j]`/`upper[j]` are the min/max of its frames `j−band ..= j+band`.
#[derive(Debug, Clone, PartialEq)]
pub struct Envelope {
    /// The band the envelope was made with, frames.
    pub band: usize,
    /// Per-feature minimum around each frame.
    pub lower: Vec<Frame>,
    /// Per-feature maximum around each frame.
    pub upper: Vec<Frame>,
}

impl Envelope {
    /// The envelope of `frames` over `band`. Not RT-safe (allocates).
    pub fn of(frames: &[Frame], band: usize) -> Envelope {
        let mut lower = Vec::with_capacity(frames.len());
        let mut upper = Vec::with_capacity(frames.len());
        for j in 0..frames.len() {
            let around = frames
                .iter()
                .skip(j.saturating_sub(band))
                .take(j + band + 1 - j.saturating_sub(band));
            let mut lo = [f32::INFINITY; FEATURES];
            let mut hi = [f32::NEG_INFINITY; FEATURES];
            for frame in around {
                for ((l, h), &v) in lo.iter_mut().zip(hi.iter_mut()).zip(frame) {
                    *l = l.min(v);
                    *h = h.max(v);
                }
            }
            lower.push(lo);
            upper.push(hi);
        }
        Envelope { band, lower, upper }
    }
}

/// Squared Euclidean distance between two frames.
fn cost(a: &Frame, b: &Frame) -> f64 {
    let mut sum = 0.0f32;
    for (x, y) in a.iter().zip(b) {
        let d = x - y;
        sum += d * d;
    }
    f64::from(sum)
}

/// The lesser of two sums of costs (never NaN: frames are finite), as
/// one `minsd`: `f64::min`'s NaN handling lengthens the loop's chain.
fn least(x: f64, y: f64) -> f64 {
    if x < y { x } else { y }
}

/// The frame of `b` (length `m`) on the diagonal at row `i` of `a`
/// (length `n`), and the band's half-width widened to the slope.
fn diagonal(i: usize, n: usize, m: usize) -> usize {
    if n <= 1 {
        return 0;
    }
    (i * (m - 1) + (n - 1) / 2) / (n - 1)
}

fn effective_band(band: usize, n: usize, m: usize) -> usize {
    // A row's window moves by at most ceil((m−1)/(n−1)) frames; a band at
    // least that wide keeps consecutive windows connected.
    let slope = if n <= 1 { m } else { (m - 1).div_ceil(n - 1) };
    band.max(slope)
}

/// The DTW distance between `a` and `b` (see the module's documentation):
/// 0 for identical sequences; `f64::INFINITY` if either is empty or
/// longer than [`MAX_FRAMES`], or as soon as every cell of a row exceeds
/// what `abandon_above` allows (then the true distance exceeds it).
/// RT-safe: two rows on the stack, no allocation.
pub fn dtw_distance(a: &[Frame], b: &[Frame], band: usize, abandon_above: f64) -> f64 {
    let (n, m) = (a.len(), b.len());
    if n == 0 || m == 0 || n > MAX_FRAMES || m > MAX_FRAMES {
        return f64::INFINITY;
    }
    let weight = (n + m) as f64;
    let bound = abandon_above * abandon_above * weight;
    let band = effective_band(band, n, m);
    // Rows of the cumulative cost, shifted by one: slot `j + 1` is column
    // `j`, slot 0 the column before the first (∞, but 0 diagonally before
    // the first cell so that it weighs 2·cost). Slots a row does not
    // write are ∞ or older than what the next row reads (see below).
    let mut prev = [f64::INFINITY; MAX_FRAMES + 1];
    let mut cur = [f64::INFINITY; MAX_FRAMES + 1];
    if let Some(start) = prev.first_mut() {
        *start = 0.0;
    }
    for (i, x) in a.iter().enumerate() {
        let center = diagonal(i, n, m);
        let lo = center.saturating_sub(band);
        let hi = (center + band).min(m - 1);
        // The next row reads slots lo' ..= hi' + 1 with lo' ≥ lo: slot lo
        // and slot hi + 2 are written ∞ here; slots beyond were never
        // written by a row with a lower `hi`.
        for edge in [lo, hi + 2] {
            if let Some(slot) = cur.get_mut(edge) {
                *slot = f64::INFINITY;
            }
        }
        let (Some(row_b), Some(diag), Some(up), Some(out)) = (
            b.get(lo..=hi),
            prev.get(lo..=hi),
            prev.get(lo + 1..=hi + 1),
            cur.get_mut(lo + 1..=hi + 1),
        ) else {
            return f64::INFINITY;
        };
        let mut left = f64::INFINITY;
        let mut row_min = f64::INFINITY;
        for (((y, &d_diag), &d_up), slot) in row_b.iter().zip(diag).zip(up).zip(out) {
            let d = cost(x, y);
            let value = least(least(d_diag + 2.0 * d, d_up + d), left + d);
            *slot = value;
            left = value;
            row_min = least(row_min, value);
        }
        if row_min > bound {
            return f64::INFINITY;
        }
        std::mem::swap(&mut prev, &mut cur);
    }
    let total = prev.get(m).copied().unwrap_or(f64::INFINITY);
    (total / weight).sqrt()
}

/// LB_Keogh of `a` against a template of `envelope.lower.len()` frames:
/// ≤ [`dtw_distance`]`(a, template, envelope.band, _)` whenever the
/// template's band there is `envelope.band` (its band is not widened by the
/// slope); `f64::INFINITY` for the cases where the distance is.
/// RT-safe.
pub fn lb_keogh(a: &[Frame], envelope: &Envelope) -> f64 {
    let (n, m) = (a.len(), envelope.lower.len());
    if n == 0 || m == 0 || n > MAX_FRAMES || m > MAX_FRAMES {
        return f64::INFINITY;
    }
    if effective_band(envelope.band, n, m) != envelope.band {
        return 0.0; // the band is wider than the envelope's: no bound.
    }
    let mut sum = 0.0f64;
    for (i, x) in a.iter().enumerate() {
        let j = diagonal(i, n, m);
        let (Some(lo), Some(hi)) = (envelope.lower.get(j), envelope.upper.get(j)) else {
            continue;
        };
        let mut row = 0.0f32;
        for ((&v, &l), &h) in x.iter().zip(lo).zip(hi) {
            let d = if v > h {
                v - h
            } else if v < l {
                l - v
            } else {
                0.0
            };
            row += d * d;
        }
        sum += f64::from(row);
    }
    (sum / (n + m) as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A smooth shape `len` frames long: one period of a sine, each
    /// feature a little later in phase.
    fn shape(len: usize, scale: f32) -> Vec<Frame> {
        (0..len)
            .map(|i| {
                let t = i as f32 / (len - 1) as f32 * std::f32::consts::TAU;
                std::array::from_fn(|k| scale * (t + 0.5 * k as f32).sin())
            })
            .collect()
    }

    #[test]
    fn a_sequence_is_at_distance_zero_from_itself() {
        let a = shape(40, 1.0);
        assert_eq!(dtw_distance(&a, &a, 4, f64::INFINITY), 0.0);
    }

    #[test]
    fn a_constant_offset_is_its_rms() {
        // Every frame 0.5 apart in one feature: every cost 0.25, mean 0.25.
        let a = vec![[0.0; FEATURES]; 10];
        let b = vec![[0.5, 0.0, 0.0, 0.0, 0.0, 0.0]; 10];
        assert_eq!(dtw_distance(&a, &b, 2, f64::INFINITY), 0.5);
    }

    #[test]
    fn distance_is_symmetric() {
        let a = shape(30, 1.0);
        let b = shape(30, 1.3);
        assert_eq!(
            dtw_distance(&a, &b, 3, f64::INFINITY),
            dtw_distance(&b, &a, 3, f64::INFINITY)
        );
    }

    #[test]
    fn a_stretched_copy_is_nearer_than_another_shape() {
        let a = shape(30, 1.0);
        let stretched = shape(42, 1.0);
        let other: Vec<Frame> = shape(30, 1.0).into_iter().rev().collect();
        let near = dtw_distance(&a, &stretched, 3, f64::INFINITY);
        let far = dtw_distance(&a, &other, 3, f64::INFINITY);
        // What is left is the sampling: 30 and 42 points of one period
        // never sit at the same phases (≈ 0.1 rad apart at most).
        assert!(near < 0.15, "{near}");
        assert!(far > 5.0 * near, "{far} vs {near}");
    }

    #[test]
    fn empty_or_too_long_sequences_are_infinitely_far() {
        let a = shape(10, 1.0);
        assert_eq!(dtw_distance(&a, &[], 2, 1.0), f64::INFINITY);
        let long = vec![[0.0; FEATURES]; MAX_FRAMES + 1];
        assert_eq!(dtw_distance(&a, &long, 2, f64::INFINITY), f64::INFINITY);
    }

    fn frames(len: std::ops::Range<usize>) -> impl Strategy<Value = Vec<Frame>> {
        prop::collection::vec(prop::array::uniform6(-2.0f32..2.0), len)
    }

    proptest! {
        #[test]
        fn lb_keogh_never_exceeds_dtw(a in frames(2..64), b in frames(2..64), band in 1usize..8) {
            let envelope = Envelope::of(&b, band);
            let lb = lb_keogh(&a, &envelope);
            let d = dtw_distance(&a, &b, band, f64::INFINITY);
            prop_assert!(lb <= d * (1.0 + 1e-6) + 1e-9, "lb {lb} > dtw {d}");
        }

        #[test]
        fn abandoning_happens_only_above_the_bound(
            a in frames(2..64), b in frames(2..64), band in 1usize..8, bound in 0.0f64..3.0,
        ) {
            let exact = dtw_distance(&a, &b, band, f64::INFINITY);
            let early = dtw_distance(&a, &b, band, bound);
            if early == f64::INFINITY {
                prop_assert!(exact > bound, "abandoned at {bound}, true {exact}");
            } else {
                prop_assert_eq!(early, exact);
            }
        }

        #[test]
        fn equal_lengths_are_symmetric(a in frames(5..6), b in frames(5..6), band in 1usize..4) {
            prop_assert_eq!(
                dtw_distance(&a, &b, band, f64::INFINITY),
                dtw_distance(&b, &a, band, f64::INFINITY)
            );
        }
    }
}
