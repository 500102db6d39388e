//! Re-zeroing after a stuck fault: whether the signal has held one level
//! long enough to become the new neutral.

/// Re-zeroing looks at the signal in windows of this many samples (100 ms:
/// five whole periods of 50 Hz hum and six of 60 Hz, so hum averages out).
pub const REZERO_WINDOW_MS: usize = 100;

/// Samples dropped from each end of a window before averaging it (a
/// trimmed mean): a spike or dropout to a rail lasts at most `glitch_ms`
/// samples, so up to ten of either never move a window's level.
pub const REZERO_TRIM: usize = 10;

/// A level is steady while the trimmed means of all its windows lie within
/// this band (highest − lowest). Noise of σ = 0.1 V moves a window's mean
/// by about 0.011 V and the fastest drift (0.5 V a minute) 0.017 V in 2 s;
/// a held breath wanders by more (the synthetic user's by ±0.1 V at
/// 0.5 Hz: 0.2 V in any 2 s).
pub const REZERO_STEADY_VOLTS: f64 = 0.1;

/// Whether the signal has held one level, window by window. RT-safe: a
/// fixed array, sorted in place once per window.
#[derive(Debug, Clone)]
pub(super) struct Steadiness {
    window: [f64; REZERO_WINDOW_MS],
    filled: usize,
    /// Windows in the current steady run, their lowest and highest
    /// trimmed means and the sum of them.
    windows: u64,
    low: f64,
    high: f64,
    sum: f64,
}

impl Steadiness {
    pub(super) fn new() -> Self {
        Steadiness {
            window: [0.0; REZERO_WINDOW_MS],
            filled: 0,
            windows: 0,
            low: 0.0,
            high: 0.0,
            sum: 0.0,
        }
    }

    pub(super) fn reset(&mut self) {
        self.filled = 0;
        self.windows = 0;
    }

    /// Adds a valid sample; when a window completes, returns how many
    /// windows the steady run now spans and its mean level.
    pub(super) fn push(&mut self, volts: f64) -> Option<(u64, f64)> {
        let slot = self.window.get_mut(self.filled)?;
        *slot = volts;
        self.filled += 1;
        if self.filled < REZERO_WINDOW_MS {
            return None;
        }
        self.filled = 0;
        self.window.sort_unstable_by(f64::total_cmp);
        let kept = REZERO_WINDOW_MS - 2 * REZERO_TRIM;
        let mean = self.window.iter().skip(REZERO_TRIM).take(kept).sum::<f64>() / kept as f64;
        let (low, high) = (self.low.min(mean), self.high.max(mean));
        if self.windows > 0 && high - low <= REZERO_STEADY_VOLTS {
            self.windows += 1;
            (self.low, self.high) = (low, high);
            self.sum += mean;
        } else {
            // The level moved: a new run starts with this window.
            self.windows = 1;
            (self.low, self.high, self.sum) = (mean, mean, mean);
        }
        Some((self.windows, self.sum / self.windows as f64))
    }
}
