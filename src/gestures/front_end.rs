//! The front end fitted to the person, as the breath interface is fitted
//! from their rest and breaths: the segmenter's onset and end thresholds
//! just above what their head does at rest (tremor, a wheelchair's
//! vibration, the sensor's noise), measured in the protocol's opening
//! rest, so a small, slow person's gestures start segments and a
//! tremor's do not.
//!
//! The rest is measured as the segmenter sees it: frames averaged over
//! `frame_ms`, the rates less their mean (the gyro's bias) and the
//! acceleration less its mean (the resting gravity), each smoothed by
//! [`MovingAverage`]. Of that rest:
//!
//! * `motion_on_rad_s` is [`ON_OVER_REST`] × its largest smoothed rate,
//!   within [`ON_RANGE`];
//! * `motion_off_rad_s` is half the onset;
//! * `hold_tilt_rad` is at least [`HOLD_OVER_REST`] × its largest
//!   smoothed gravity deviation (the default otherwise).

use crate::control::Tick;
use crate::control::gesture::GestureConfig;
use crate::control::gesture::features::{FrameBuilder, GRAVITY, MovingAverage, SMOOTHING_FRAMES};
use crate::control::imu::ImuSample;
use crate::gestures::protocol::REST_MS;

/// The onset is this many times the rest's largest smoothed rate…
pub const ON_OVER_REST: f64 = 4.0;
/// …within this range, rad/s (least: below it, sensor noise and the
/// bias's drift; most: the default for a typical person, whose gestures
/// peak at 1.5–3 rad/s).
pub const ON_RANGE: (f64, f64) = (0.2, 0.6);
/// The hold threshold is at least this many times the rest's largest
/// smoothed gravity deviation.
pub const HOLD_OVER_REST: f64 = 3.0;
/// The last part of the opening rest is not measured, ms: the first
/// movement's smoothed beginning may reach into it.
const REST_MARGIN_MS: Tick = 300;

/// What the opening rest shows, as the segmenter would see it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rest {
    /// Largest smoothed rate, rad/s.
    pub rate: f64,
    /// Largest smoothed gravity deviation, g (≈ rad).
    pub tilt: f64,
}

/// The opening rest of `samples` (tick order) measured with `config`'s
/// frames: its first [`REST_MS`] less a margin. None if the recording is
/// shorter or holds too few frames.
pub fn rest(config: &GestureConfig, samples: &[(Tick, ImuSample)]) -> Option<Rest> {
    let &(first, _) = samples.first()?;
    let until = first + REST_MS - REST_MARGIN_MS;
    if samples.last()?.0 < first + REST_MS {
        return None;
    }
    let mut builder = FrameBuilder::new(config.frame_ms);
    let mut frames: Vec<ImuSample> = Vec::new();
    let mut held: Option<&ImuSample> = None;
    let mut samples = samples.iter().peekable();
    for tick in first..until {
        while let Some((_, s)) = samples.next_if(|(t, _)| *t <= tick) {
            held = Some(s);
        }
        if let Some((_, mean)) = builder.push(tick, held) {
            frames.push(mean);
        }
    }
    if frames.len() < 2 * SMOOTHING_FRAMES {
        return None;
    }
    let n = frames.len() as f64;
    let mut mean = [0.0; 6];
    for f in &frames {
        for (m, v) in mean.iter_mut().zip(f.values) {
            *m += v / n;
        }
    }
    let (mut rates, mut tilts) = (MovingAverage::default(), MovingAverage::default());
    let mut rest = Rest {
        rate: 0.0,
        tilt: 0.0,
    };
    for (i, f) in frames.iter().enumerate() {
        let mut rate = [0.0; 3];
        let mut tilt = [0.0; 3];
        for (k, (r, t)) in rate.iter_mut().zip(tilt.iter_mut()).enumerate() {
            *t = (f.values[k] - mean[k]) / GRAVITY;
            *r = f.values[k + 3] - mean[k + 3];
        }
        let (rate, tilt) = (rates.push(rate), tilts.push(tilt));
        // The average is full only from its last frame on.
        if i + 1 >= SMOOTHING_FRAMES {
            rest.rate = rest.rate.max(rate);
            rest.tilt = rest.tilt.max(tilt);
        }
    }
    Some(rest)
}

/// `config` with its onset, end and hold thresholds fitted to `rest`.
pub fn fit(config: &GestureConfig, rest: &Rest) -> GestureConfig {
    let on = (ON_OVER_REST * rest.rate).clamp(ON_RANGE.0, ON_RANGE.1);
    GestureConfig {
        motion_on_rad_s: on,
        motion_off_rad_s: on / 2.0,
        hold_tilt_rad: config.hold_tilt_rad.max(HOLD_OVER_REST * rest.tilt),
        ..*config
    }
}
