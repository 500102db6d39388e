//! What became of the home events and the connection, for the report:
//! the figures [`Delivery`](super::delivery::Delivery) counts, and the
//! plain words the report gives them. Pure.

use std::time::Duration;

/// What happened to the events and the connection.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct Tally {
    /// Acknowledged by the broker.
    pub confirmed: u64,
    /// Written to a connection that broke before the acknowledgement.
    pub unconfirmed: u64,
    /// Waited longer than `max_delay_ms` for the broker.
    pub expired: u64,
    /// Refused because the queue was full.
    pub queue_full: u64,
    /// Still waiting when the output closed.
    pub unsent_at_close: u64,
    /// Written, and not acknowledged when the output closed (a broker
    /// that stopped answering).
    pub unacked_at_close: u64,
    /// Times the connection broke.
    pub outages: u64,
    /// Time without a connection.
    pub down: Duration,
    /// The longest time without a connection.
    pub longest_down: Duration,
    /// The last reason the broker could not be reached.
    pub last_why: Option<String>,
    /// Times Home Assistant came online and discovery went again.
    pub rediscoveries: u64,
    /// Retained configs of events no longer in the library, deleted.
    pub deleted_configs: u64,
    /// Discovery or availability messages the client's channel refused.
    pub announcements_refused: u64,
}

impl Tally {
    /// Events lost, whatever the reason.
    pub fn lost(&self) -> u64 {
        self.unconfirmed
            + self.expired
            + self.queue_full
            + self.unacked_at_close
            + self.unsent_at_close
    }

    /// Each way an event is lost ([`Tally::lost`] sums them): how many,
    /// and why in words.
    fn losses(&self, max_delay: Duration, queue: usize) -> [(u64, String); 5] {
        [
            (
                self.unconfirmed,
                "sent as the connection broke, never acknowledged (not sent again: it may have arrived, never twice)".into(),
            ),
            (
                self.expired,
                format!("waited longer than {:.1} s for the broker", secs(max_delay)),
            ),
            (
                self.queue_full,
                format!("found {queue} events already waiting"),
            ),
            (
                self.unacked_at_close,
                "sent but not acknowledged by the end (the broker stopped answering; they may have arrived)".into(),
            ),
            (
                self.unsent_at_close,
                "still waiting for the broker at the end".into(),
            ),
        ]
    }

    /// Adds one spell without a connection.
    pub fn add_down(&mut self, down: Duration) {
        self.down = self.down.saturating_add(down);
        self.longest_down = self.longest_down.max(down);
    }

    /// What went wrong, in plain words (`max_delay`: how long an event
    /// may wait for the broker; `queue`: how many may wait).
    pub fn notes(&self, max_delay: Duration, queue: usize) -> Vec<String> {
        let mut notes = Vec::new();
        if self.outages > 0 || !self.down.is_zero() {
            let times = match self.outages {
                0 | 1 => String::new(),
                n => format!(" ({n} times, the longest {:.1} s)", secs(self.longest_down)),
            };
            let why = self
                .last_why
                .as_deref()
                .map_or_else(String::new, |w| format!("; last: {w}"));
            notes.push(format!(
                "the broker was unreachable for {:.1} s{times}{why}",
                secs(self.down)
            ));
        }
        let lost = self.lost();
        if lost > 0 {
            let parts: Vec<String> = self
                .losses(max_delay, queue)
                .iter()
                .filter(|(n, _)| *n > 0)
                .map(|(n, why)| format!("{n} {why}"))
                .collect();
            notes.push(format!(
                "{lost} {} lost: {}",
                if lost == 1 {
                    "event was"
                } else {
                    "events were"
                },
                parts.join("; ")
            ));
        }
        if self.announcements_refused > 0 {
            notes.push(format!(
                "{} discovery or availability messages could not be queued",
                self.announcements_refused
            ));
        }
        if self.deleted_configs > 0 {
            notes.push(format!(
                "deleted {} Home Assistant trigger(s) of events no longer in the library",
                self.deleted_configs
            ));
        }
        notes
    }
}

fn secs(d: Duration) -> f64 {
    d.as_secs_f64()
}
