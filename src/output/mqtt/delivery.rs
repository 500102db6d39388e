//! The home output's delivery as a state machine without I/O: what to
//! hand the MQTT client, and when, from what the network reports. Time is
//! an argument and every input and output is a plain value, so the same
//! code runs behind [`MqttOutput`](super::MqttOutput) (which reads the
//! clock, feeds the [`NetworkNotice`]s and hands the [`Request`]s to rumqttc) and
//! in the unit tests on a simulated clock. Not RT-safe (it allocates).
//!
//! The rules it keeps:
//! * an event waits, in order, while there is no connection: at most
//!   [`QUEUE`] of them, each at most `max_delay_ms`; it is handed once
//!   connected;
//! * **at most once**: an event written on a connection that broke
//!   before the broker's PUBACK is lost and never handed again (it may
//!   have arrived; a light's toggle must never act twice); one handed but
//!   never written goes on the next connection;
//! * each connection subscribes to the device's retained trigger configs
//!   and to Home Assistant's status, then announces `online` and every
//!   discovery config, retained; Home Assistant's `online` announces
//!   again; a retained trigger config of an event no longer in the
//!   library is deleted (an empty retained config);
//! * closing waits up to [`CLOSE_WAIT`] for the events in flight, then
//!   says `offline` (retained) and disconnects, and waits up to
//!   [`CLOSE_WAIT`] for that.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use crate::control::target::HomeEvent;
use crate::output::OutputReport;
use crate::output::settings::MqttSettings;

use super::discovery::{self, OFFLINE, ONLINE, Topics};
use super::tally::Tally;

/// Most events waiting for the broker; more are dropped and counted.
pub const QUEUE: usize = 64;

/// How long closing waits for the events still queued or in flight to be
/// acknowledged, then for the goodbye to be written.
pub const CLOSE_WAIT: Duration = Duration::from_secs(2);

/// What the network reports, in the order it happened.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum NetworkNotice {
    /// The broker accepted a connection (its CONNACK).
    Connected,
    /// A connection broke, or an attempt to connect failed: why, in plain
    /// words. Every request handed before it has been dropped.
    Broken(String),
    /// The client wrote the oldest request it was handed.
    Written(Written),
    /// The broker acknowledged the publish with this packet id (PUBACK).
    Acked(u16),
    /// A message on a subscribed topic.
    Message {
        /// Its topic.
        topic: String,
        /// Its payload.
        payload: Vec<u8>,
        /// Whether the broker kept it (an old message, not a new one).
        retain: bool,
    },
    /// The client's thread has ended: nothing more can be sent.
    Gone,
}

/// A request the client wrote, as it reports it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Written {
    /// A publish, with its packet id.
    Publish(u16),
    /// A subscription.
    Subscribe,
    /// The disconnect.
    Disconnect,
}

/// What to hand the client.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Request {
    /// Publish at QoS 1.
    Publish {
        /// Where.
        topic: String,
        /// What.
        payload: String,
        /// Whether the broker keeps it for later subscribers.
        retain: bool,
    },
    /// Subscribe to a topic filter.
    Subscribe {
        /// The filter.
        filter: String,
        /// The QoS asked for.
        qos: Qos,
    },
    /// Disconnect cleanly: the broker drops the last will.
    Disconnect,
}

/// An MQTT quality of service.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Qos {
    /// QoS 0.
    AtMostOnce,
    /// QoS 1.
    AtLeastOnce,
}

/// What the client did with a request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Handed {
    /// Taken: it will be written, or dropped with its connection.
    Taken,
    /// Refused: the client's channel is full.
    Full,
    /// Refused: the connection is closing (the network thread will say
    /// why).
    Closed,
}

