//! `[sensor]`: timers positive, the re-zero shift inside the band between
//! the thresholds, mappings finite and not flat, key and axis names real.

use crate::config::error::Problems;
use crate::sensor::settings::{EvdevInput, SensorSettings};

/// Checks `[sensor]` and its `evdev`, `serial` and `iio` tables.
pub(super) fn sensor(p: &mut Problems, c: &SensorSettings) {
    p.positive_ms("sensor.rezero_ms", c.rezero_ms);
    p.positive_ms("sensor.rezero_timeout_ms", c.rezero_timeout_ms);
    if c.rezero_timeout_ms < c.rezero_ms {
        p.add(
            "sensor.rezero_timeout_ms",
            format!(
                "{} ms is shorter than sensor.rezero_ms ({} ms): the neutral could never be measured",
                c.rezero_timeout_ms, c.rezero_ms
            ),
        );
    }
    if !(c.rezero_max_shift_fraction >= 0.0 && c.rezero_max_shift_fraction < 1.0) {
        p.add(
            "sensor.rezero_max_shift_fraction",
            format!(
                "{} must be at least 0 and below 1 (a fraction of the distance from the neutral to the nearer threshold: at 1 a breath held through the measurement could become the neutral)",
                c.rezero_max_shift_fraction
            ),
        );
    }
    let e = &c.evdev;
    for (key, value) in [
        ("sensor.evdev.volts_at_min", e.volts_at_min),
        ("sensor.evdev.volts_at_max", e.volts_at_max),
    ] {
        if !value.is_finite() {
            p.add(key, format!("{value} must be a finite number of volts"));
        }
    }
    if e.volts_at_min == e.volts_at_max {
        p.add(
            "sensor.evdev.volts_at_max",
            "must differ from sensor.evdev.volts_at_min: the axis would read one level whatever the pressure",
        );
    }
    if e.axis.parse::<evdev::AbsoluteAxisCode>().is_err() {
        p.add(
            "sensor.evdev.axis",
            format!(
                "{:?} is not a Linux absolute axis name (e.g. ABS_X, ABS_Y, ABS_Z, ABS_RX, ABS_THROTTLE)",
                e.axis
            ),
        );
    }
    for (key, names) in [
        ("sensor.evdev.sip_keys", &e.sip_keys),
        ("sensor.evdev.puff_keys", &e.puff_keys),
    ] {
        let bad: Vec<&str> = names
            .iter()
            .filter(|n| n.parse::<evdev::KeyCode>().is_err())
            .map(String::as_str)
            .collect();
        if !bad.is_empty() {
            p.add(
                key,
                format!(
                    "{bad:?}: not Linux key or button names (e.g. BTN_TRIGGER, BTN_THUMB, KEY_ENTER, KEY_SPACE)"
                ),
            );
        }
        if names.is_empty() && e.input == EvdevInput::Switches {
            p.add(key, "needs at least one key for `input = \"switches\"`");
        }
    }
    if let Some(both) = e.sip_keys.iter().find(|k| e.puff_keys.contains(k)) {
        p.add(
            "sensor.evdev.puff_keys",
            format!("{both} is also a sip key: a key means sip or puff, not both"),
        );
    }
    let s = &c.serial;
    if s.baud == 0 || s.baud > 4_000_000 {
        p.add(
            "sensor.serial.baud",
            format!("{} must be between 1 and 4000000", s.baud),
        );
    }
    p.range(
        "sensor.serial.full_scale",
        s.full_scale,
        0.0,
        false,
        1e9,
        "counts",
    );
    p.range(
        "sensor.serial.volts_per_hpa",
        s.volts_per_hpa,
        0.0,
        false,
        5.0,
        "V/hPa",
    );
    p.positive_ms("sensor.serial.answer_timeout_ms", s.answer_timeout_ms);
    p.positive_ms("sensor.serial.silence_ms", s.silence_ms);
    let i = &c.iio;
    if !(i.gain.is_finite() && i.gain != 0.0) {
        p.add(
            "sensor.iio.gain",
            format!("{} must be a finite number other than 0", i.gain),
        );
    }
    if !i.offset_volts.is_finite() {
        p.add(
            "sensor.iio.offset_volts",
            format!("{} must be a finite number of volts", i.offset_volts),
        );
    }
    if i.rate_hz == 0 || i.rate_hz > 1000 {
        p.add(
            "sensor.iio.rate_hz",
            format!(
                "{} must be between 1 and 1000 (the control loop runs at 1 kHz)",
                i.rate_hz
            ),
        );
    }
    if !i.buffered && !i.trigger.is_empty() {
        p.add(
            "sensor.iio.trigger",
            format!(
                "{:?} is used only with buffered = true: set it, or leave trigger out to read through sysfs",
                i.trigger
            ),
        );
    }
}
