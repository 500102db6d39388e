//! The home: each matched home event goes to Home Assistant over MQTT
//! (`--output mqtt`). Not RT-safe: runs on the runtime's output thread,
//! with the MQTT client on a thread of its own ([`network`]).
//!
//! What is published ([`discovery`]): retained discovery configs (a
//! device trigger per event and one `event` entity), `online`/`offline`
//! on `<device_id>/availability` (retained; `offline` is also the
//! broker's last will), and one QoS 1 message per match on
//! `<device_id>/event`. Discovery goes again at every connection and
//! whenever Home Assistant announces itself `online` on
//! `<prefix>/status`; retained trigger configs of events no longer in the
//! library are deleted.
//!
//! Delivery is **at most once per match**: an event is held (in order, at
//! most [`QUEUE`] of them, each at most `max_delay_ms`) while the broker
//! is unreachable and sent once when it is back. An event written to a
//! connection that broke before the broker acknowledged it is *not* sent
//! again — it may or may not have arrived, and a home event such as a
//! light's toggle must never act twice — and is counted lost. The loop
//! never waits: [`Output::apply`] only queues and hands messages to the
//! client's bounded channel.

pub mod credentials;
pub mod discovery;
mod network;

use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, TryRecvError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime};

use rumqttc::{Client, Event, Incoming, LastWill, MqttOptions, Outgoing, QoS};

use crate::control::output_command::OutputCommand;
use crate::control::target::HomeEvent;
use crate::output::settings::MqttSettings;
use crate::output::{Output, OutputError, OutputReport};

use credentials::Credentials;
use discovery::{OFFLINE, ONLINE, Topics};
use network::{Gate, Notice};

/// Most events waiting for the broker; more are dropped and counted.
pub const QUEUE: usize = 64;
/// Requests rumqttc's channel holds (the discovery configs of a large
/// library fit at once).
const CHANNEL: usize = 512;
/// Notices the network thread may have outstanding.
const NOTICES: usize = 4096;
/// The keep-alive: a broker that stops answering is noticed within about
/// twice this.
const KEEP_ALIVE: Duration = Duration::from_secs(5);
/// How long connecting may take, s.
const CONNECT_TIMEOUT_S: u64 = 5;
/// How long [`Output::close`] waits for the events still queued or in
/// flight to be acknowledged, then for the goodbye to be written.
const CLOSE_WAIT: Duration = Duration::from_secs(2);
/// Largest packet either way (a library's discovery config fits).
const MAX_PACKET: usize = 256 * 1024;

/// Home Assistant over MQTT. See the module's documentation.
pub struct MqttOutput {
    describe: String,
    client: Client,
    topics: Topics,
    /// Retained discovery configs, `(topic, JSON)`.
    configs: Vec<(String, String)>,
    /// The library's event names (a retained trigger config of any other
    /// is deleted).
    events: Vec<String>,
    max_delay: Duration,
    tick_zero: Option<SystemTime>,
    gate: Arc<Gate>,
    notices: Receiver<Notice>,
    /// Dropped to stop the network thread.
    stop: Option<Sender<()>>,
    thread: Option<JoinHandle<()>>,
    link: Link,
    /// Events not handed to the client yet, oldest first.
    queue: VecDeque<Waiting>,
    /// What was handed to the client on this connection and not yet
    /// written, in order.
    handed: VecDeque<Handed>,
    /// Events written on this connection, by packet id, not yet
    /// acknowledged.
    unacked: Vec<(u16, Waiting)>,
    tally: Tally,
    report: Option<OutputReport>,
}

/// One event on its way.
#[derive(Debug, Clone)]
struct Waiting {
    message: String,
    /// When it was applied: it expires `max_delay` later.
    at: Instant,
}

/// A request handed to the client.
#[derive(Debug)]
enum Handed {
    Event(Waiting),
    /// Discovery, availability, a subscription or the disconnect.
    Other,
}

/// The broker's reachability.
#[derive(Debug, Clone)]
enum Link {
    Up,
    Down {
        since: Instant,
        why: String,
    },
    /// The client's thread has ended (only after close, or a failure of
    /// the client itself).
    Gone,
}

