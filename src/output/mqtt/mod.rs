//! The home: each matched home event goes to Home Assistant over MQTT
//! (`--output mqtt`). Not RT-safe: runs on the runtime's output thread,
//! with the MQTT client on a thread of its own (`network.rs`).
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
//! light's toggle must never act twice — and is counted lost.
//!
//! `delivery.rs` decides all of that, without I/O (time is an argument);
//! [`MqttOutput`] is its shell: it holds rumqttc's client and its network
//! thread, reads the clock, feeds the delivery what the network reports
//! and hands the client what the delivery asks for. The loop never waits:
//! [`Output::apply`] only queues and hands messages to the client's
//! bounded channel.

pub mod credentials;
mod delivery;
pub mod discovery;
mod network;
mod tally;

use std::sync::Arc;
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, TryRecvError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime};

use rumqttc::{Client, LastWill, MqttOptions, QoS};

use crate::control::output_command::OutputCommand;
use crate::control::target::HomeEvent;
use crate::output::settings::MqttSettings;
use crate::output::{Output, OutputError, OutputReport};

use credentials::Credentials;
use delivery::{Delivery, Handed, NetworkNotice, Qos, Request};
use discovery::{OFFLINE, Topics};
use network::Gate;

pub use delivery::QUEUE;

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
/// Longest wait for a notice while closing, between looks at the clock.
const CLOSE_POLL: Duration = Duration::from_millis(20);
/// Largest packet either way (a library's discovery config fits).
const MAX_PACKET: usize = 256 * 1024;

/// Home Assistant over MQTT: rumqttc's client and its network thread
/// around a `Delivery` (`delivery.rs`), which decides. See the module's documentation.
pub struct MqttOutput {
    describe: String,
    client: Client,
    gate: Arc<Gate>,
    notices: Receiver<NetworkNotice>,
    /// Dropped to stop the network thread.
    stop: Option<Sender<()>>,
    thread: Option<JoinHandle<()>>,
    delivery: Delivery,
    tick_zero: Option<SystemTime>,
    report: Option<OutputReport>,
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
        let mut unique: Vec<HomeEvent> = Vec::new();
        for event in events {
            if !unique.iter().any(|u| u.as_str() == event.as_str()) {
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
                topics.availability,
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
            gate,
            notices,
            stop: Some(stop),
            thread: Some(thread),
            delivery: Delivery::new(settings, &unique),
            tick_zero: None,
            report: None,
        };
        // The first answer: the CONNACK, or why there is none.
        let wait = Duration::from_secs(CONNECT_TIMEOUT_S + 1);
        match output.receive(wait) {
            Some(NetworkNotice::Broken(why)) => {
                output.stop_thread();
                Err(error(format!(
                    "cannot connect to the broker at {address}: {why}"
                )))
            }
            None | Some(NetworkNotice::Gone) => {
                output.stop_thread();
                Err(error(format!(
                    "cannot connect to the broker at {address}: no answer within {} s",
                    wait.as_secs()
                )))
            }
            Some(answer) => {
                output.turn(Some(answer), None);
                Ok(output)
            }
        }
    }

    /// One turn, and the only place the clock is read: feeds the delivery
    /// `first` and every notice waiting, then `message` (a match), then
    /// hands the client what the delivery asks for. Returns the time read.
    fn turn(&mut self, first: Option<NetworkNotice>, message: Option<String>) -> Instant {
        let now = Instant::now();
        let mut next = first.or_else(|| self.receive(Duration::ZERO));
        while let Some(notice) = next {
            // Once gone, the channel says so at every look: once is enough.
            let gone = notice == NetworkNotice::Gone;
            self.delivery.notice(notice, now);
            next = if gone {
                None
            } else {
                self.receive(Duration::ZERO)
            };
        }
        if let Some(message) = message {
            self.delivery.apply(message, now);
        }
        while let Some(request) = self.delivery.poll(now) {
            let outcome = self.hand(request);
            if !self.delivery.handed(outcome) {
                break;
            }
        }
        now
    }

    /// The next notice, waiting up to `wait` for it; [`NetworkNotice::Gone`]
    /// once the network thread has ended.
    fn receive(&self, wait: Duration) -> Option<NetworkNotice> {
        let got = if wait.is_zero() {
            self.notices
                .try_recv()
                .map_err(|e| e == TryRecvError::Disconnected)
        } else {
            self.notices
                .recv_timeout(wait)
                .map_err(|e| e == RecvTimeoutError::Disconnected)
        };
        match got {
            Ok(notice) => Some(notice),
            Err(true) => Some(NetworkNotice::Gone),
            Err(false) => None,
        }
    }

    /// Hands one request to rumqttc if the connection is open (under the
    /// gate: it then belongs to that connection), without waiting.
    fn hand(&self, request: Request) -> Handed {
        let open = self.gate.lock();
        if !*open {
            return Handed::Closed;
        }
        let taken = match request {
            Request::Publish {
                topic,
                payload,
                retain,
            } => self
                .client
                .try_publish(topic, QoS::AtLeastOnce, retain, payload),
            Request::Subscribe { filter, qos } => {
                let qos = match qos {
                    Qos::AtMostOnce => QoS::AtMostOnce,
                    Qos::AtLeastOnce => QoS::AtLeastOnce,
                };
                self.client.try_subscribe(filter, qos)
            }
            Request::Disconnect => self.client.try_disconnect(),
        };
        if taken.is_ok() {
            Handed::Taken
        } else {
            Handed::Full
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

    /// Closes: the delivery's bounded wait for acknowledgements and the
    /// goodbye, then the report.
    fn finish(&mut self) -> OutputReport {
        let mut now = self.turn(None, None);
        self.delivery.close(now);
        let mut wait = Duration::ZERO;
        loop {
            let first = self.receive(wait);
            now = self.turn(first, None);
            let Some(until) = self.delivery.closing_until() else {
                break;
            };
            wait = until.saturating_duration_since(now).min(CLOSE_POLL);
        }
        self.stop_thread();
        self.delivery.finish(now);
        self.delivery.report(self.describe.clone())
    }
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
        let matched_at = self
            .tick_zero
            .and_then(|zero| zero.checked_add(Duration::from_millis(*tick)))
            .unwrap_or_else(SystemTime::now);
        let message = discovery::event_message(event, *tick, sequence, matched_at);
        self.turn(None, Some(message));
    }

    fn idle(&mut self) {
        self.turn(None, None);
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
