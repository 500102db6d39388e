//! What the home output publishes where: its topics, Home Assistant's
//! discovery configs (a device trigger per event and one `event` entity)
//! and an event's message. Pure: strings in, strings out.
//!
//! One message per match, on `<device_id>/event`: the event entity reads
//! its `event_type`, and every device trigger listens on the same topic,
//! extracting `event_type` with a `value_template` and comparing it with
//! its own `payload`. Home Assistant's two views of a match therefore
//! always agree — both got it or neither did.

use std::time::{Duration, SystemTime, UNIX_EPOCH};

use serde_json::{Value, json};

use crate::control::Tick;
use crate::control::sequence::Sequence;
use crate::control::target::HomeEvent;
use crate::output::settings::MqttSettings;

/// The device trigger's `type`: Home Assistant's frontend shows it as
/// "`<subtype>` pressed".
pub const TRIGGER_TYPE: &str = "button_short_press";
/// The event entity's discovery object id.
pub const EVENT_ENTITY: &str = "home_events";
/// The availability topic's payloads (Home Assistant's defaults).
pub const ONLINE: &str = "online";
/// See [`ONLINE`].
pub const OFFLINE: &str = "offline";

/// The topics of one device.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Topics {
    /// `<device_id>/availability`: `online` while connected (retained),
    /// `offline` on a clean close and as the broker's last will.
    pub availability: String,
    /// `<device_id>/event`: one JSON message per match.
    pub events: String,
    /// `<prefix>/status`: Home Assistant's `online` asks for discovery
    /// again.
    pub ha_status: String,
    /// `<prefix>/device_automation/<device_id>/`: the device triggers'
    /// config topics begin so.
    pub trigger_root: String,
}

impl Topics {
    /// The topics for `settings`' prefix and device.
    pub fn new(settings: &MqttSettings) -> Topics {
        let (prefix, device) = (&settings.prefix, &settings.device_id);
        Topics {
            availability: format!("{device}/availability"),
            events: format!("{device}/event"),
            ha_status: format!("{prefix}/status"),
            trigger_root: format!("{prefix}/device_automation/{device}/"),
        }
    }

    /// The filter that brings back the device's retained trigger configs
    /// (to delete those of events no longer in the library).
    pub fn trigger_configs(&self) -> String {
        format!("{}+/config", self.trigger_root)
    }

    /// The event a retained trigger config on `topic` is for, if `topic`
    /// is one of this device's.
    pub fn trigger_of<'a>(&self, topic: &'a str) -> Option<&'a str> {
        topic
            .strip_prefix(self.trigger_root.as_str())?
            .strip_suffix("/config")
            .filter(|event| !event.is_empty() && !event.contains('/'))
    }
}

/// The `device` block every config carries: ties the triggers and the
/// entity to one device in Home Assistant's registry.
fn device(settings: &MqttSettings) -> Value {
    json!({
        "identifiers": [settings.device_id],
        "name": settings.device_id,
        "manufacturer": "sipnpuff",
        "model": "Sip-and-puff interface",
        "sw_version": env!("CARGO_PKG_VERSION"),
    })
}

/// Who published the config (Home Assistant logs it).
fn origin() -> Value {
    json!({ "name": "sipnpuff", "sw_version": env!("CARGO_PKG_VERSION") })
}

