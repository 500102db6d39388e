//! Long scripted sessions through the whole core: what a user does for an
//! hour is detected and matched exactly, under noise, hum, drift and spikes.

use crate::common;

use sipnpuff::config::Config;
use sipnpuff::sim::script::random_session;
use sipnpuff::sim::sensor_model::{SignalGenerator, SignalParams};

#[test]
fn one_noisy_hour_loses_and_invents_nothing() {
    let config = Config::default();
    let params = SignalParams::clean(config.core().detector(), 42)
        .with_noise(0.03)
        .with_hum(0.05)
        .with_drift(0.2)
        .with_spikes_every(250);
    let (script, modes) = random_session(&config, 3600, 42);
    assert!(modes.len() > 300, "{} selections", modes.len());
    let samples = SignalGenerator::new(params, &script).take(3_600_000);
    // Tolerance on each burst's length: the neutral is frozen during a breath
    // (up to 3 s here) while a 0.2 V, one-minute sinusoidal drift moves it
    // by up to 0.2 × 2π/60 s × 3 s ≈ 0.06 V, which moves the end of a slow
    // ramp (≥ 0.02 V/ms) by up to 3 ms; tracker lag (τ + delay = 1.1 s)
    // adds ~1 ms, hum and noise up to 2.5 ms per end: about 9 ms in all
    // (11 ms measured).
    let n = common::assert_session(&config, samples, &script, &modes, 15);
    assert_eq!(n, 3_600_000);
}

#[test]
fn paper_library_session_waits_for_prefixes() {
    let config = common::paper_config();
    let params = SignalParams::clean(config.core().detector(), 9).with_noise(0.03);
    let (script, modes) = random_session(&config, 600, 9);
    let samples = SignalGenerator::new(params, &script);
    common::assert_session(&config, samples, &script, &modes, 10);
}
