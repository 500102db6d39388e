//! Re-zero at start: the neutral is measured from the sensor at rest before
//! anything can move, as LipSync and FLipMouse do, instead of trusting the
//! configured `detector.neutral_volts` (a pressure sensor's zero drifts
//! with temperature, altitude and the tube's fit).
//!
//! The sensor is at rest when, over `rezero_ms` of samples, no sample is
//! further from their mean than half the distance to the nearer threshold
//! (a breath would be), and the mean is within `rezero_max_shift_fraction`
//! of that distance from the configured neutral (a breath held steady
//! through the whole window would not be). Until then the measurement
//! starts again and the user is told why; after `rezero_timeout_ms` it is
//! an error. Not RT-safe: runs before the control loop starts.

use std::time::{Duration, Instant};

use crate::control::detector::DetectorConfig;
use crate::control::sample::Sample;
use crate::sensor::settings::SensorSettings;
use crate::sensor::{Samples, SensorError};

/// The neutral as measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Neutral {
    /// The mean level at rest, volts.
    pub volts: f64,
    /// The noise: standard deviation of the samples, volts.
    pub noise_volts: f64,
    /// The largest distance of a sample from the mean, volts.
    pub peak_volts: f64,
    /// Samples measured.
    pub samples: u32,
}

impl std::fmt::Display for Neutral {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "neutral {:.4} V measured at rest (noise {:.4} V rms, peak {:.4} V, {} samples)",
            self.volts, self.noise_volts, self.peak_volts, self.samples
        )
    }
}

/// What a window of samples says.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// Still measuring.
    Measuring,
    /// At rest: this is the neutral.
    AtRest(Neutral),
    /// Not at rest (why, in words); measuring starts again.
    NotAtRest(String),
}

/// The window being measured: the pure part.
#[derive(Debug, Clone)]
pub struct RestWindow {
    needed: usize,
    configured: f64,
    max_shift: f64,
    band: f64,
    values: Vec<f64>,
}

impl RestWindow {
    /// A window of `settings.rezero_ms` samples around `detector`'s levels.
    pub fn new(settings: &SensorSettings, detector: &DetectorConfig) -> RestWindow {
        let nearest = (detector.puff_threshold_volts - detector.neutral_volts)
            .min(detector.neutral_volts - detector.sip_threshold_volts);
        let needed = settings.rezero_ms as usize;
        RestWindow {
            needed,
            configured: detector.neutral_volts,
            max_shift: settings.rezero_max_shift_fraction * nearest,
            band: nearest / 2.0,
            values: Vec::with_capacity(needed),
        }
    }

    /// Adds one sample (one per millisecond).
    pub fn push(&mut self, volts: f64) -> Verdict {
        self.values.push(volts);
        if self.values.len() < self.needed {
            return Verdict::Measuring;
        }
        let n = self.values.len() as f64;
        let mean = self.values.iter().sum::<f64>() / n;
        let variance = self.values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
        let peak = self
            .values
            .iter()
            .map(|v| (v - mean).abs())
            .fold(0.0, f64::max);
        let count = self.values.len();
        self.values.clear();
        if peak.is_nan() || peak > self.band {
            return Verdict::NotAtRest(format!(
                "the level moved by {peak:.3} V (more than {:.3} V, half-way to a threshold): a breath?",
                self.band
            ));
        }
        let shift = mean - self.configured;
        if shift.is_nan() || shift.abs() > self.max_shift {
            return Verdict::NotAtRest(format!(
                "the rest level {mean:.3} V is {shift:+.3} V from detector.neutral_volts {:.3} V (more than the {:.3} V sensor.rezero_max_shift_fraction allows): a breath held in, or the sensor's mapping is off",
                self.configured, self.max_shift
            ));
        }
        Verdict::AtRest(Neutral {
            volts: mean,
            noise_volts: variance.sqrt(),
            peak_volts: peak,
            samples: u32::try_from(count).unwrap_or(u32::MAX),
        })
    }
}

