//! `[output.uinput]` and `[output.mqtt]`: the device's name, the
//! pointer's speeds, the broker's address and Home Assistant's prefix.

use crate::config::error::Problems;
use crate::control::pointer::PointerConfig;
use crate::output::settings::OutputSettings;

/// Longest uinput device name: 78 bytes. The kernel's
/// `UINPUT_MAX_NAME_SIZE` is 80 with the terminating zero, but evdev's
/// builder asserts (panics) unless the name and its zero are shorter than
/// 80, so a 79-byte name must be refused here, before the run.
const MAX_DEVICE_NAME: usize = crate::output::uinput::MAX_NAME;
/// Highest pointer speed, counts/s (a 4K screen in under a second).
const MAX_POINTER_SPEED: f64 = 5000.0;
/// Highest scroll speed, detents/s.
const MAX_SCROLL_SPEED: f64 = 100.0;

/// Longest an event may wait for an unreachable broker, ms (an hour).
const MAX_EVENT_DELAY_MS: u32 = 3_600_000;

/// Every check of `[output]`.
pub(super) fn output(p: &mut Problems, output: &OutputSettings, pointer: &PointerConfig) {
    let name = &output.uinput.name;
    if name.trim().is_empty() {
        p.add("output.uinput.name", "must name the device");
    } else if name.len() > MAX_DEVICE_NAME {
        p.add(
            "output.uinput.name",
            format!("{} bytes: at most {MAX_DEVICE_NAME} fit", name.len()),
        );
    }
    let key = |k: &str| format!("output.uinput.{k}");
    let c = pointer;
    p.range(
        &key("pointer_speed"),
        c.pointer_speed,
        0.0,
        false,
        MAX_POINTER_SPEED,
        "counts/s",
    );
    p.range(
        &key("pointer_acceleration"),
        c.pointer_acceleration,
        0.0,
        false,
        100.0 * MAX_POINTER_SPEED,
        "counts/s²",
    );
    p.range(
        &key("pointer_jerk"),
        c.pointer_jerk,
        0.0,
        false,
        10_000.0 * MAX_POINTER_SPEED,
        "counts/s³",
    );
    p.range(
        &key("scroll_speed"),
        c.scroll_speed,
        0.0,
        false,
        MAX_SCROLL_SPEED,
        "detents/s",
    );
    p.range(
        &key("scroll_acceleration"),
        c.scroll_acceleration,
        0.0,
        false,
        100.0 * MAX_SCROLL_SPEED,
        "detents/s²",
    );
    p.range(
        &key("scroll_jerk"),
        c.scroll_jerk,
        0.0,
        false,
        10_000.0 * MAX_SCROLL_SPEED,
        "detents/s³",
    );

    let m = &output.mqtt;
    if m.host.trim().is_empty() {
        p.add("output.mqtt.host", "must name the broker's host");
    }
    if m.port == 0 {
        p.add("output.mqtt.port", "must be a port, 1–65535");
    }
    for (k, value) in [("prefix", &m.prefix), ("device_id", &m.device_id)] {
        let topic_safe = !value.is_empty()
            && value
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
        if !topic_safe {
            p.add(
                format!("output.mqtt.{k}"),
                format!(
                    "{value:?} must be letters, digits, `_` or `-` (it is part of every topic)"
                ),
            );
        }
    }
    if m.max_delay_ms > MAX_EVENT_DELAY_MS {
        p.add(
            "output.mqtt.max_delay_ms",
            format!(
                "{} ms: at most {MAX_EVENT_DELAY_MS} ms (an hour) an event may wait for the broker",
                m.max_delay_ms
            ),
        );
    }
}
