//! The statistics of the paper's comparison: mean, sample standard
//! deviation and the Wilcoxon signed-rank test for paired data.
//!
//! The paper reports p = 5.86 × 10⁻³ for each task with 8 participants:
//! that is the normal approximation (no continuity correction) when all 8
//! differences have the same sign (z = 18 / √51). The study reports that
//! approximation, as the paper did, and the exact p-value beside it.

/// Mean; NaN for no values.
pub fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len() as f64
}

/// Sample standard deviation (n − 1); NaN for fewer than two values.
pub fn sample_sd(values: &[f64]) -> f64 {
    let m = mean(values);
    let squares: f64 = values.iter().map(|v| (v - m) * (v - m)).sum();
    (squares / (values.len() as f64 - 1.0)).sqrt()
}

/// The alternative hypothesis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tail {
    /// The first sample is larger (one-tailed).
    Greater,
    /// The samples differ either way (two-tailed).
    TwoSided,
}

/// A Wilcoxon signed-rank test of paired samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SignedRank {
    /// Pairs with a non-zero difference (zeros are dropped, Wilcoxon's
    /// original method).
    pub n: usize,
    /// Sum of the ranks of the positive differences.
    pub w_plus: f64,
    /// Normal approximation with the tie correction, without continuity
    /// correction (the paper's figures).
    pub z: f64,
    /// p-value of the normal approximation.
    pub p_normal: f64,
    /// Exact p-value from the distribution of W+ (ties: ranks averaged,
    /// the distribution of untied ranks, as is usual); `None` above 50
    /// pairs.
    pub p_exact: Option<f64>,
}

/// Standard normal CDF.
fn phi(z: f64) -> f64 {
    crate::fit::stats::normal_cdf(z)
}

/// Tests whether `first − second` is centred on zero. `None` if the
/// slices differ in length or every difference is zero.
pub fn wilcoxon_signed_rank(first: &[f64], second: &[f64], tail: Tail) -> Option<SignedRank> {
    if first.len() != second.len() {
        return None;
    }
    let mut diffs: Vec<f64> = first
        .iter()
        .zip(second)
        .map(|(a, b)| a - b)
        .filter(|d| *d != 0.0)
        .collect();
    let n = diffs.len();
    if n == 0 {
        return None;
    }
    diffs.sort_by(|a, b| a.abs().total_cmp(&b.abs()));
    // Average ranks over ties of |d|; the tie term Σ(t³ − t) for the
    // variance.
    let mut w_plus = 0.0;
    let mut tie_term = 0.0;
    let mut i = 0;
    while i < n {
        let mut j = i;
        while j + 1 < n && diffs[j + 1].abs() == diffs[i].abs() {
            j += 1;
        }
        let rank = (i + j) as f64 / 2.0 + 1.0;
        let t = (j - i + 1) as f64;
        tie_term += t * t * t - t;
        w_plus += rank * diffs[i..=j].iter().filter(|d| **d > 0.0).count() as f64;
        i = j + 1;
    }
    let nf = n as f64;
    let mean = nf * (nf + 1.0) / 4.0;
    let var = nf * (nf + 1.0) * (2.0 * nf + 1.0) / 24.0 - tie_term / 48.0;
    let z = (w_plus - mean) / var.sqrt();
    let p_normal = match tail {
        Tail::Greater => 1.0 - phi(z),
        Tail::TwoSided => (2.0 * phi(-z.abs())).min(1.0),
    };
    let p_exact = (n <= 50).then(|| exact_p(n, w_plus, tail));
    Some(SignedRank {
        n,
        w_plus,
        z,
        p_normal,
        p_exact,
    })
}

/// P(W+ ≥ w) (or the two-sided double of the smaller tail) under the null,
/// counting the 2ⁿ sign assignments of ranks 1..n.
fn exact_p(n: usize, w_plus: f64, tail: Tail) -> f64 {
    let max = n * (n + 1) / 2;
    // counts[s]: sign assignments whose positive ranks sum to s.
    let mut counts = vec![0f64; max + 1];
    counts[0] = 1.0;
    for rank in 1..=n {
        for s in (rank..=max).rev() {
            counts[s] += counts[s - rank];
        }
    }
    let total = 2f64.powi(n as i32);
    // Averaged ranks can be halves: compare with a small slack.
    let at_least = |w: f64| -> f64 {
        counts
            .iter()
            .enumerate()
            .filter(|(s, _)| *s as f64 >= w - 1e-9)
            .map(|(_, c)| c)
            .sum::<f64>()
            / total
    };
    match tail {
        Tail::Greater => at_least(w_plus),
        Tail::TwoSided => {
            let mirrored = max as f64 - w_plus;
            (2.0 * at_least(w_plus.max(mirrored))).min(1.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn the_papers_p_value_is_eight_of_eight_faster() {
        // Every one of 8 participants faster with ASP: the paper's
        // p = 5.86 × 10⁻³, exactly the normal approximation.
        let bsp = [120.0, 131.0, 99.0, 150.0, 142.0, 118.0, 160.0, 101.0];
        let asp = [80.0, 90.0, 70.0, 95.0, 100.0, 75.0, 90.0, 57.0];
        let t = wilcoxon_signed_rank(&bsp, &asp, Tail::Greater).unwrap();
        assert_eq!(t.n, 8);
        assert_eq!(t.w_plus, 36.0);
        assert!(close(t.z, 18.0 / 51f64.sqrt(), 1e-12));
        assert!(close(t.p_normal, 5.86e-3, 0.005e-3), "{}", t.p_normal);
        assert_eq!(t.p_exact, Some(1.0 / 256.0));
    }

    #[test]
    fn textbook_example_with_ties() {
        // Differences 1.5, −2, 3, 3, 4, −5, 6 (no zero): ranks 1, 2, 3.5,
        // 3.5, 5, 6, 7; W+ = 1 + 3.5 + 3.5 + 5 + 7 = 20.
        let x = [11.5, 8.0, 13.0, 14.0, 15.0, 5.0, 16.0];
        let y = [10.0, 10.0, 10.0, 11.0, 11.0, 10.0, 10.0];
        let t = wilcoxon_signed_rank(&x, &y, Tail::TwoSided).unwrap();
        assert_eq!(t.n, 7);
        assert_eq!(t.w_plus, 20.0);
        // var = 7·8·15/24 − (2³ − 2)/48 = 35 − 0.125
        let z = (20.0 - 14.0) / 34.875f64.sqrt();
        assert!(close(t.z, z, 1e-12));
        assert!(close(t.p_normal, 2.0 * (1.0 - phi(z)), 1e-12));
        // P(W+ ≥ 20) for n = 7 is 24/128 (tabulated); two-sided 48/128.
        assert!(close(t.p_exact.unwrap(), 48.0 / 128.0, 1e-12));
    }

    #[test]
    fn zeros_are_dropped_and_all_zero_has_no_test() {
        assert!(wilcoxon_signed_rank(&[1.0, 2.0], &[1.0, 2.0], Tail::TwoSided).is_none());
        let t = wilcoxon_signed_rank(&[1.0, 3.0, 5.0], &[1.0, 2.0, 3.0], Tail::Greater).unwrap();
        assert_eq!(t.n, 2);
        assert_eq!(t.p_exact, Some(0.25));
    }

    #[test]
    fn phi_and_sd() {
        assert!(close(phi(0.0), 0.5, 1e-15));
        assert!(close(phi(1.959_963_984_540_054), 0.975, 1e-12));
        assert!(close(
            sample_sd(&[2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0]),
            2.138_089_935_299_395,
            1e-12
        ));
    }
}