/// The home output's delivery. See the module's documentation.
#[derive(Debug)]
pub struct Delivery {
    topics: Topics,
    /// Retained discovery configs, `(topic, JSON)`.
    configs: Vec<(String, String)>,
    /// The library's event names (a retained trigger config of any other
    /// is deleted).
    events: Vec<String>,
    max_delay: Duration,
    link: Link,
    phase: Phase,
    /// Requests other than events (discovery, availability,
    /// subscriptions, deletions, the goodbye), handed before them.
    outbox: VecDeque<Request>,
    /// Events not handed yet, oldest first.
    queue: VecDeque<Waiting>,
    /// The request last polled, until [`Delivery::handed`] says what
    /// became of it.
    in_hand: Option<InHand>,
    /// What was handed on this connection and not yet written, in order.
    unwritten: VecDeque<Unwritten>,
    /// Events written on this connection, by packet id, not yet
    /// acknowledged.
    unacked: Vec<(u16, Waiting)>,
    tally: Tally,
}

/// One event on its way.
#[derive(Debug, Clone)]
struct Waiting {
    message: String,
    /// When it was applied: it expires `max_delay` later.
    at: Instant,
}

/// A request handed and not yet written.
#[derive(Debug)]
enum Unwritten {
    Event(Waiting),
    /// Discovery, availability, a subscription or the disconnect.
    Other,
}

/// The request polled, waiting for its answer.
#[derive(Debug)]
enum InHand {
    Event(Waiting),
    Publish,
    Subscribe,
    Disconnect,
}

/// The broker's reachability.
#[derive(Debug, Clone, Copy)]
enum Link {
    /// Before the first answer (that wait is no outage).
    Starting,
    Up,
    Down {
        since: Instant,
    },
    /// The client's thread has ended, or the output closed.
    Gone,
}

/// Where the output is in its life.
#[derive(Debug, Clone, Copy)]
enum Phase {
    Running,
    /// Closing: the events in flight have until then to be acknowledged.
    Settling {
        until: Instant,
    },
    /// `offline` and the disconnect are handed; they have until then.
    Goodbye {
        until: Instant,
    },
    Closed,
}

impl Delivery {
    /// The delivery of `events` (each once) with `settings`' topics,
    /// discovery and `max_delay_ms`, before any connection.
    pub fn new(settings: &MqttSettings, events: &[HomeEvent]) -> Delivery {
        Delivery {
            topics: Topics::new(settings),
            configs: discovery::configs(settings, events),
            events: events.iter().map(|e| e.as_str().to_owned()).collect(),
            max_delay: Duration::from_millis(u64::from(settings.max_delay_ms)),
            link: Link::Starting,
            phase: Phase::Running,
            outbox: VecDeque::new(),
            queue: VecDeque::new(),
            in_hand: None,
            unwritten: VecDeque::new(),
            unacked: Vec::new(),
            tally: Tally::default(),
        }
    }

    /// One match's `message`, applied at `now`: it waits its turn, or is
    /// dropped and counted when [`QUEUE`] events already wait.
    pub fn apply(&mut self, message: String, now: Instant) {
        if self.queue.len() >= QUEUE {
            self.tally.queue_full += 1;
        } else {
            self.queue.push_back(Waiting { message, at: now });
        }
    }

    /// What the network reported, at `now`.
    pub fn notice(&mut self, notice: NetworkNotice, now: Instant) {
        match notice {
            NetworkNotice::Connected => self.on_connected(now),
            NetworkNotice::Broken(why) => self.on_broken(why, now),
            NetworkNotice::Written(written) => {
                if let (Some(Unwritten::Event(waiting)), Written::Publish(id)) =
                    (self.unwritten.pop_front(), written)
                {
                    self.unacked.push((id, waiting));
                }
            }
            NetworkNotice::Acked(id) => {
                if let Some(i) = self.unacked.iter().position(|(pkid, _)| *pkid == id) {
                    self.unacked.swap_remove(i);
                    self.tally.confirmed += 1;
                }
            }
            NetworkNotice::Message {
                topic,
                payload,
                retain,
            } => self.on_message(&topic, &payload, retain),
            NetworkNotice::Gone => self.on_gone(now),
        }
    }