/// What happened to the events, for the report.
#[derive(Debug, Default, Clone)]
struct Tally {
    /// Acknowledged by the broker.
    confirmed: u64,
    /// Written to a connection that broke before the acknowledgement.
    unconfirmed: u64,
    /// Waited longer than `max_delay_ms` for the broker.
    expired: u64,
    /// Refused because [`QUEUE`] events were already waiting.
    queue_full: u64,
    /// Still waiting when the output closed.
    unsent_at_close: u64,
    /// Written, and not acknowledged when the output closed (a broker
    /// that stopped answering).
    unacked_at_close: u64,
    /// Times the connection broke.
    outages: u64,
    /// Time without a connection.
    down: Duration,
    longest_down: Duration,
    /// The last reason the broker could not be reached.
    last_why: Option<String>,
    /// Times Home Assistant came online and discovery went again.
    rediscoveries: u64,
    /// Retained configs of events no longer in the library, deleted.
    deleted_configs: u64,
    /// Discovery or availability messages the client's channel refused.
    announcements_refused: u64,
}

impl MqttOutput {
    /// Connects to the broker in `settings` for the library's `events`
    /// (the command line applies `--output mqtt:HOST:PORT` to `settings`
    /// first) and announces the device to Home Assistant. Waits for the
    /// broker's answer (at most about 5 s): a wrong address, a broker
    /// that is down, refused credentials or a world-readable credentials
    /// file are errors now, before the run starts. Not RT-safe.
    pub fn open(settings: &MqttSettings, events: &[HomeEvent]) -> Result<MqttOutput, OutputError> {
        let error = |detail: String| OutputError {
            output: "mqtt",
            detail,
        };
        let mut names: Vec<String> = Vec::new();
        let mut unique: Vec<HomeEvent> = Vec::new();
        for event in events {
            if !names.iter().any(|n| n == event.as_str()) {
                names.push(event.as_str().to_owned());
                unique.push(*event);
            }
        }
        if unique.is_empty() {
            return Err(error(
                "the library fires no home event: give a [[sequence]] an `event = \"…\"`".into(),
            ));
        }
        let address = format!("{}:{}", settings.host, settings.port);
        let topics = Topics::new(settings);

        let client_id = format!("sipnpuff-{}-{}", settings.device_id, std::process::id());
        let mut options = MqttOptions::new(client_id, settings.host.clone(), settings.port);
        options
            .set_keep_alive(KEEP_ALIVE)
            .set_clean_session(true)
            .set_max_packet_size(MAX_PACKET, MAX_PACKET)
            .set_last_will(LastWill::new(
                topics.availability.clone(),
                OFFLINE,
                QoS::AtLeastOnce,
                true,
            ));
        if let Some(path) = &settings.credentials_file {
            let c = Credentials::read(path).map_err(error)?;
            options.set_credentials(c.username, c.password);
        }
        if settings.tls {
            options.set_transport(tls_transport().map_err(error)?);
        }

        let (client, mut connection) = Client::new(options, CHANNEL);
        let mut network_options = rumqttc::NetworkOptions::new();
        network_options.set_connection_timeout(CONNECT_TIMEOUT_S);
        connection.eventloop.set_network_options(network_options);
        let gate = Arc::new(Gate::default());
        let (notice_tx, notices) = std::sync::mpsc::sync_channel(NOTICES);
        let (stop, stop_rx) = std::sync::mpsc::channel();
        let thread = {
            let gate = Arc::clone(&gate);
            std::thread::Builder::new()
                .name("mqtt".into())
                .spawn(move || {
                    network::run(connection, gate, notice_tx, stop_rx, CONNECT_TIMEOUT_S)
                })
                .map_err(|e| error(format!("cannot start the MQTT client's thread: {e}")))?
        };

        let mut output = MqttOutput {
            describe: format!(
                "mqtt {address} (device \"{}\", {} home event{})",
                settings.device_id,
                unique.len(),
                if unique.len() == 1 { "" } else { "s" }
            ),
            client,
            configs: discovery::configs(settings, &unique),
            topics,
            events: names,
            max_delay: Duration::from_millis(u64::from(settings.max_delay_ms)),
            tick_zero: None,
            gate,
            notices,
            stop: Some(stop),
            thread: Some(thread),
            link: Link::Down {
                since: Instant::now(),
                why: "not connected yet".into(),
            },
            queue: VecDeque::new(),
            handed: VecDeque::new(),
            unacked: Vec::new(),
            tally: Tally::default(),
            report: None,
        };
        // The first answer: the CONNACK, or why there is none.
        let wait = Duration::from_secs(CONNECT_TIMEOUT_S + 1);
        match output.notices.recv_timeout(wait) {
            Ok(Notice::Event(event)) => output.on_event(event),
            Ok(Notice::Broken(why)) => {
                output.stop_thread();
                return Err(error(format!(
                    "cannot connect to the broker at {address}: {why}"
                )));
            }
            Err(_) => {
                output.stop_thread();
                return Err(error(format!(
                    "cannot connect to the broker at {address}: no answer within {} s",
                    wait.as_secs()
                )));
            }
        }
        // The wait to connect is no outage.
        output.tally.down = Duration::ZERO;
        output.tally.longest_down = Duration::ZERO;
        output.pump();
        Ok(output)
    }

