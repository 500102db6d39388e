//! Any text as a configuration file: never a panic; an error names each
//! key and what is wrong; an accepted configuration builds a core that
//! runs.

#![no_main]

use libfuzzer_sys::fuzz_target;
use sipnpuff::config::Config;
use sipnpuff::pipeline::Core;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match Config::from_toml_str(text) {
        Ok(config) => {
            let d = config.detector();
            assert!(d.min_burst_ms < d.long_burst_ms && d.glitch_ms < d.min_burst_ms);
            assert!(d.sip_threshold_volts < d.neutral_volts);
            assert!(d.neutral_volts < d.puff_threshold_volts);
            let m = config.motion();
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
            let entries = config.sequences();
            for (i, a) in entries.iter().enumerate() {
                for b in &entries[i + 1..] {
                    assert!(a.actions != b.actions, "duplicate sequence accepted");
                }
            }
            let mut core: Core = Core::new(&config);
            for tick in 0..200 {
                let out = core.step(tick, d.neutral_volts);
                assert!(out.motion.arm_command.is_none_or(|c| c.is_zero()));
            }
        }
        Err(errors) => {
            assert!(!errors.0.is_empty(), "an error without a problem");
            for e in &errors.0 {
                assert!(!e.key.is_empty() && !e.message.is_empty(), "{e:?}");
            }
        }
    }
});