/// Measures the neutral from `samples`, one read a millisecond, telling
/// `say` why it waits whenever the sensor is not at rest.
pub fn measure(
    samples: &mut impl Samples,
    settings: &SensorSettings,
    detector: &DetectorConfig,
    mut say: impl FnMut(&str),
) -> Result<Neutral, SensorError> {
    let mut window = RestWindow::new(settings, detector);
    let started = Instant::now();
    let timeout = Duration::from_millis(u64::from(settings.rezero_timeout_ms));
    let mut last_reason = String::new();
    let mut next = Instant::now();
    loop {
        let reading = samples.try_read(0);
        if reading.sample == Sample::Lost {
            return Err(SensorError::Disconnected {
                what: "the sensor".into(),
                detail: "it went away while its neutral was being measured".into(),
            });
        }
        if let Sample::Volts(volts) = reading.sample {
            match window.push(volts) {
                Verdict::Measuring => {}
                Verdict::AtRest(neutral) => return Ok(neutral),
                Verdict::NotAtRest(reason) => {
                    say(&format!(
                        "measuring the sensor's neutral: {reason} — please rest (no sip or puff); measuring again"
                    ));
                    last_reason = reason;
                }
            }
        }
        if started.elapsed() > timeout {
            return Err(SensorError::WrongDevice {
                device: "the sensor".into(),
                message: format!(
                    "was not at rest for {} ms within {} ms, so its neutral could not be measured{}; rest away from the mouthpiece and start again (or set `[sensor] rezero = false` to use detector.neutral_volts)",
                    settings.rezero_ms,
                    settings.rezero_timeout_ms,
                    if last_reason.is_empty() {
                        " (no samples arrived)".to_string()
                    } else {
                        format!(" (last: {last_reason})")
                    }
                ),
            });
        }
        next += Duration::from_millis(1);
        let now = Instant::now();
        if next > now {
            std::thread::sleep(next - now);
        } else {
            next = now;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn window() -> RestWindow {
        RestWindow::new(&SensorSettings::default(), &DetectorConfig::default())
    }

    fn feed(w: &mut RestWindow, volts: impl IntoIterator<Item = f64>) -> Vec<Verdict> {
        volts
            .into_iter()
            .map(|v| w.push(v))
            .filter(|v| *v != Verdict::Measuring)
            .collect()
    }

    #[test]
    fn a_quiet_sensor_gives_its_mean_and_noise() {
        let mut w = window();
        // 1000 samples alternating 2.60 ± 0.01 V.
        let verdicts = feed(
            &mut w,
            (0..1000).map(|i| 2.6 + if i % 2 == 0 { 0.01 } else { -0.01 }),
        );
        let [Verdict::AtRest(n)] = verdicts.as_slice() else {
            panic!("{verdicts:?}");
        };
        assert!((n.volts - 2.6).abs() < 1e-12);
        assert!((n.noise_volts - 0.01).abs() < 1e-12);
        assert!((n.peak_volts - 0.01).abs() < 1e-12);
        assert_eq!(n.samples, 1000);
    }

    #[test]
    fn a_breath_during_the_window_means_measuring_again() {
        let mut w = window();
        let mut signal: Vec<f64> = vec![2.5; 700];
        signal.extend([3.6; 300]); // a puff
        signal.extend([2.5; 1000]);
        let verdicts = feed(&mut w, signal);
        assert!(
            matches!(&verdicts[0], Verdict::NotAtRest(why) if why.contains("a breath?")),
            "{verdicts:?}"
        );
        assert!(matches!(verdicts[1], Verdict::AtRest(n) if (n.volts - 2.5).abs() < 1e-12));
    }

    #[test]
    fn a_breath_held_steady_through_the_window_is_not_the_neutral() {
        let mut w = window();
        let verdicts = feed(&mut w, [2.9; 1000]);
        assert!(
            matches!(&verdicts[0], Verdict::NotAtRest(why) if why.contains("+0.400 V from detector.neutral_volts")),
            "{verdicts:?}"
        );
        // 0.2 V off (within the default 0.25 V): a drifted zero, taken.
        assert!(
            matches!(feed(&mut w, [2.7; 1000])[0], Verdict::AtRest(n) if (n.volts - 2.7).abs() < 1e-12)
        );
    }
}
