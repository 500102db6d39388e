//! The delivery case by case on a simulated clock: a [`Sim`] plays the
//! network and the client around it, and each test reads as its
//! scenario, with the exact requests handed and the exact figures.

use std::collections::VecDeque;

use super::*;

/// The library: two events, with the default topics (`sipnpuff`,
/// `homeassistant`).
fn library() -> [HomeEvent; 2] {
    [
        HomeEvent::new("lights_toggle").unwrap(),
        HomeEvent::new("call_for_help").unwrap(),
    ]
}

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// A match's message on the events' topic.
fn event(message: &str) -> Request {
    Request::Publish {
        topic: "sipnpuff/event".into(),
        payload: message.into(),
        retain: false,
    }
}

/// `online` and every discovery config, retained, in that order.
fn discovery() -> Vec<Request> {
    let configs = discovery::configs(&MqttSettings::default(), &library());
    let topics: Vec<&str> = configs.iter().map(|(t, _)| t.as_str()).collect();
    assert_eq!(
        topics,
        [
            "homeassistant/device_automation/sipnpuff/lights_toggle/config",
            "homeassistant/device_automation/sipnpuff/call_for_help/config",
            "homeassistant/event/sipnpuff/home_events/config",
        ]
    );
    let mut requests = vec![retained("sipnpuff/availability", "online")];
    requests.extend(configs.iter().map(|(t, c)| retained(t, c)));
    requests
}

/// What every connection hands first: the two subscriptions, then
/// [`discovery`].
fn connection() -> Vec<Request> {
    let mut requests = vec![
        Request::Subscribe {
            filter: "homeassistant/device_automation/sipnpuff/+/config".into(),
            qos: Qos::AtMostOnce,
        },
        Request::Subscribe {
            filter: "homeassistant/status".into(),
            qos: Qos::AtLeastOnce,
        },
    ];
    requests.extend(discovery());
    requests
}

/// [`connection`], then these events.
fn connection_then(events: &[&str]) -> Vec<Request> {
    let mut requests = connection();
    requests.extend(events.iter().map(|m| event(m)));
    requests
}

/// The goodbye: `offline`, retained, then the disconnect.
fn goodbye() -> Vec<Request> {
    vec![
        retained("sipnpuff/availability", "offline"),
        Request::Disconnect,
    ]
}

const REFUSED: &str = "connection refused (no broker listens there)";
const CLOSED: &str = "the broker closed the connection";

/// A delivery on a simulated clock, with a client that takes what it is
/// handed and writes it when told, numbering publishes from 1.
struct Sim {
    delivery: Delivery,
    start: Instant,
    now: Instant,
    /// Taken by the client and not written yet, in order.
    taken: VecDeque<Request>,
    next_id: u16,
}

impl Sim {
    /// The library's delivery, `max_delay_ms` 10 s, not connected yet.
    fn new() -> Sim {
        Sim::with_max_delay(10_000)
    }

    fn with_max_delay(max_delay_ms: u32) -> Sim {
        let settings = MqttSettings {
            max_delay_ms,
            ..MqttSettings::default()
        };
        let start = Instant::now();
        Sim {
            delivery: Delivery::new(&settings, &library()),
            start,
            now: start,
            taken: VecDeque::new(),
            next_id: 1,
        }
    }

    /// The clock, `t` ms after the start.
    fn at(&mut self, t: u64) -> &mut Sim {
        self.now = self.start + ms(t);
        self
    }

    fn instant(&self, t: u64) -> Instant {
        self.start + ms(t)
    }

    fn apply(&mut self, message: &str) -> &mut Sim {
        self.delivery.apply(message.into(), self.now);
        self
    }

    fn notice(&mut self, notice: NetworkNotice) -> &mut Sim {
        self.delivery.notice(notice, self.now);
        self
    }

    /// Polls until the delivery has nothing more now, the client taking
    /// everything; what was handed.
    fn turn(&mut self) -> Vec<Request> {
        let mut handed = Vec::new();
        while let Some(request) = self.delivery.poll(self.now) {
            handed.push(request.clone());
            self.taken.push_back(request);
            assert!(self.delivery.handed(Handed::Taken));
        }
        handed
    }

    /// Polls with a client that refuses everything (`why`); what was
    /// offered.
    fn refusing(&mut self, why: Handed) -> Vec<Request> {
        let mut offered = Vec::new();
        while let Some(request) = self.delivery.poll(self.now) {
            offered.push(request);
            if !self.delivery.handed(why) {
                break;
            }
        }
        offered
    }

    /// The broker accepts a connection; what is handed at once.
    fn connect(&mut self) -> Vec<Request> {
        self.notice(NetworkNotice::Connected).turn()
    }

    /// The connection breaks, and the client drops what it still held
    /// (the network thread does so).
    fn broken(&mut self, why: &str) -> &mut Sim {
        self.taken.clear();
        self.notice(NetworkNotice::Broken(why.into()))
    }

