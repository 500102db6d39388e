//! `replay`: runs the core over a recording as fast as the machine allows
//! and writes its events as JSON Lines.

use std::io::{Read, Write};

use serde_json::{Value, json};

use crate::Tick;
use crate::config::Config;
use crate::csv_signal::CsvSignal;
use crate::event::Event;
use crate::pipeline::Core;

/// What a replay did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ReplaySummary {
    /// Samples (ticks) processed.
    pub samples: u64,
    /// Events written.
    pub events: u64,
}

/// One event as a JSON object: `{"tick":N,"event":"…",…}`.
pub fn event_json(tick: Tick, event: &Event) -> Value {
    match event {
        Event::Burst(b) => json!({
            "tick": tick, "event": "burst", "action": b.action.code(),
            "start_tick": b.start, "duration_ms": b.duration_ms(),
        }),
        Event::Match { sequence, mode } => json!({
            "tick": tick, "event": "match",
            "sequence": sequence.codes().collect::<Vec<_>>(), "mode": mode.name(),
        }),
        Event::Reset { sequence, reason } => json!({
            "tick": tick, "event": "reset",
            "sequence": sequence.codes().collect::<Vec<_>>(), "reason": reason.name(),
        }),
        Event::Detection { reason } => json!({
            "tick": tick, "event": "detection", "reason": reason.name(),
        }),
        Event::Fault(reason) => json!({
            "tick": tick, "event": "fault", "reason": reason.describe(),
        }),
        Event::Recovered => json!({ "tick": tick, "event": "recovered" }),
    }
}

/// Replays every sample of `signal` through a fresh core, writing one JSON
/// line per event to `out`. Stops at the first malformed row, with its line.
pub fn replay<R: Read>(
    config: &Config,
    signal: &mut CsvSignal<R>,
    out: &mut impl Write,
) -> anyhow::Result<ReplaySummary> {
    let mut core: Core = Core::new(config);
    let mut summary = ReplaySummary::default();
    while let Some(volts) = signal.next_sample()? {
        let output = core.step(summary.samples, volts);
        for event in output.events.iter() {
            serde_json::to_writer(&mut *out, &event_json(output.tick, event))?;
            out.write_all(b"\n")?;
            summary.events += 1;
        }
        summary.samples += 1;
    }
    out.flush()?;
    Ok(summary)
}