    /// The next request to hand the client at `now`, if any: discovery
    /// and the like first, then the events in order (those that waited
    /// longer than `max_delay` are given up first). Say what became of it
    /// with [`Delivery::handed`] before polling again (unanswered, it
    /// counts as taken: the side on which nothing is sent twice).
    pub fn poll(&mut self, now: Instant) -> Option<Request> {
        if self.in_hand.is_some() {
            self.handed(Handed::Taken);
        }
        loop {
            if let Some(request) = self.outbox.pop_front() {
                self.in_hand = Some(match request {
                    Request::Publish { .. } => InHand::Publish,
                    Request::Subscribe { .. } => InHand::Subscribe,
                    Request::Disconnect => InHand::Disconnect,
                });
                return Some(request);
            }
            match self.phase {
                Phase::Running => return self.next_event(now),
                Phase::Settling { until } if !self.settled() && now < until => {
                    return self.next_event(now);
                }
                Phase::Settling { .. } => self.say_goodbye(now),
                Phase::Goodbye { until } => {
                    if !matches!(self.link, Link::Up) || now >= until {
                        self.phase = Phase::Closed;
                    }
                    return None;
                }
                Phase::Closed => return None,
            }
        }
    }

    /// What became of the request last polled; whether to poll again now
    /// (not after a refused event: the events behind it wait their turn).
    pub fn handed(&mut self, outcome: Handed) -> bool {
        let Some(in_hand) = self.in_hand.take() else {
            return true;
        };
        match (in_hand, outcome) {
            (InHand::Event(waiting), Handed::Taken) => {
                self.unwritten.push_back(Unwritten::Event(waiting));
            }
            (InHand::Event(waiting), Handed::Full | Handed::Closed) => {
                self.queue.push_front(waiting);
                return false;
            }
            (_, Handed::Taken) => self.unwritten.push_back(Unwritten::Other),
            (InHand::Publish, Handed::Full) => self.tally.announcements_refused += 1,
            // No disconnect to wait for.
            (InHand::Disconnect, _) => self.phase = Phase::Closed,
            (InHand::Publish | InHand::Subscribe, _) => {}
        }
        true
    }

    /// Begins closing at `now`: [`Delivery::poll`] hands the goodbye once
    /// the events in flight are acknowledged or [`CLOSE_WAIT`] has passed.
    pub fn close(&mut self, now: Instant) {
        if let Phase::Running = self.phase {
            self.phase = Phase::Settling {
                until: later(now, CLOSE_WAIT),
            };
        }
    }

    /// While closing, the latest time to poll again (a notice may come
    /// sooner); `None` once closed, or before [`Delivery::close`].
    pub fn closing_until(&self) -> Option<Instant> {
        match self.phase {
            Phase::Settling { until } | Phase::Goodbye { until } => Some(until),
            Phase::Running | Phase::Closed => None,
        }
    }

    /// Ends the accounts at `now`: the outage going on, the events still
    /// waiting or unacknowledged. Nothing is handed after it.
    pub fn finish(&mut self, now: Instant) {
        if self.in_hand.is_some() {
            self.handed(Handed::Taken);
        }
        self.on_gone(now);
        self.tally.unsent_at_close += self.queue.len() as u64;
        self.queue.clear();
        self.phase = Phase::Closed;
    }

    /// The report of `output` (its description): events acknowledged,
    /// lost, and the notes.
    pub fn report(&self, output: String) -> OutputReport {
        OutputReport {
            output,
            applied: self.tally.confirmed,
            dropped: 0,
            lost: self.tally.lost(),
            notes: self.tally.notes(self.max_delay, QUEUE),
            pointer_travel: None,
        }
    }

    /// A connection is up: end the outage, subscribe, announce the device.
    fn on_connected(&mut self, now: Instant) {
        self.end_outage(now);
        self.link = Link::Up;
        if !self.speaking() {
            return;
        }
        // Retained configs of events no longer in the library come back
        // on this subscription (before the new ones are published).
        self.outbox.push_back(Request::Subscribe {
            filter: self.topics.trigger_configs(),
            qos: Qos::AtMostOnce,
        });
        self.outbox.push_back(Request::Subscribe {
            filter: self.topics.ha_status.clone(),
            qos: Qos::AtLeastOnce,
        });
        self.announce();
    }

    /// Availability `online` and every discovery config, retained.
    fn announce(&mut self) {
        self.outbox
            .push_back(retained(&self.topics.availability, ONLINE));
        for (topic, config) in &self.configs {
            self.outbox.push_back(retained(topic, config));
        }
    }