    /// The client writes the first `n` requests it took; the packet ids
    /// of the events among them.
    fn write(&mut self, n: usize) -> Vec<u16> {
        let mut ids = Vec::new();
        for _ in 0..n {
            let written = match self.taken.pop_front().unwrap() {
                Request::Publish { topic, .. } => {
                    let id = self.next_id;
                    self.next_id += 1;
                    if topic == "sipnpuff/event" {
                        ids.push(id);
                    }
                    Written::Publish(id)
                }
                Request::Subscribe { .. } => Written::Subscribe,
                Request::Disconnect => Written::Disconnect,
            };
            self.notice(NetworkNotice::Written(written));
        }
        ids
    }

    /// The client writes everything it took.
    fn write_all(&mut self) -> Vec<u16> {
        self.write(self.taken.len())
    }

    /// The broker acknowledges every one of `ids`.
    fn ack(&mut self, ids: &[u16]) -> &mut Sim {
        for &id in ids {
            self.notice(NetworkNotice::Acked(id));
        }
        self
    }

    /// The client writes everything it took, and the broker acknowledges
    /// it all.
    fn deliver(&mut self) {
        let ids = self.write_all();
        self.ack(&ids);
    }

    /// Connected, everything written and acknowledged.
    fn settled_connection(&mut self) {
        assert_eq!(self.connect(), connection());
        self.deliver();
    }

    /// The connection breaks at `from` ms (`why`) and is back at `to`;
    /// what is handed then.
    fn outage(&mut self, from: u64, to: u64, why: &str) -> Vec<Request> {
        self.at(from).broken(why);
        self.at(to).connect()
    }

    /// A message from the broker.
    fn message(&mut self, topic: &str, payload: &str, retain: bool) -> Vec<Request> {
        self.notice(NetworkNotice::Message {
            topic: topic.into(),
            payload: payload.as_bytes().to_vec(),
            retain,
        })
        .turn()
    }

    fn close(&mut self) -> &mut Sim {
        self.delivery.close(self.now);
        self
    }

    /// Ends the accounts now; the report's figures are `applied`, `lost`
    /// and `notes`, exactly.
    fn ends_with(&mut self, applied: u64, lost: u64, notes: &[&str]) {
        self.delivery.finish(self.now);
        let report = self.delivery.report("mqtt".into());
        assert_eq!((report.applied, report.lost), (applied, lost), "{report:?}");
        assert_eq!(report.notes, notes);
    }
}

// ------------------------------------------------ discovery and availability

#[test]
fn each_connection_subscribes_then_announces_online_and_every_config() {
    let mut sim = Sim::new();
    assert_eq!(sim.turn(), []);
    assert_eq!(sim.at(10).connect(), connection());
    sim.write_all();
    assert_eq!(sim.at(500).turn(), []);
    assert_eq!(sim.outage(1000, 1300, CLOSED), connection());
    sim.write_all();
    assert_eq!(sim.outage(2000, 2100, CLOSED), connection());
    assert_eq!(
        sim.delivery.tally,
        Tally {
            outages: 2,
            down: ms(400),
            longest_down: ms(300),
            last_why: Some(CLOSED.into()),
            ..Tally::default()
        }
    );
}

#[test]
fn home_assistants_online_brings_discovery_again() {
    let mut sim = Sim::new();
    sim.settled_connection();
    let status = "homeassistant/status";
    assert_eq!(sim.message(status, "online", false), discovery());
    // A retained `online` is an old birth; `offline` asks for nothing.
    assert_eq!(sim.message(status, "online", true), []);
    assert_eq!(sim.message(status, "offline", false), []);
    assert_eq!(sim.delivery.tally.rediscoveries, 1);
    sim.ends_with(0, 0, &[]);
}

#[test]
fn retained_configs_of_events_no_longer_in_the_library_are_deleted() {
    let mut sim = Sim::new();
    sim.settled_connection();
    let old = "homeassistant/device_automation/sipnpuff/old_event/config";
    let config = r#"{"automation_type":"trigger"}"#;
    assert_eq!(sim.message(old, config, true), [retained(old, "")]);
    // The library's own, the deletion coming back, a live message and
    // another device's: left alone.
    let lights = "homeassistant/device_automation/sipnpuff/lights_toggle/config";
    assert_eq!(sim.message(lights, config, true), []);
    assert_eq!(sim.message(old, "", true), []);
    assert_eq!(sim.message(old, config, false), []);
    let other = "homeassistant/device_automation/bob/old_event/config";
    assert_eq!(sim.message(other, config, true), []);
    sim.ends_with(
        0,
        0,
        &["deleted 1 Home Assistant trigger(s) of events no longer in the library"],
    );
}