    /// Takes every notice waiting, then sends what the queue holds.
    fn pump(&mut self) {
        loop {
            match self.notices.try_recv() {
                Ok(notice) => self.on_notice(notice),
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => {
                    self.on_gone();
                    break;
                }
            }
        }
        self.flush();
    }

    fn on_notice(&mut self, notice: Notice) {
        match notice {
            Notice::Event(event) => self.on_event(event),
            Notice::Broken(why) => self.on_broken(why),
        }
    }

    fn on_event(&mut self, event: Event) {
        match event {
            Event::Incoming(Incoming::ConnAck(_)) => self.on_connected(),
            Event::Incoming(Incoming::PubAck(ack)) => {
                if let Some(i) = self.unacked.iter().position(|(id, _)| *id == ack.pkid) {
                    self.unacked.swap_remove(i);
                    self.tally.confirmed += 1;
                }
            }
            Event::Incoming(Incoming::Publish(publish)) => {
                self.on_message(&publish.topic, &publish.payload, publish.retain);
            }
            // A request leaves rumqttc's channel: the next one handed.
            Event::Outgoing(Outgoing::Publish(pkid)) => {
                if let Some(Handed::Event(waiting)) = self.handed.pop_front() {
                    self.unacked.push((pkid, waiting));
                }
            }
            Event::Outgoing(
                Outgoing::Subscribe(_) | Outgoing::Unsubscribe(_) | Outgoing::Disconnect,
            ) => {
                self.handed.pop_front();
            }
            _ => {}
        }
    }

    /// A connection is up: end the outage, announce the device, send what
    /// waited.
    fn on_connected(&mut self) {
        if let Link::Down { since, .. } = self.link {
            let down = since.elapsed();
            self.tally.down += down;
            self.tally.longest_down = self.tally.longest_down.max(down);
        }
        self.link = Link::Up;
        // Retained configs of events no longer in the library come back
        // on this subscription (before the new ones are published).
        self.subscribe(self.topics.trigger_configs(), QoS::AtMostOnce);
        self.subscribe(self.topics.ha_status.clone(), QoS::AtLeastOnce);
        self.announce();
    }

    /// Availability `online` and every discovery config, retained.
    fn announce(&mut self) {
        let availability = self.topics.availability.clone();
        self.hand_other(&availability, ONLINE.to_owned());
        for (topic, config) in self.configs.clone() {
            self.hand_other(&topic, config);
        }
    }

    fn on_message(&mut self, topic: &str, payload: &[u8], retain: bool) {
        if topic == self.topics.ha_status {
            // A retained `online` is an old birth; discovery just went.
            if payload == ONLINE.as_bytes() && !retain {
                self.tally.rediscoveries += 1;
                self.announce();
            }
        } else if let Some(event) = self.topics.trigger_of(topic) {
            let stale = retain && !payload.is_empty() && !self.events.iter().any(|e| e == event);
            if stale {
                // An empty retained config deletes the trigger.
                let topic = topic.to_owned();
                self.hand_other(&topic, String::new());
                self.tally.deleted_configs += 1;
            }
        }
    }

    /// The connection broke: what was written and not acknowledged is
    /// lost; what was handed and never written waits for the next one.
    fn on_broken(&mut self, why: String) {
        self.tally.unconfirmed += self.unacked.len() as u64;
        self.unacked.clear();
        let never_written: Vec<Waiting> = self
            .handed
            .drain(..)
            .filter_map(|h| match h {
                Handed::Event(w) => Some(w),
                Handed::Other => None,
            })
            .collect();
        for waiting in never_written.into_iter().rev() {
            self.queue.push_front(waiting);
        }
        if matches!(self.link, Link::Up) {
            self.tally.outages += 1;
            self.link = Link::Down {
                since: Instant::now(),
                why: why.clone(),
            };
        } else if let Link::Down { why: last, .. } = &mut self.link {
            last.clone_from(&why);
        }
        self.tally.last_why = Some(why);
    }

