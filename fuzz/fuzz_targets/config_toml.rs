//! Any text as a configuration file: never a panic; an error names each
//! key and what is wrong; an accepted configuration keeps the validator's
//! promises and builds a core that runs. Inputs starting with `#` are
//! read as they are; others choose a value for each numeric key (from
//! values at and around the boundaries, or raw), so the fuzzer explores
//! the relations between keys as well as the syntax.

#![no_main]

use libfuzzer_sys::fuzz_target;
use sipnpuff::config::Config;
use sipnpuff::control::pipeline::Pipeline;
use sipnpuff::control::tick::{TickInput, TickOutput};

/// Numeric keys, by section.
const KEYS: [(&str, &str); 22] = [
    ("detector", "neutral_volts"),
    ("detector", "puff_threshold_volts"),
    ("detector", "sip_threshold_volts"),
    ("detector", "hysteresis_volts"),
    ("detector", "min_burst_ms"),
    ("detector", "long_burst_ms"),
    ("detector", "glitch_ms"),
    ("detector", "neutral_tracking_ms"),
    ("detector", "fault_margin_volts"),
    ("detector", "fault_recovery_ms"),
    ("detector", "stale_ms"),
    ("matcher", "sequence_timeout_ms"),
    ("command", "inactivity_timeout_ms"),
    ("motion", "linear_speed_mps"),
    ("motion", "angular_speed_radps"),
    ("motion", "linear_acceleration_mps2"),
    ("motion", "linear_jerk_mps3"),
    ("motion", "finger_speed"),
    ("workspace", "reach_m"),
    ("workspace", "min_radius_m"),
    ("workspace", "stop_margin_m"),
    ("scanning", "dwell_ms"),
];

/// Values at and around the defaults and limits.
const VALUES: [&str; 24] = [
    "0", "1", "2", "4", "5", "6", "39", "40", "41", "499", "500", "501", "-1", "1000000", "0.0",
    "0.05", "0.1", "0.2", "0.5", "1.0", "2.0", "2.5", "3.0", "5.0",
];

/// TOML from bytes: two bytes per key, skip, a listed value or a raw one.
fn structured(data: &[u8]) -> String {
    let mut text = String::new();
    let mut section = "";
    for ((table, key), pair) in KEYS.iter().zip(data.chunks(2)) {
        let choice = pair[0];
        let raw = pair.get(1).copied().unwrap_or(0);
        if choice % 4 == 0 {
            continue; // keep the default
        }
        if *table != section {
            text += &format!("[{table}]\n");
            section = table;
        }
        let value = if choice % 4 == 1 {
            format!("{}", u32::from(raw) * 10)
        } else {
            VALUES[usize::from(raw) % VALUES.len()].to_string()
        };
        text += &format!("{key} = {value}\n");
    }
    text
}

fuzz_target!(|data: &[u8]| {
    let text = if data.first() == Some(&b'#') {
        match std::str::from_utf8(data) {
            Ok(text) => text.to_string(),
            Err(_) => return,
        }
    } else {
        structured(data)
    };
    match Config::from_toml_str(&text) {
        Ok(config) => {
            let d = config.core().detector();
            assert!(d.min_burst_ms < d.long_burst_ms && d.glitch_ms < d.min_burst_ms);
            assert!(d.sip_threshold_volts < d.neutral_volts);
            assert!(d.neutral_volts < d.puff_threshold_volts);
            let m = config.core().motion();
            for limit in [
                m.linear_speed_mps,
                m.angular_speed_radps,
                m.linear_acceleration_mps2,
                m.angular_acceleration_radps2,
                m.linear_jerk_mps3,
                m.angular_jerk_radps3,
            ] {
                assert!(limit.is_finite() && limit > 0.0, "limit {limit}");
            }
            // Every sequence distinct: a match must name one mode.
            let entries = config.core().sequences();
            for (i, a) in entries.iter().enumerate() {
                for b in &entries[i + 1..] {
                    assert!(a.actions != b.actions, "duplicate sequence accepted");
                }
            }
            let mut core = Pipeline::new(config.core());
            let mut out = TickOutput::default();
            for tick in 0..200 {
                core.step(&TickInput::volts(tick, d.neutral_volts), &mut out);
                assert!(out.motion.arm_command.is_none_or(|c| c.is_zero()));
            }
        }
        Err(errors) => {
            assert!(!errors.0.is_empty(), "an error without a problem");
            // Each error says what is wrong and where: its key, or (a
            // syntax error) its line.
            for e in &errors.0 {
                assert!(!e.message.is_empty(), "{e:?}");
                assert!(!e.key.is_empty() || e.line.is_some(), "{e:?}");
            }
        }
    }
});
