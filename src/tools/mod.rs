//! Tools built on the core: `replay` (a CSV of samples, [`csv_replay`], or
//! a session recording, [`recording::recording_replay`], through the
//! pipeline and the simulated arm; [`replay`] and [`trace`] are what both
//! share), session recordings (`run --record`), the benches (`bench tick`,
//! `bench latency`, `bench replay`), the accuracy scorer (`bench
//! accuracy`, the stress tests), a session's samples read for fitting
//! ([`signal_file`]), and synthetic recordings written ([`generate`]).
//! Neither the core nor the runtime imports them.

pub mod accuracy;
pub mod bench_replay;
pub mod bench_tick;
pub mod csv_replay;
pub mod float_text;
pub mod generate;
pub mod gesture_accuracy;
pub mod imu_csv;
pub mod imu_replay;
pub mod latency;
pub mod output_file;
pub mod recording;
pub mod replay;
pub mod replay_files;
pub mod safety;
pub mod signal_file;
pub mod trace;
