//! Replaying an IMU recording (`replay FILE.csv` whose header is
//! `tick,ax,…`): every tick from the first sample to the last through a core fed
//! by the IMU alone, the samples on their ticks and none between (the
//! core holds the last), as the breath replay does with volts.

use std::io::Write;

use crate::control::core_config::CoreConfig;
use crate::control::imu::ImuInput;
use crate::control::tick::TickInput;
use crate::tools::imu_csv::ImuRecording;
use crate::tools::replay::{ReplayError, ReplayRun, ReplaySummary};

/// Replays `recording` through `config` (whose gestures are loaded) and
/// the simulated arm, writing one JSON line per event to `out` and, if
/// given, one trace row per tick.
pub fn replay(
    config: &CoreConfig,
    recording: &ImuRecording,
    out: &mut dyn Write,
    trace: Option<&mut dyn Write>,
) -> Result<ReplaySummary, ReplayError> {
    let mut run = ReplayRun::new(config, out, trace)?;
    let mut samples = recording.samples.iter().peekable();
    let first = recording.samples.first().map_or(0, |(t, _)| *t);
    let last = recording.samples.last().map_or(0, |(t, _)| *t);
    for tick in first..=last {
        let mut imu = ImuInput::Missing;
        while let Some((_, sample)) = samples.next_if(|(t, _)| *t <= tick) {
            imu = ImuInput::Sample(*sample);
        }
        run.step(&TickInput::imu(tick, imu))?;
    }
    run.finish()
}
