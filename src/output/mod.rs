//! The output seam: where the core's commands beyond the arm go — the
//! computer's keyboard and pointer ([`uinput`]) and the home
//! ([`mqtt`], Home Assistant over MQTT).
//!
//! An output's life: **open** (by the command line, before anything
//! starts: a missing device or broker address is an error then, never
//! mid-run) → **begin** (the loop's tick 0 in wall-clock time) →
//! **apply** each [`OutputCommand`] on the output's own thread, never the
//! control thread → **close**: let go of every key and button held, then
//! say what was done and lost. Every way out of a run closes the output
//! (the runtime's output thread does it when the loop ends, stops, faults
//! or dies), and a backend's own `Drop` lets go of anything still held.

use std::fmt;
use std::time::SystemTime;

use serde::Serialize;

use crate::control::output_command::{OutputCommand, PointerMove};

#[cfg(feature = "mqtt")]
pub mod mqtt;
pub mod settings;
pub mod uinput;

/// Which outputs to drive besides the arm: the `--output` values.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum OutputSpec {
    /// `uinput`: a virtual keyboard and pointer through `/dev/uinput`;
    /// settings in `[output.uinput]`.
    Uinput,
    /// `mqtt` or `mqtt:HOST:PORT`: Home Assistant over MQTT; settings in
    /// `[output.mqtt]` (the address given here wins over the file's).
    Mqtt {
        /// `HOST:PORT` given on the command line.
        address: Option<(String, u16)>,
    },
}

impl OutputSpec {
    /// Parses an `--output` value; the error says which forms exist.
    pub fn parse(text: &str) -> Result<OutputSpec, String> {
        let forms = "`uinput`, `mqtt` or `mqtt:HOST:PORT`";
        match text {
            "uinput" => Ok(OutputSpec::Uinput),
            "mqtt" => Ok(OutputSpec::Mqtt { address: None }),
            _ => match text.strip_prefix("mqtt:").and_then(|a| a.rsplit_once(':')) {
                Some((host, port)) if !host.is_empty() => match port.parse::<u16>() {
                    Ok(port) if port > 0 => Ok(OutputSpec::Mqtt {
                        address: Some((host.to_owned(), port)),
                    }),
                    _ => Err(format!(
                        "`{port}` is not a port (1–65535) in --output `{text}`"
                    )),
                },
                _ => Err(format!("unknown output `{text}`: use {forms}")),
            },
        }
    }

    /// `uinput` or `mqtt`.
    pub fn kind(&self) -> &'static str {
        match self {
            OutputSpec::Uinput => "uinput",
            OutputSpec::Mqtt { .. } => "mqtt",
        }
    }
}

/// One output, driven from its own thread.
pub trait Output: Send {
    /// What it is, for the report: `uinput "sipnpuff" (/dev/input/event5)`.
    fn describe(&self) -> String;

    /// The run's tick 0 happens at `tick_zero` (wall clock): a command's
    /// tick becomes a time. Called once, before the first command.
    fn begin(&mut self, _tick_zero: SystemTime) {}

    /// Carries out one command. Never panics; a failure is counted and
    /// reported at [`Output::close`].
    fn apply(&mut self, command: &OutputCommand);

    /// Called about every millisecond between commands (an MQTT client
    /// notices its connection here).
    fn idle(&mut self) {}

    /// Whether a person waits on it with the loop's timing (a key held
    /// for a breath, the pointer moving): its thread then runs SCHED_FIFO
    /// below the control thread. A network output is not.
    fn has_deadlines(&self) -> bool {
        false
    }

    /// Lets go of every key and button held, closes, and says what was
    /// done and lost.
    fn close(&mut self) -> OutputReport;
}

/// What one output did in a run (the report's `outputs`).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct OutputReport {
    /// [`Output::describe`].
    pub output: String,
    /// Commands carried out.
    pub applied: u64,
    /// Commands dropped because the output's ring was full (the output
    /// was too slow; the loop never waits for it).
    pub dropped: u64,
    /// Commands that could not be carried out (a home event the broker
    /// never acknowledged, a write to the device that failed).
    pub lost: u64,
    /// Plain words on what went wrong, if anything: "the broker was
    /// unreachable for 4.1 s; 2 events were lost".
    pub notes: Vec<String>,
    /// The pointer motion written, for an output that moves the pointer
    /// (uinput): the sum of its moves, what a reader of the device sums to.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pointer_travel: Option<PointerMove<i64>>,
}

/// Why an output cannot be opened: said before anything starts.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OutputError {
    /// The output (`uinput`, `mqtt`).
    pub output: &'static str,
    /// What is wrong and what to do about it.
    pub detail: String,
}

impl fmt::Display for OutputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "output {}: {}", self.output, self.detail)
    }
}

impl std::error::Error for OutputError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn output_forms() {
        assert_eq!(OutputSpec::parse("uinput"), Ok(OutputSpec::Uinput));
        assert_eq!(
            OutputSpec::parse("mqtt"),
            Ok(OutputSpec::Mqtt { address: None })
        );
        assert_eq!(
            OutputSpec::parse("mqtt:broker.local:8883"),
            Ok(OutputSpec::Mqtt {
                address: Some(("broker.local".into(), 8883))
            })
        );
        assert!(OutputSpec::parse("mqtt:host:0").is_err());
        assert!(OutputSpec::parse("mqtt:host").is_err());
        assert!(OutputSpec::parse("speaker").unwrap_err().contains("uinput"));
    }
}
