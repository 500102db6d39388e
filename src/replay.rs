//! `replay`: runs the core over a recording as fast as the machine allows,
//! drives the simulated JACO with the core's 100 Hz stream, writes events
//! as JSON Lines and, optionally, a per-tick motion trace as CSV.

use std::io::{Read, Write};

use serde_json::{Value, json};

use crate::Tick;
use crate::arm::{ArmBackend, SimulatedJaco};
use crate::config::Config;
use crate::csv_signal::CsvSignal;
use crate::event::Event;
use crate::motion::MotionEvent;
use crate::pipeline::{Core, TickOutput};

/// What a replay did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ReplaySummary {
    /// Samples (ticks) processed.
    pub samples: u64,
    /// Events written.
    pub events: u64,
    /// Commands sent to the arm (100 Hz).
    pub arm_commands: u64,
    /// Ticks on which the simulated arm was outside its workspace.
    pub ticks_outside_workspace: u64,
    /// The simulated arm's final position, m.
    pub final_position: [f64; 3],
    /// Its final orientation as a rotation vector, rad.
    pub final_rotation_vector: [f64; 3],
    /// Its final finger position, units.
    pub final_fingers: f64,
}

/// Header of the `--trace` CSV.
pub const TRACE_HEADER: &str = "tick,mode,vx,vy,vz,wx,wy,wz,fingers_vel,x,y,z,rx,ry,rz,fingers";

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
        Event::Highlight { mode } => json!({
            "tick": tick, "event": "highlight", "mode": mode.name(),
        }),
        Event::Detection { reason } => json!({
            "tick": tick, "event": "detection", "reason": reason.name(),
        }),
        Event::Fault(reason) => json!({
            "tick": tick, "event": "fault", "reason": reason.describe(),
        }),
        Event::Recovered => json!({ "tick": tick, "event": "recovered" }),
        Event::Motion(m) => motion_event_json(tick, m),
    }
}

fn motion_event_json(tick: Tick, event: &MotionEvent) -> Value {
    match event {
        MotionEvent::Saved { position } => json!({
            "tick": tick, "event": "saved", "position": position,
        }),
        MotionEvent::GotoStarted {
            distance_m,
            angle_rad,
        } => json!({
            "tick": tick, "event": "goto_started", "distance_m": distance_m, "angle_rad": angle_rad,
        }),
        MotionEvent::GotoReached => json!({ "tick": tick, "event": "goto_reached" }),
        MotionEvent::NoSavedPoint => json!({
            "tick": tick, "event": "no_saved_point", "reason": "goto_point: no pose has been saved",
        }),
        MotionEvent::AlreadyAtSavedPoint => json!({ "tick": tick, "event": "at_saved_point" }),
        MotionEvent::WorkspaceLimit(boundary) => json!({
            "tick": tick, "event": "workspace_limit", "boundary": boundary.name(),
        }),
        MotionEvent::TrajectoryError => json!({
            "tick": tick, "event": "trajectory_error",
            "reason": "trajectory generator failed; braking with acceleration limits",
        }),
    }
}

/// Writes one trace row: the core's 1 kHz commanded twist (base frame) and
/// the simulated arm's pose.
fn trace_row(out: &mut dyn Write, output: &TickOutput, arm: &SimulatedJaco) -> std::io::Result<()> {
    let state = arm.state();
    let p = state.pose.translation.vector;
    let r = state.pose.rotation.scaled_axis();
    write!(out, "{},{}", output.tick, output.command.state.name())?;
    for value in output
        .motion
        .velocity()
        .iter()
        .chain(p.iter())
        .chain(r.iter())
    {
        write!(out, ",{value}")?;
    }
    writeln!(out, ",{}", state.fingers)
}

/// Replays every sample of `signal` through a fresh core and the simulated
/// arm, writing one JSON line per event to `out` and, if given, one trace
/// row per tick. Stops at the first malformed row, with its line.
pub fn replay<R: Read>(
    config: &Config,
    signal: &mut CsvSignal<R>,
    out: &mut dyn Write,
    mut trace: Option<&mut dyn Write>,
) -> anyhow::Result<ReplaySummary> {
    let mut core: Core = Core::new(config);
    let mut arm = SimulatedJaco::new(config);
    let mut summary = ReplaySummary::default();
    if let Some(trace) = trace.as_deref_mut() {
        writeln!(trace, "{TRACE_HEADER}")?;
    }
    while let Some(volts) = signal.next_sample()? {
        let output = core.step(summary.samples, volts);
        for event in output.events.iter() {
            serde_json::to_writer(&mut *out, &event_json(output.tick, event))?;
            out.write_all(b"\n")?;
            summary.events += 1;
        }
        if let Some(command) = &output.motion.arm_command {
            // The simulation cannot refuse a command.
            let _ = arm.send(command);
            summary.arm_commands += 1;
        }
        arm.advance_ms();
        if !arm.inside_workspace() {
            summary.ticks_outside_workspace += 1;
        }
        if let Some(trace) = trace.as_deref_mut() {
            trace_row(trace, &output, &arm)?;
        }
        summary.samples += 1;
    }
    out.flush()?;
    if let Some(trace) = trace {
        trace.flush()?;
    }
    let state = arm.state();
    summary.final_position = state.pose.translation.vector.into();
    summary.final_rotation_vector = state.pose.rotation.scaled_axis().into();
    summary.final_fingers = state.fingers;
    Ok(summary)
}