    fn on_message(&mut self, topic: &str, payload: &[u8], retain: bool) {
        if !self.speaking() {
            return;
        }
        if topic == self.topics.ha_status {
            // A retained `online` is an old birth; discovery just went.
            if payload == ONLINE.as_bytes() && !retain {
                self.tally.rediscoveries += 1;
                self.announce();
            }
        } else if let Some(event) = self.topics.trigger_of(topic)
            && retain
            && !payload.is_empty()
            && !self.events.iter().any(|e| e == event)
        {
            // An empty retained config deletes the trigger.
            self.outbox.push_back(retained(topic, ""));
            self.tally.deleted_configs += 1;
        }
    }

    /// The connection broke: what was written and not acknowledged is
    /// lost; the events handed and never written wait for the next one.
    fn on_broken(&mut self, why: String, now: Instant) {
        self.tally.unconfirmed += self.unacked.len() as u64;
        self.unacked.clear();
        while let Some(unwritten) = self.unwritten.pop_back() {
            if let Unwritten::Event(waiting) = unwritten {
                self.queue.push_front(waiting);
            }
        }
        // Meant for the connection that broke; the next announces again.
        self.outbox.clear();
        match self.link {
            Link::Up => {
                self.tally.outages += 1;
                self.link = Link::Down { since: now };
            }
            Link::Starting => self.link = Link::Down { since: now },
            Link::Down { .. } | Link::Gone => {}
        }
        self.tally.last_why = Some(why);
    }

    /// The client's thread ended: nothing more can be sent.
    fn on_gone(&mut self, now: Instant) {
        self.end_outage(now);
        self.link = Link::Gone;
        self.tally.unacked_at_close += self.unacked.len() as u64;
        self.unacked.clear();
        for unwritten in self.unwritten.drain(..) {
            if let Unwritten::Event(_) = unwritten {
                self.tally.unsent_at_close += 1;
            }
        }
        self.outbox.clear();
    }

    fn end_outage(&mut self, now: Instant) {
        if let Link::Down { since } = self.link {
            self.tally.add_down(now.saturating_duration_since(since));
        }
    }

    /// The oldest event, if it may go now; gives up those that waited
    /// longer than `max_delay`.
    fn next_event(&mut self, now: Instant) -> Option<Request> {
        while let Some(front) = self.queue.front() {
            if now.saturating_duration_since(front.at) <= self.max_delay {
                break;
            }
            self.queue.pop_front();
            self.tally.expired += 1;
        }
        if !matches!(self.link, Link::Up) {
            return None;
        }
        let waiting = self.queue.pop_front()?;
        let request = Request::Publish {
            topic: self.topics.events.clone(),
            payload: waiting.message.clone(),
            retain: false,
        };
        self.in_hand = Some(InHand::Event(waiting));
        Some(request)
    }

    /// `offline` and the disconnect, if connected; else closed.
    fn say_goodbye(&mut self, now: Instant) {
        if matches!(self.link, Link::Up) {
            self.outbox
                .push_back(retained(&self.topics.availability, OFFLINE));
            self.outbox.push_back(Request::Disconnect);
            self.phase = Phase::Goodbye {
                until: later(now, CLOSE_WAIT),
            };
        } else {
            self.phase = Phase::Closed;
        }
    }

    /// Whether every event has been acknowledged (or can no longer be).
    fn settled(&self) -> bool {
        !matches!(self.link, Link::Up)
            || (self.queue.is_empty()
                && self.unacked.is_empty()
                && !self
                    .unwritten
                    .iter()
                    .any(|u| matches!(u, Unwritten::Event(_))))
    }

    /// Whether announcements may still go (not after the goodbye).
    fn speaking(&self) -> bool {
        matches!(self.phase, Phase::Running | Phase::Settling { .. })
    }
}

/// `now + wait`, or `now` where that would not fit in an [`Instant`].
fn later(now: Instant, wait: Duration) -> Instant {
    now.checked_add(wait).unwrap_or(now)
}

/// A retained publish.
fn retained(topic: &str, payload: &str) -> Request {
    Request::Publish {
        topic: topic.to_owned(),
        payload: payload.to_owned(),
        retain: true,
    }
}

#[cfg(test)]
mod tests;
