//! `[detector]`: every level inside 0–5 V and on the right side of the
//! neutral, the hysteresis inside the band, timers positive and ordered.

use crate::config::error::Problems;
use crate::control::detector::{DetectorConfig, REZERO_WINDOW_MS};

/// Checks `[detector]`.
pub(super) fn detector(p: &mut Problems, c: &DetectorConfig) {
    for (key, v) in [
        ("detector.neutral_volts", c.neutral_volts),
        ("detector.puff_threshold_volts", c.puff_threshold_volts),
        ("detector.sip_threshold_volts", c.sip_threshold_volts),
    ] {
        if !(0.0..=5.0).contains(&v) {
            p.add(key, format!("{v} V is outside the sensor's 0–5 V range"));
        }
    }
    let (puff_room, sip_room) = (
        c.puff_threshold_volts - c.neutral_volts,
        c.neutral_volts - c.sip_threshold_volts,
    );
    // `hysteresis_volts` serves both kinds unless sips have their own.
    let shared = if c.sip_hysteresis_volts.is_some() {
        ("the puff threshold", puff_room)
    } else {
        ("the nearest threshold", puff_room.min(sip_room))
    };
    let checks = [(
        "detector.hysteresis_volts",
        Some(c.hysteresis_volts),
        shared,
    )]
    .into_iter()
    .chain([(
        "detector.sip_hysteresis_volts",
        c.sip_hysteresis_volts,
        ("the sip threshold", sip_room),
    )]);
    for (key, hysteresis, (threshold, room)) in checks {
        let Some(h) = hysteresis else { continue };
        if h.is_nan() || h < 0.0 {
            p.add(key, "must be 0 V or more");
        } else if room > 0.0 && h >= room {
            p.add(
                key,
                format!(
                    "{h} V must be smaller than the distance from the neutral to {threshold} ({room:.3} V)"
                ),
            );
        }
    }
    if !(c.fault_margin_volts > 0.0 && c.fault_margin_volts <= 5.0) {
        p.add(
            "detector.fault_margin_volts",
            format!(
                "{} V must be above 0 V and at most 5 V",
                c.fault_margin_volts
            ),
        );
    }
    for (key, ms) in [
        ("detector.min_burst_ms", c.min_burst_ms),
        ("detector.long_burst_ms", c.long_burst_ms),
        ("detector.neutral_tracking_ms", c.neutral_tracking_ms),
        ("detector.fault_recovery_ms", c.fault_recovery_ms),
        ("detector.stale_ms", c.stale_ms),
        ("detector.max_hold_ms", c.max_hold_ms),
        ("detector.rezero_ms", c.rezero_ms),
    ] {
        p.positive_ms(key, ms);
    }
    in_order(p, c);
}

/// The thresholds on their sides of the neutral; a glitch shorter than a
/// burst, a short burst shorter than a long one, the longest breath longer
/// than both, the re-zero two windows long.
fn in_order(p: &mut Problems, c: &DetectorConfig) {
    let (shorter, shorter_ms) = if c.max_hold_ms <= c.long_burst_ms {
        ("detector.long_burst_ms", c.long_burst_ms)
    } else {
        ("detector.min_burst_ms", c.min_burst_ms)
    };
    let window = REZERO_WINDOW_MS as u32;
    for (broken, key, message) in [
        (
            c.puff_threshold_volts <= c.neutral_volts,
            "detector.puff_threshold_volts",
            format!(
                "{} V must be above detector.neutral_volts ({} V): a puff raises the voltage",
                c.puff_threshold_volts, c.neutral_volts
            ),
        ),
        (
            c.sip_threshold_volts >= c.neutral_volts,
            "detector.sip_threshold_volts",
            format!(
                "{} V must be below detector.neutral_volts ({} V): a sip lowers the voltage",
                c.sip_threshold_volts, c.neutral_volts
            ),
        ),
        (
            c.long_burst_ms <= c.min_burst_ms,
            "detector.long_burst_ms",
            format!(
                "{} ms must be greater than detector.min_burst_ms ({} ms)",
                c.long_burst_ms, c.min_burst_ms
            ),
        ),
        (
            c.glitch_ms >= c.min_burst_ms,
            "detector.glitch_ms",
            format!(
                "{} ms must be smaller than detector.min_burst_ms ({} ms): a glitch is shorter than any burst",
                c.glitch_ms, c.min_burst_ms
            ),
        ),
        (
            c.max_hold_ms <= shorter_ms,
            "detector.max_hold_ms",
            format!(
                "{} ms must be greater than {shorter} ({shorter_ms} ms): a breath longer than max_hold_ms is a stuck sensor",
                c.max_hold_ms
            ),
        ),
        (
            c.rezero_ms < 2 * window,
            "detector.rezero_ms",
            format!(
                "{} ms must be at least {} ms: steadiness is judged over {window} ms windows, at least two",
                c.rezero_ms,
                2 * window
            ),
        ),
    ] {
        if broken {
            p.add(key, message);
        }
    }
}
