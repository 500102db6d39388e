//! The outputs' settings: the `[output.uinput]` and `[output.mqtt]`
//! tables. Read and validated by `config/` like every other section; used
//! only when an output is opened (never on the control thread). The
//! pointer's speeds, which the core uses, live with the core
//! ([`PointerConfig`](crate::control::pointer::PointerConfig)) and are
//! written in `[output.uinput]` beside the device's name.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

/// The outputs' settings (`[output]`).
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OutputSettings {
    /// `--output uinput`.
    pub uinput: UinputSettings,
    /// `--output mqtt`.
    pub mqtt: MqttSettings,
}

/// `[output.uinput]`'s device settings.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct UinputSettings {
    /// The virtual device's name, as the desktop lists it.
    pub name: String,
}

impl Default for UinputSettings {
    fn default() -> Self {
        UinputSettings {
            name: "sipnpuff".into(),
        }
    }
}

/// `[output.mqtt]`: the broker and Home Assistant's conventions.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MqttSettings {
    /// The broker's host name or address.
    pub host: String,
    /// The broker's port (1883; 8883 with TLS).
    pub port: u16,
    /// Home Assistant's discovery prefix.
    pub prefix: String,
    /// A file holding `username` and `password` lines (TOML), readable
    /// by its owner only; none: connect anonymously.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub credentials_file: Option<PathBuf>,
    /// Connect with TLS (rustls, the system's root certificates).
    pub tls: bool,
    /// The device's stable identifier in Home Assistant (and its topics'
    /// root): one per person's controller.
    pub device_id: String,
    /// How long an event fired while the broker is unreachable waits for
    /// it, ms; past that it is given up and counted lost (a light that
    /// toggles a minute after the breath surprises more than one that
    /// does not). 0: never wait.
    pub max_delay_ms: u32,
}

impl Default for MqttSettings {
    fn default() -> Self {
        MqttSettings {
            host: "127.0.0.1".into(),
            port: 1883,
            prefix: "homeassistant".into(),
            credentials_file: None,
            tls: false,
            device_id: "sipnpuff".into(),
            max_delay_ms: 10_000,
        }
    }
}
