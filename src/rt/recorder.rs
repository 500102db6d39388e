//! The session recorder's seam on the telemetry side (`run --record`).
//!
//! The control thread already sends the telemetry thread all a recording
//! needs: each tick's [`TickInput`] in its tick record, each event, and
//! (when recording) a copy of each arm command on a ring of its own. The
//! telemetry thread hands them on to a [`SessionRecorder`], which must
//! never block it: the implementation (`tools::recording`) queues them,
//! bounded, for a writer thread, and drops and counts what does not fit.
//! The runtime knows nothing of files or formats.

use serde::{Deserialize, Serialize};

use crate::control::Tick;
use crate::control::event::TimedEvent;
use crate::control::motion::stream::ArmCommand;
use crate::control::tick::TickInput;
use crate::rt::telemetry::Drops;

/// Where the telemetry thread hands what the control thread sent it.
/// Called on the telemetry thread, never on the control thread; not
/// RT-safe, but an implementation must not block (a slow disk drops and
/// counts, it never holds up the events or the report).
pub trait SessionRecorder {
    /// The run is about to start with this sensor and arm (as they
    /// describe themselves).
    fn start(&mut self, sensor: &str, arm: &str);

    /// One tick's input to the core, in tick order.
    fn input(&mut self, input: &TickInput);

    /// One arm command the core produced, in order.
    fn command(&mut self, command: &ArmCommand);

    /// One event, in order.
    fn event(&mut self, event: &TimedEvent);

    /// Items lost on the way to the telemetry thread (full rings) since
    /// the last call; called before the next item that did arrive.
    fn lost(&mut self, lost: Lost);
}

/// Items a recording is missing, by kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Lost {
    /// Ticks (the core's inputs).
    pub ticks: u64,
    /// Arm commands.
    pub arm_commands: u64,
    /// Events.
    pub events: u64,
}

impl Lost {
    /// Nothing lost.
    pub fn is_empty(&self) -> bool {
        *self == Lost::default()
    }

    /// Both counts together.
    pub fn plus(self, other: Lost) -> Lost {
        Lost {
            ticks: self.ticks + other.ticks,
            arm_commands: self.arm_commands + other.arm_commands,
            events: self.events + other.events,
        }
    }

    /// What the rings dropped between two cumulative counts: tick
    /// records, recorded arm commands and events (samples the sensor ran
    /// ahead with, and commands the arm ring dropped, are not the core's
    /// input or output: a recording does not miss them).
    pub fn between(before: &Drops, after: &Drops) -> Lost {
        Lost {
            ticks: after.records.saturating_sub(before.records),
            arm_commands: after
                .recorded_commands
                .saturating_sub(before.recorded_commands),
            events: after.events.saturating_sub(before.events),
        }
    }
}

/// What a recording holds and whether it is whole: the counts its
/// `meta.json` and its run's report both give (each embeds this, its
/// fields at the top level of the JSON).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct RecordingSummary {
    /// Every tick, arm command and event is in it and its files were
    /// ended properly: replay can verify the run bit for bit.
    pub complete: bool,
    /// Ticks written (the core's steps).
    pub ticks: u64,
    /// Arm commands written.
    pub arm_commands: u64,
    /// Events written.
    pub events: u64,
    /// The tick on which the safe stop began, if it is in the recording.
    pub stop_tick: Option<Tick>,
    /// Bytes of samples, commands and events written.
    pub bytes: u64,
    /// The cap on them (`--record-max-mb`).
    pub max_bytes: u64,
    /// What is missing, whatever the cause.
    pub lost: Lost,
    /// Why it is incomplete, in words (empty when complete; a failure is
    /// among them).
    pub problems: Vec<String>,
}

/// What a run's recording holds, in its report (and its `report.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RecordingReport {
    /// The recording's directory.
    pub dir: String,
    /// What it holds.
    #[serde(flatten)]
    pub summary: RecordingSummary,
    /// The recording failed: a write error, or a writer that never
    /// finished (a stalled disk). The run's exit status is then 1.
    pub error: Option<String>,
}

impl RecordingReport {
    /// One line for the run report.
    pub fn to_line(&self) -> String {
        let s = &self.summary;
        let counts = format!(
            "{} ticks, {} arm commands, {} events, {:.1} kB (cap {} MB)",
            s.ticks,
            s.arm_commands,
            s.events,
            s.bytes as f64 / 1e3,
            s.max_bytes as f64 / 1e6
        );
        if s.complete {
            format!("recording: {}: complete: {counts}\n", self.dir)
        } else {
            let why = match (s.problems.is_empty(), &self.error) {
                (true, Some(error)) => error.clone(),
                _ => s.problems.join("; "),
            };
            format!(
                "recording: {}: INCOMPLETE ({why}): {counts}; lost {} ticks, {} arm commands, {} events; replay will not claim equality\n",
                self.dir, s.lost.ticks, s.lost.arm_commands, s.lost.events
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn losses_are_the_recordings_rings_only() {
        let before = Drops {
            samples: 5,
            records: 1,
            ..Drops::default()
        };
        let after = Drops {
            samples: 50,
            arm_commands: 7,
            records: 4,
            events: 2,
            recorded_commands: 1,
        };
        assert_eq!(
            Lost::between(&before, &after),
            Lost {
                ticks: 3,
                arm_commands: 1,
                events: 2
            }
        );
        assert!(Lost::between(&after, &after).is_empty());
    }

    /// The report of a complete recording of 10 ticks.
    fn report() -> RecordingReport {
        RecordingReport {
            dir: "rec".into(),
            summary: RecordingSummary {
                complete: true,
                ticks: 10,
                arm_commands: 1,
                events: 2,
                stop_tick: Some(9),
                bytes: 1500,
                max_bytes: 200_000_000,
                lost: Lost::default(),
                problems: Vec::new(),
            },
            error: None,
        }
    }

    #[test]
    fn the_report_keeps_the_summary_at_its_top_level() {
        assert_eq!(
            serde_json::to_string(&report()).unwrap(),
            r#"{"dir":"rec","complete":true,"ticks":10,"arm_commands":1,"events":2,"stop_tick":9,"bytes":1500,"max_bytes":200000000,"lost":{"ticks":0,"arm_commands":0,"events":0},"problems":[],"error":null}"#
        );
    }

    #[test]
    fn the_report_line_says_complete_or_why_not() {
        let mut r = report();
        assert_eq!(
            r.to_line(),
            "recording: rec: complete: 10 ticks, 1 arm commands, 2 events, 1.5 kB (cap 200 MB)\n"
        );
        r.summary.complete = false;
        r.summary.lost.ticks = 4;
        r.summary.problems.push("the size cap was reached".into());
        let line = r.to_line();
        assert!(
            line.starts_with("recording: rec: INCOMPLETE (the size cap was reached): 10 ticks"),
            "{line}"
        );
        assert!(
            line.contains("lost 4 ticks, 0 arm commands, 0 events"),
            "{line}"
        );
    }
}