#[test]
fn a_refused_announcement_is_counted_one_for_a_closing_connection_is_not() {
    let mut sim = Sim::new();
    sim.notice(NetworkNotice::Connected);
    assert_eq!(sim.refusing(Handed::Full), connection());
    sim.notice(NetworkNotice::Connected);
    assert_eq!(sim.refusing(Handed::Closed), connection());
    sim.ends_with(
        0,
        0,
        &["4 discovery or availability messages could not be queued"],
    );
}

// ------------------------------------------------ events: waiting and order

#[test]
fn an_event_applied_while_down_goes_once_when_the_broker_is_back() {
    let mut sim = Sim::new();
    sim.settled_connection();
    sim.at(1000).broken(REFUSED);
    sim.at(1200).apply("m1");
    assert_eq!(sim.turn(), []);
    assert_eq!(sim.at(1500).connect(), connection_then(&["m1"]));
    sim.deliver();
    assert_eq!(sim.at(1600).turn(), []);
    // Acknowledged: never again, whatever the connection does.
    assert_eq!(sim.outage(2000, 2100, CLOSED), connection());
    sim.ends_with(
        1,
        0,
        &[&format!(
            "the broker was unreachable for 0.6 s (2 times, the longest 0.5 s); last: {CLOSED}"
        )],
    );
}

#[test]
fn events_go_in_order_and_a_refused_one_waits_with_those_behind_it() {
    let mut sim = Sim::new();
    sim.settled_connection();
    sim.apply("m1").apply("m2");
    // The client's channel is full: m1 is offered, m2 not even that.
    assert_eq!(sim.refusing(Handed::Full), [event("m1")]);
    sim.apply("m3");
    assert_eq!(sim.refusing(Handed::Closed), [event("m1")]);
    assert_eq!(sim.turn(), [event("m1"), event("m2"), event("m3")]);
    sim.deliver();
    sim.ends_with(3, 0, &[]);
}

#[test]
fn an_event_expires_after_max_delay_to_the_millisecond() {
    let mut sim = Sim::with_max_delay(200);
    sim.at(0).apply("m1");
    sim.at(1).apply("m2");
    assert_eq!(sim.at(200).turn(), []);
    assert_eq!(sim.delivery.tally.expired, 0);
    // At 201 ms m1 has waited 201 ms (given up), m2 200 ms (sent).
    assert_eq!(sim.at(201).connect(), connection_then(&["m2"]));
    sim.deliver();
    sim.ends_with(
        1,
        1,
        &["1 event was lost: 1 waited longer than 0.2 s for the broker"],
    );
}

#[test]
fn an_event_expires_while_the_broker_stays_away_and_zero_never_waits() {
    let mut sim = Sim::with_max_delay(0);
    sim.settled_connection();
    sim.apply("m1");
    assert_eq!(sim.turn(), [event("m1")]);
    sim.deliver();
    sim.at(100).broken(REFUSED);
    sim.apply("m2");
    assert_eq!(sim.turn(), []);
    assert_eq!(sim.delivery.tally.expired, 0);
    assert_eq!(sim.at(101).turn(), []);
    assert_eq!(sim.delivery.tally.expired, 1);
    assert_eq!(sim.at(150).connect(), connection());
}

#[test]
fn a_full_queue_drops_the_newest_and_counts_them() {
    let mut sim = Sim::new();
    let messages: Vec<String> = (0..QUEUE + 2).map(|i| format!("m{i}")).collect();
    for message in &messages {
        sim.apply(message);
    }
    assert_eq!(sim.delivery.tally.queue_full, 2);
    let kept: Vec<&str> = messages[..QUEUE].iter().map(String::as_str).collect();
    assert_eq!(sim.at(10).connect(), connection_then(&kept));
    sim.deliver();
    sim.ends_with(
        QUEUE as u64,
        2,
        &["2 events were lost: 2 found 64 events already waiting"],
    );
}

// ------------------------------------------------ at most once

#[test]
fn an_event_written_on_a_connection_that_broke_is_lost_and_never_sent_again() {
    let mut sim = Sim::new();
    sim.settled_connection();
    sim.apply("m1").apply("m2");
    assert_eq!(sim.turn(), [event("m1"), event("m2")]);
    // m1 is written; m2 is still in the client's channel when the
    // connection breaks (the network thread drops it unwritten).
    let written = sim.write(1);
    assert_eq!(written.len(), 1);
    sim.at(100).broken(CLOSED);
    sim.at(200).apply("m3");
    // m2 never left: it goes before m3. m1 may have arrived: never again.
    assert_eq!(sim.at(300).connect(), connection_then(&["m2", "m3"]));
    sim.deliver();
    // A late acknowledgement of the broken connection's id counts nothing.
    sim.ack(&written);
    assert_eq!(sim.outage(400, 500, CLOSED), connection());
    sim.ends_with(
        2,
        1,
        &[
            "the broker was unreachable for 0.3 s (2 times, the longest 0.2 s); last: the broker closed the connection",
            "1 event was lost: 1 sent as the connection broke, never acknowledged (not sent again: it may have arrived, never twice)",
        ],
    );
}

