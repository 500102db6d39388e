//! Tools built on the core: `replay` (recordings through the pipeline and
//! the simulated arm), session recordings (`run --record`, and their
//! replay), the benches (`bench tick`, `bench latency`, `bench replay`), and the accuracy
//! scorer (`bench accuracy`, the stress tests). Neither the core nor the
//! runtime imports them.

pub mod accuracy;
pub mod bench_replay;
pub mod bench_tick;
pub mod float_text;
pub mod latency;
pub mod recording;
pub mod replay;
pub mod safety;
