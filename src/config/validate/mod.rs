//! The checks a configuration must pass, on typed values, each error with
//! its key. They run on every `Config` made: on a file's settings once
//! they are read (so its problems of every kind are reported together)
//! and on a configuration changed in code (`Config::with_*`), so no way
//! of building a `Config` skips them.
//!
//! One file per part of the file: `detector`, `selection` (matcher,
//! command mode, scanning, the library), `motion` (limits and workspace),
//! `arm` (power-up pose, measured-pose checks, backends), `sensor`,
//! `output` and `realtime` (`[rt]`).

mod arm;
mod detector;
mod motion;
mod output;
mod realtime;
mod selection;
mod sensor;

use crate::arm::settings::ArmSettings;
use crate::config::error::Problems;
use crate::config::realtime::RtSettings;
use crate::control::core_config::CoreConfig;
use crate::output::settings::OutputSettings;
use crate::sensor::settings::SensorSettings;

pub use selection::MAX_SEQUENCES;

/// Upper bound for every timer, to catch unit mistakes (seconds typed as
/// milliseconds ×1000) and keep tick arithmetic far from overflow.
pub const MAX_TIMER_MS: u32 = 600_000;

/// The checks' common forms.
impl Problems {
    /// Checks `low < value ≤ high` (or `low ≤ value` when `low_inclusive`).
    fn range(
        &mut self,
        key: &str,
        value: f64,
        low: f64,
        low_inclusive: bool,
        high: f64,
        unit: &str,
    ) {
        let above_low = if low_inclusive {
            value >= low
        } else {
            value > low
        };
        if !(above_low && value <= high) {
            let bound = if low_inclusive { "at least" } else { "above" };
            self.add(
                key,
                format!("{value} {unit} must be {bound} {low} {unit} and at most {high} {unit}"),
            );
        }
    }

    /// Checks a timer: above 0 and at most [`MAX_TIMER_MS`].
    fn positive_ms(&mut self, key: &str, value: u32) {
        if value == 0 {
            self.add(key, "must be greater than 0 ms");
        } else if value > MAX_TIMER_MS {
            self.add(
                key,
                format!("{value} ms is more than the {MAX_TIMER_MS} ms allowed"),
            );
        }
    }
}

/// Every check, section by section in the order `sipnpuff config` prints
/// them.
pub(super) fn config(
    p: &mut Problems,
    core: &CoreConfig,
    sensor: &SensorSettings,
    arm: &ArmSettings,
    output: &OutputSettings,
    rt: &RtSettings,
) {
    detector::detector(p, core.detector());
    selection::matcher(p, core.matcher());
    selection::command(p, core.command());
    motion::motion(p, core.motion());
    motion::workspace(p, core.workspace());
    arm::home(p, core.home(), core.workspace());
    arm::feedback(p, core.feedback());
    arm::backends(p, arm);
    selection::scanning(p, core.scanning());
    selection::library(p, core.sequences());
    selection::gestures(p, core);
    sensor::sensor(p, sensor);
    output::output(p, output, core.pointer());
    realtime::rt(p, rt);
}
