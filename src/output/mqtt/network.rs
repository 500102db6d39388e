//! The MQTT client's own thread: it drives rumqttc's connection (connect,
//! read, write, keep-alive, reconnect with backoff) and reports what
//! happened, in order and as plain [`NetworkNotice`]s, to the output's thread.
//! Nothing here waits on the output, and the output never waits on the
//! network.
//!
//! At-most-once delivery rests on two things done here. The session is
//! clean, and when a connection breaks this thread closes the [`Gate`],
//! drains every request the output handed to rumqttc and drops them:
//! rumqttc never sends anything of a broken connection again (it would
//! resend unacknowledged publishes with DUP). The output learns of the
//! break after every notification of that connection, so it knows which
//! of its events had been written (unconfirmed: lost, never resent) and
//! which had not (sent again on the next connection).

use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender, TryRecvError};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use rumqttc::{
    ConnectReturnCode, Connection, ConnectionError, Event, Incoming, Outgoing, StateError,
};

use super::delivery::{NetworkNotice, Written};

/// First wait before reconnecting; it doubles up to [`MAX_BACKOFF`].
const FIRST_BACKOFF: Duration = Duration::from_millis(100);
/// Longest wait between attempts to reconnect.
const MAX_BACKOFF: Duration = Duration::from_secs(2);

/// Whether the output may hand requests to rumqttc: open from a
/// connection's CONNACK until it breaks. The network thread closes it and
/// drains rumqttc's requests under the lock, so every request the output
/// handed belongs to exactly one connection.
#[derive(Debug, Default)]
pub struct Gate(Mutex<bool>);

impl Gate {
    /// The lock (a poisoned lock is still a valid flag).
    pub fn lock(&self) -> MutexGuard<'_, bool> {
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// Runs `connection` until the output is gone or asked to stop, sending
/// [`NetworkNotice`]s. Not RT-safe (the MQTT client's own thread).
pub fn run(
    mut connection: Connection,
    gate: Arc<Gate>,
    notices: SyncSender<NetworkNotice>,
    stop: Receiver<()>,
    connect_timeout_s: u64,
) {
    let mut backoff = FIRST_BACKOFF;
    loop {
        match connection.recv() {
            Ok(Ok(event)) => {
                let connected = matches!(event, Event::Incoming(Incoming::ConnAck(_)));
                if connected {
                    *gate.lock() = true;
                    backoff = FIRST_BACKOFF;
                }
                let disconnected = matches!(event, Event::Outgoing(Outgoing::Disconnect));
                let sent = notice_of(event).is_none_or(|notice| notices.send(notice).is_ok());
                if !sent || disconnected || stopped(&stop) {
                    return; // the output is gone or closed, or closed the connection
                }
            }
            Ok(Err(error)) => {
                let leftovers: Vec<Event> = {
                    let mut open = gate.lock();
                    *open = false;
                    let eventloop = &mut connection.eventloop;
                    // Requests handed since rumqttc's own clean-up, then
                    // all of them: nothing of this connection is resent.
                    eventloop.clean();
                    eventloop.pending.clear();
                    eventloop.state.events.drain(..).collect()
                };
                for notice in leftovers.into_iter().filter_map(notice_of) {
                    if notices.send(notice).is_err() {
                        return;
                    }
                }
                if notices
                    .send(NetworkNotice::Broken(plain(&error, connect_timeout_s)))
                    .is_err()
                {
                    return;
                }
                match stop.recv_timeout(backoff) {
                    Err(RecvTimeoutError::Timeout) => {}
                    Ok(()) | Err(RecvTimeoutError::Disconnected) => return,
                }
                backoff = (backoff * 2).min(MAX_BACKOFF);
            }
            // Every client handle is gone: the output was dropped.
            Err(_) => return,
        }
    }
}

/// What the delivery needs to know of one of rumqttc's notifications
/// (pings and the acknowledgements this client sends are not).
fn notice_of(event: Event) -> Option<NetworkNotice> {
    Some(match event {
        Event::Incoming(Incoming::ConnAck(_)) => NetworkNotice::Connected,
        Event::Incoming(Incoming::PubAck(ack)) => NetworkNotice::Acked(ack.pkid),
        Event::Incoming(Incoming::Publish(publish)) => NetworkNotice::Message {
            topic: publish.topic,
            payload: publish.payload.to_vec(),
            retain: publish.retain,
        },
        Event::Outgoing(Outgoing::Publish(pkid)) => NetworkNotice::Written(Written::Publish(pkid)),
        Event::Outgoing(Outgoing::Subscribe(_) | Outgoing::Unsubscribe(_)) => {
            NetworkNotice::Written(Written::Subscribe)
        }
        Event::Outgoing(Outgoing::Disconnect) => NetworkNotice::Written(Written::Disconnect),
        _ => return None,
    })
}

/// Whether the output has asked this thread to end (it drops its end).
fn stopped(stop: &Receiver<()>) -> bool {
    !matches!(stop.try_recv(), Err(TryRecvError::Empty))
}

/// Why a connection broke or could not be made, for people.
pub fn plain(error: &ConnectionError, connect_timeout_s: u64) -> String {
    match error {
        ConnectionError::Io(e) if e.kind() == std::io::ErrorKind::ConnectionRefused => {
            "connection refused (no broker listens there)".into()
        }
        ConnectionError::Io(e) => format!("network error: {e}"),
        ConnectionError::ConnectionRefused(code) => match code {
            ConnectReturnCode::BadUserNamePassword => {
                "the broker refused the user name or password".into()
            }
            ConnectReturnCode::NotAuthorized => {
                "the broker refused the connection: not authorised (a wrong user name or password, \
                 or none given where the broker needs one: see credentials_file)"
                    .into()
            }
            ConnectReturnCode::ServiceUnavailable => "the broker is unavailable".into(),
            other => format!("the broker refused the connection ({other:?})"),
        },
        ConnectionError::NetworkTimeout => {
            format!("no answer from the broker within {connect_timeout_s} s")
        }
        ConnectionError::FlushTimeout => "the broker stopped reading".into(),
        ConnectionError::MqttState(StateError::AwaitPingResp) => {
            "the broker stopped answering (no reply to the keep-alive ping)".into()
        }
        ConnectionError::MqttState(StateError::Io(e)) => format!("network error: {e}"),
        ConnectionError::MqttState(StateError::ConnectionAborted) => {
            "the broker closed the connection".into()
        }
        other => other.to_string(),
    }
}