#[test]
fn the_client_thread_ending_counts_what_it_held() {
    let mut sim = Sim::new();
    sim.settled_connection();
    sim.apply("m1").apply("m2");
    sim.turn();
    sim.write(1);
    sim.at(100).notice(NetworkNotice::Gone);
    sim.apply("m3");
    assert_eq!(sim.turn(), []);
    sim.ends_with(
        0,
        3,
        &[
            "3 events were lost: 1 sent but not acknowledged by the end (the broker stopped answering; they may have arrived); 2 still waiting for the broker at the end",
        ],
    );
}

// ------------------------------------------------ outages

#[test]
fn the_wait_to_connect_is_no_outage_and_outages_add_up() {
    let mut sim = Sim::new();
    sim.at(5000).settled_connection();
    assert_eq!(sim.delivery.tally.down, Duration::ZERO);
    sim.at(6000).broken(CLOSED);
    // A failed attempt to reconnect is the same outage.
    sim.at(6300).broken(REFUSED);
    assert_eq!(sim.at(6500).connect(), connection());
    let stalled = "the broker stopped answering (no reply to the keep-alive ping)";
    assert_eq!(sim.outage(7000, 7200, stalled), connection());
    sim.ends_with(
        0,
        0,
        &[&format!(
            "the broker was unreachable for 0.7 s (2 times, the longest 0.5 s); last: {stalled}"
        )],
    );
}

// ------------------------------------------------ closing

#[test]
fn close_waits_for_the_acknowledgements_then_says_goodbye() {
    let mut sim = Sim::new();
    sim.settled_connection();
    sim.apply("m1");
    sim.turn();
    let ids = sim.write_all();
    sim.at(1000).close();
    assert_eq!(sim.turn(), []);
    assert_eq!(sim.delivery.closing_until(), Some(sim.instant(3000)));
    sim.at(1500).ack(&ids);
    assert_eq!(sim.turn(), goodbye());
    assert_eq!(sim.delivery.closing_until(), Some(sim.instant(3500)));
    sim.write_all();
    sim.at(1510).notice(NetworkNotice::Gone);
    assert_eq!(sim.turn(), []);
    assert_eq!(sim.delivery.closing_until(), None);
    sim.ends_with(1, 0, &[]);
}

#[test]
fn close_gives_up_on_a_broker_that_stopped_answering_after_its_bounds() {
    let mut sim = Sim::new();
    sim.settled_connection();
    sim.apply("m1");
    sim.turn();
    sim.write_all();
    sim.at(1000).close();
    assert_eq!(sim.at(2999).turn(), []);
    assert_eq!(sim.at(3000).turn(), goodbye());
    assert_eq!(sim.at(4999).turn(), []);
    assert_eq!(sim.delivery.closing_until(), Some(sim.instant(5000)));
    assert_eq!(sim.at(5000).turn(), []);
    assert_eq!(sim.delivery.closing_until(), None);
    sim.ends_with(
        0,
        1,
        &[
            "1 event was lost: 1 sent but not acknowledged by the end (the broker stopped answering; they may have arrived)",
        ],
    );
}

#[test]
fn close_sends_what_waits_and_a_refused_disconnect_ends_the_goodbye() {
    let mut sim = Sim::new();
    sim.settled_connection();
    sim.apply("m1");
    sim.close();
    assert_eq!(sim.turn(), [event("m1")]);
    let ids = sim.write_all();
    // Home Assistant's `online` still brings discovery while settling.
    let status = "homeassistant/status";
    assert_eq!(sim.message(status, "online", false), discovery());
    sim.write_all();
    sim.ack(&ids);
    assert_eq!(sim.refusing(Handed::Full), goodbye());
    assert_eq!(sim.delivery.closing_until(), None);
    // After the goodbye nothing more is announced.
    assert_eq!(sim.message(status, "online", false), []);
    sim.ends_with(
        1,
        0,
        &["1 discovery or availability messages could not be queued"],
    );
}

#[test]
fn closing_while_down_ends_at_once_and_counts_what_waited() {
    let mut sim = Sim::new();
    sim.settled_connection();
    sim.at(100).broken(REFUSED);
    sim.at(150).apply("m1");
    sim.at(400).close();
    assert_eq!(sim.turn(), []);
    assert_eq!(sim.delivery.closing_until(), None);
    sim.ends_with(
        0,
        1,
        &[
            &format!("the broker was unreachable for 0.3 s; last: {REFUSED}"),
            "1 event was lost: 1 still waiting for the broker at the end",
        ],
    );
}