    /// The client's thread ended: nothing more can be sent.
    fn on_gone(&mut self) {
        if let Link::Down { since, .. } = self.link {
            let down = since.elapsed();
            self.tally.down += down;
            self.tally.longest_down = self.tally.longest_down.max(down);
        }
        self.tally.unacked_at_close += self.unacked.len() as u64;
        self.unacked.clear();
        for handed in self.handed.drain(..) {
            if let Handed::Event(_) = handed {
                self.tally.unsent_at_close += 1;
            }
        }
        self.link = Link::Gone;
    }

    /// Hands the waiting events to the client while connected, oldest
    /// first; gives up those that waited longer than `max_delay`.
    fn flush(&mut self) {
        while let Some(front) = self.queue.front() {
            let up = matches!(self.link, Link::Up);
            if up && self.hand_event(front.message.clone()) {
                if let Some(waiting) = self.queue.pop_front() {
                    self.handed.push_back(Handed::Event(waiting));
                }
            } else if front.at.elapsed() > self.max_delay {
                self.queue.pop_front();
                self.tally.expired += 1;
            } else {
                break; // down, closing, or the client's channel is full
            }
        }
    }

    /// Hands one event's message to the client if the connection is
    /// open; whether it took it.
    fn hand_event(&self, message: String) -> bool {
        let open = self.gate.lock();
        *open
            && self
                .client
                .try_publish(self.topics.events.clone(), QoS::AtLeastOnce, false, message)
                .is_ok()
    }

    /// Hands a retained message that is not an event (discovery,
    /// availability) to the client, if the connection is open.
    fn hand_other(&mut self, topic: &str, payload: String) {
        let open = self.gate.lock();
        if !*open {
            return;
        }
        match self
            .client
            .try_publish(topic, QoS::AtLeastOnce, true, payload)
        {
            Ok(()) => self.handed.push_back(Handed::Other),
            Err(_) => self.tally.announcements_refused += 1,
        }
    }

    fn subscribe(&mut self, filter: String, qos: QoS) {
        let open = self.gate.lock();
        if *open && self.client.try_subscribe(filter, qos).is_ok() {
            self.handed.push_back(Handed::Other);
        }
    }

    /// Whether every event has been acknowledged (or can no longer be).
    fn settled(&self) -> bool {
        !matches!(self.link, Link::Up)
            || (self.queue.is_empty()
                && self.unacked.is_empty()
                && !self.handed.iter().any(|h| matches!(h, Handed::Event(_))))
    }

    /// Waits for the next notice until `deadline`; whether one came.
    fn wait_notice(&mut self, deadline: Instant) -> bool {
        let left = deadline.saturating_duration_since(Instant::now());
        match self
            .notices
            .recv_timeout(left.min(Duration::from_millis(20)))
        {
            Ok(notice) => {
                self.on_notice(notice);
                true
            }
            Err(RecvTimeoutError::Timeout) => false,
            Err(RecvTimeoutError::Disconnected) => {
                self.on_gone();
                false
            }
        }
    }

    /// Tells the network thread to end; joins it if it has.
    fn stop_thread(&mut self) {
        self.stop = None;
        // A thread blocked on the network ends when that returns (its
        // channels are gone), on its own.
        if let Some(thread) = self.thread.take()
            && thread.is_finished()
        {
            let _ = thread.join();
        }
    }

    fn finish(&mut self) -> OutputReport {
        let deadline = Instant::now() + CLOSE_WAIT;
        // The events still queued or in flight, acknowledged.
        loop {
            self.pump();
            if self.settled() || Instant::now() >= deadline {
                break;
            }
            self.wait_notice(deadline);
        }
        // The goodbye: `offline` (retained), then DISCONNECT, so the
        // broker keeps `offline` and drops the last will.
        if matches!(self.link, Link::Up) {
            let availability = self.topics.availability.clone();
            self.hand_other(&availability, OFFLINE.to_owned());
            let asked = {
                let open = self.gate.lock();
                *open && self.client.try_disconnect().is_ok()
            };
            if asked {
                self.handed.push_back(Handed::Other);
                let deadline = Instant::now() + CLOSE_WAIT;
                while !matches!(self.link, Link::Gone) && Instant::now() < deadline {
                    self.wait_notice(deadline);
                }
            }
        }
        if let Link::Down { since, .. } = self.link {
            let down = since.elapsed();
            self.tally.down += down;
            self.tally.longest_down = self.tally.longest_down.max(down);
            self.link = Link::Gone;
        }
        self.stop_thread();
        let t = &mut self.tally;
        t.unacked_at_close += self.unacked.len() as u64;
        self.unacked.clear();
        t.unsent_at_close += self.queue.len() as u64;
        self.queue.clear();
        t.unsent_at_close += self
            .handed
            .drain(..)
            .filter(|h| matches!(h, Handed::Event(_)))
            .count() as u64;
        OutputReport {
            output: self.describe.clone(),
            applied: t.confirmed,
            dropped: 0,
            lost: t.lost(),
            notes: t.notes(self.max_delay),
            pointer_travel: None,
        }
    }
}

