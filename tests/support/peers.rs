//! What the arm backends' tests against their peers share: the core's
//! commands from a recording, and the timing of a stream as the peer
//! received it.

use std::path::Path;

use sipnpuff::control::motion::stream::ArmCommand;
use sipnpuff::tools::recording::format::commands::CommandItem;
use sipnpuff::tools::recording::read::Recording;

/// The core's arm commands, from the recording in `dir` (`run --record`);
/// fails the test if the recording lost any.
pub fn recorded_commands(dir: &Path) -> Vec<ArmCommand> {
    let recording = Recording::open(dir).unwrap();
    let mut decoder = recording.commands().unwrap();
    let mut commands = Vec::new();
    while let Some(item) = decoder.next_item().unwrap() {
        match item {
            CommandItem::Command(c) => commands.push(c),
            CommandItem::Lost(n) => panic!("the recording lost {n} commands"),
        }
    }
    commands
}

/// The gaps between a stream's arrival times, ms.
pub struct Gaps {
    /// Sorted.
    sorted_ms: Vec<f64>,
    mean_ms: f64,
}

impl Gaps {
    /// The gaps between `times_ns` (CLOCK_MONOTONIC, in arrival order).
    pub fn of(times_ns: &[i64]) -> Gaps {
        let mut sorted_ms: Vec<f64> = times_ns
            .windows(2)
            .map(|w| (w[1] - w[0]) as f64 / 1e6)
            .collect();
        let mean_ms = sorted_ms.iter().sum::<f64>() / sorted_ms.len() as f64;
        sorted_ms.sort_by(f64::total_cmp);
        Gaps { sorted_ms, mean_ms }
    }

    /// Messages a second over the stream.
    pub fn rate_hz(&self) -> f64 {
        1000.0 / self.mean_ms
    }

    pub fn mean_ms(&self) -> f64 {
        self.mean_ms
    }

    /// The standard deviation, ms.
    pub fn sd_ms(&self) -> f64 {
        let n = self.sorted_ms.len() as f64;
        let squares: f64 = self
            .sorted_ms
            .iter()
            .map(|g| (g - self.mean_ms).powi(2))
            .sum();
        (squares / n).sqrt()
    }

    /// The `q` quantile (0 the smallest, 1 the largest), ms.
    pub fn quantile(&self, q: f64) -> f64 {
        quantile(&self.sorted_ms, q)
    }
}

/// The `q` quantile of `sorted` (nearest rank).
pub fn quantile(sorted: &[f64], q: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}