/// Every retained discovery config, `(topic, JSON)`: one device trigger
/// per event, then the event entity listing them all.
pub fn configs(settings: &MqttSettings, events: &[HomeEvent]) -> Vec<(String, String)> {
    let topics = Topics::new(settings);
    let mut configs: Vec<(String, String)> = events
        .iter()
        .map(|event| {
            let name = event.as_str();
            let config = json!({
                "automation_type": "trigger",
                "topic": topics.events,
                "value_template": "{{ value_json.event_type }}",
                "payload": name,
                "type": TRIGGER_TYPE,
                "subtype": name,
                "qos": 1,
                "device": device(settings),
                "origin": origin(),
            });
            (
                format!("{}{name}/config", topics.trigger_root),
                config.to_string(),
            )
        })
        .collect();
    let device_id = &settings.device_id;
    let entity = json!({
        "name": "Home event",
        "unique_id": format!("{device_id}_{EVENT_ENTITY}"),
        "state_topic": topics.events,
        "event_types": events.iter().map(HomeEvent::as_str).collect::<Vec<_>>(),
        "device_class": "button",
        "availability_topic": topics.availability,
        "payload_available": ONLINE,
        "payload_not_available": OFFLINE,
        "qos": 1,
        "device": device(settings),
        "origin": origin(),
    });
    configs.push((
        format!(
            "{}/event/{device_id}/{EVENT_ENTITY}/config",
            settings.prefix
        ),
        entity.to_string(),
    ));
    configs
}

/// The message of one match: the event, the tick and sequence that fired
/// it, and when it matched (Unix time, ms, to the µs) so that a
/// subscriber can measure the delay to itself.
pub fn event_message(
    event: &HomeEvent,
    tick: Tick,
    sequence: &Sequence,
    matched_at: SystemTime,
) -> String {
    let unix = matched_at
        .duration_since(UNIX_EPOCH)
        .unwrap_or(Duration::ZERO);
    let matched_at_ms = unix.as_micros() as f64 / 1000.0;
    json!({
        "event_type": event.as_str(),
        "tick": tick,
        "sequence": sequence,
        "matched_at_ms": matched_at_ms,
    })
    .to_string()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::action::Action;

    fn event(name: &str) -> HomeEvent {
        HomeEvent::new(name).unwrap()
    }

    #[test]
    fn topics_of_a_device() {
        let settings = MqttSettings {
            prefix: "ha".into(),
            device_id: "anna".into(),
            ..MqttSettings::default()
        };
        let topics = Topics::new(&settings);
        assert_eq!(topics.availability, "anna/availability");
        assert_eq!(topics.events, "anna/event");
        assert_eq!(topics.ha_status, "ha/status");
        assert_eq!(
            topics.trigger_configs(),
            "ha/device_automation/anna/+/config"
        );
        assert_eq!(
            topics.trigger_of("ha/device_automation/anna/lights/config"),
            Some("lights")
        );
        assert_eq!(
            topics.trigger_of("ha/device_automation/bob/lights/config"),
            None
        );
        assert_eq!(
            topics.trigger_of("ha/device_automation/anna/a/b/config"),
            None
        );
    }

    #[test]
    fn one_trigger_per_event_and_one_entity() {
        let settings = MqttSettings::default();
        let configs = configs(&settings, &[event("lights_toggle"), event("call_help")]);
        let topics: Vec<&str> = configs.iter().map(|(t, _)| t.as_str()).collect();
        assert_eq!(
            topics,
            [
                "homeassistant/device_automation/sipnpuff/lights_toggle/config",
                "homeassistant/device_automation/sipnpuff/call_help/config",
                "homeassistant/event/sipnpuff/home_events/config",
            ]
        );
        let trigger: Value = serde_json::from_str(&configs[1].1).unwrap();
        assert_eq!(trigger["payload"], "call_help");
        assert_eq!(trigger["subtype"], "call_help");
        assert_eq!(trigger["topic"], "sipnpuff/event");
        let entity: Value = serde_json::from_str(&configs[2].1).unwrap();
        assert_eq!(entity["event_types"], json!(["lights_toggle", "call_help"]));
        assert_eq!(entity["device"]["identifiers"], json!(["sipnpuff"]));
    }

    #[test]
    fn an_event_message() {
        let sequence = Sequence::from_slice(&[Action::ShortPuff, Action::LongSip]).unwrap();
        let at = UNIX_EPOCH + Duration::from_micros(1_700_000_000_123_456);
        assert_eq!(
            event_message(&event("lights_toggle"), 4200, &sequence, at),
            r#"{"event_type":"lights_toggle","tick":4200,"sequence":[-1,2],"matched_at_ms":1700000000123.456}"#
        );
    }
}
