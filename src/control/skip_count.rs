//! How often a skip was taken, for the tests that prove each skip changes
//! nothing (`tests/it/fast_paths.rs`). Counted with the `testing` feature
//! only: without it a count is empty and adding to it is nothing.

/// A count of skipped work. `Copy`, RT-safe.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SkipCount(#[cfg(any(test, feature = "testing"))] u64);

impl SkipCount {
    /// One more.
    pub fn add(&mut self) {
        #[cfg(any(test, feature = "testing"))]
        {
            self.0 += 1;
        }
    }

    /// How many.
    #[cfg(any(test, feature = "testing"))]
    pub fn get(self) -> u64 {
        self.0
    }
}