impl Tally {
    fn lost(&self) -> u64 {
        self.unconfirmed
            + self.expired
            + self.queue_full
            + self.unsent_at_close
            + self.unacked_at_close
    }

    /// What went wrong, in plain words.
    fn notes(&self, max_delay: Duration) -> Vec<String> {
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
            let mut parts = Vec::new();
            if self.unconfirmed > 0 {
                parts.push(format!(
                    "{} sent as the connection broke, never acknowledged (not sent again: it may have arrived, never twice)",
                    self.unconfirmed
                ));
            }
            if self.expired > 0 {
                parts.push(format!(
                    "{} waited longer than {:.1} s for the broker",
                    self.expired,
                    secs(max_delay)
                ));
            }
            if self.queue_full > 0 {
                parts.push(format!(
                    "{} found {QUEUE} events already waiting",
                    self.queue_full
                ));
            }
            if self.unacked_at_close > 0 {
                parts.push(format!(
                    "{} sent but not acknowledged by the end (the broker stopped answering; they may have arrived)",
                    self.unacked_at_close
                ));
            }
            if self.unsent_at_close > 0 {
                parts.push(format!(
                    "{} still waiting for the broker at the end",
                    self.unsent_at_close
                ));
            }
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

impl Output for MqttOutput {
    fn describe(&self) -> String {
        self.describe.clone()
    }

    fn begin(&mut self, tick_zero: SystemTime) {
        self.tick_zero = Some(tick_zero);
    }

    fn apply(&mut self, command: &OutputCommand) {
        let OutputCommand::Home {
            event,
            tick,
            sequence,
        } = command
        else {
            return; // the computer's commands; nothing to let go of here
        };
        self.pump();
        let matched_at = self
            .tick_zero
            .map_or_else(SystemTime::now, |zero| zero + Duration::from_millis(*tick));
        let message = discovery::event_message(event, *tick, sequence, matched_at);
        if self.queue.len() >= QUEUE {
            self.tally.queue_full += 1;
        } else {
            self.queue.push_back(Waiting {
                message,
                at: Instant::now(),
            });
        }
        self.flush();
    }

    fn idle(&mut self) {
        self.pump();
    }

    fn close(&mut self) -> OutputReport {
        if let Some(report) = &self.report {
            return report.clone();
        }
        let report = self.finish();
        self.report = Some(report.clone());
        report
    }
}

/// The TLS transport: rustls with the ring provider and the system's root
/// certificates.
#[cfg(feature = "mqtt-tls")]
fn tls_transport() -> Result<rumqttc::Transport, String> {
    let mut roots = rustls::RootCertStore::empty();
    for cert in rustls_native_certs::load_native_certs().certs {
        let _ = roots.add(cert);
    }
    if roots.is_empty() {
        return Err(
            "tls = true, but this system has no root certificates (install ca-certificates)".into(),
        );
    }
    let provider = Arc::new(rustls::crypto::ring::default_provider());
    let config = rustls::ClientConfig::builder_with_provider(provider)
        .with_safe_default_protocol_versions()
        .map_err(|e| format!("TLS: {e}"))?
        .with_root_certificates(roots)
        .with_no_client_auth();
    Ok(rumqttc::Transport::tls_with_config(
        rumqttc::TlsConfiguration::Rustls(Arc::new(config)),
    ))
}

/// This build has no TLS: say so, and how to get it.
#[cfg(not(feature = "mqtt-tls"))]
fn tls_transport() -> Result<rumqttc::Transport, String> {
    Err("tls = true, but this sipnpuff was built without TLS: \
         build it with `cargo build --release --features mqtt-tls`, \
         or set `[output.mqtt] tls = false` for a broker without TLS"
        .into())
}
