//! Session recordings (`run --record DIR`, `replay DIR`): what the
//! control loop saw, written off the control thread, and replayed through
//! the core to the same events and arm commands, bit for bit.
//!
//! A recording is a directory:
//!
//! | file | what |
//! |---|---|
//! | `meta.json` | format version, sipnpuff version, sensor, arm, start time, counts, losses, complete or not ([`meta`]) |
//! | `config.toml` | the configuration in effect, as `sipnpuff config` prints it (reads back to the identical `Config`) |
//! | `gestures.toml` | for a person with gestures, a copy of the gesture set the run used (replay reads it, not the set's own file, which may have changed since) |
//! | `samples.bin` | every tick's input to the core: its tick, its sample or none, the IMU's, the safe stop ([`mod@format`]) |
//! | `commands.bin` | the 100 Hz arm commands the core produced ([`mod@format`]) |
//! | `events.jsonl` | the events, one JSON line each, as `run` prints them |
//! | `report.json` | the run's report, as `run --json` prints it, with the recording's summary |
//!
//! [`recorder`] (the telemetry thread's side) and [`writer`] (its own
//! thread) write one; [`read`] opens and checks one; [`recording_replay`]
//! runs it through the core and compares; [`matches`](mod@matches) reads the `match`
//! events of recordings for the designer.

pub mod format;
pub mod matches;
pub mod meta;
pub mod read;
pub mod recorder;
pub mod recording_replay;
pub mod writer;

/// `meta.json`.
pub const META: &str = "meta.json";
/// `config.toml`.
pub const CONFIG: &str = "config.toml";
/// `gestures.toml`: the gesture set the run used, copied.
pub const GESTURES: &str = "gestures.toml";
/// `samples.bin`.
pub const SAMPLES: &str = "samples.bin";
/// `commands.bin`.
pub const COMMANDS: &str = "commands.bin";
/// `events.jsonl`.
pub const EVENTS: &str = "events.jsonl";
/// `report.json`.
pub const REPORT: &str = "report.json";
