//! What the gesture front end sees of the IMU: one [`Frame`] of features
//! per `frame_ms` window.
//!
//! * [`FrameBuilder`] averages the held sample over each window of time
//!   (every tick counts, whatever the sensor's rate), so a 100 Hz sensor
//!   whose samples are held between ticks and a 1 kHz one give the same
//!   frames, and tremor and vibration above the frame rate are damped.
//! * [`RestEstimate`] turns an averaged sample into features relative to
//!   the head at rest: the three angular rates minus the gyro's bias
//!   (rad/s), and the acceleration's deviation from the resting gravity
//!   divided by g (for small angles, the tilt away from rest in radians).
//!   Rates show the movement itself (a nod, a shake); the gravity
//!   deviation shows where the head points, so a held tilt or look stays
//!   visible after the rates have died down. The rates enter linearly
//!   when small and as square roots when large ([`rate_feature`]), so a
//!   fast small movement does not outweigh the angle a larger one
//!   reaches. Bias and gravity are tracked
//!   (exponential average) only while the head is at rest. The segmenter
//!   smooths the gravity deviation over [`SMOOTHING_FRAMES`] frames
//!   before it enters a frame (see the segmenter).
//!
//! Frames are `f32`: the features carry far less than seven significant
//! digits of meaning, and half the size halves the templates' memory and
//! the distance's memory traffic.

use crate::control::Tick;
use crate::control::imu::{CHANNELS, ImuSample};

/// How many features a [`Frame`] holds: rates x, y, z, then gravity
/// deviation x, y, z.
pub const FEATURES: usize = 6;

/// Most frames a segment or template holds: 56 (3.36 s at the default
/// 60 ms frames), which bounds the classifying tick's work.
pub const MAX_FRAMES: usize = 56;

/// One frame of features (see the module's documentation).
pub type Frame = [f32; FEATURES];

/// Standard gravity, m/s²: the acceleration deviation is divided by it.
pub const GRAVITY: f64 = 9.806_65;

/// Averages the held sample over consecutive windows of `frame_ms` ticks
/// (window `k` covers ticks `k·frame_ms ..< (k+1)·frame_ms`). RT-safe.
#[derive(Debug, Clone)]
pub struct FrameBuilder {
    frame_ms: u64,
    /// The window being summed and its first tick.
    window_start: Option<Tick>,
    sum: [f64; CHANNELS],
    count: u32,
}

impl FrameBuilder {
    /// A builder for windows of `frame_ms` ticks (at least 1).
    pub fn new(frame_ms: u32) -> Self {
        FrameBuilder {
            frame_ms: u64::from(frame_ms.max(1)),
            window_start: None,
            sum: [0.0; CHANNELS],
            count: 0,
        }
    }

    /// Adds tick `now` with the sample held at that tick (none before the
    /// first). When `now` is in a later window than the one being summed,
    /// returns that window's first tick and mean sample: the frame is
    /// complete. Windows no tick fell in (a stall) give no frame.
    pub fn push(&mut self, now: Tick, held: Option<&ImuSample>) -> Option<(Tick, ImuSample)> {
        let window = now - now % self.frame_ms;
        let mut done = None;
        if let Some(start) = self.window_start
            && start != window
        {
            if self.count > 0 {
                let n = f64::from(self.count);
                let mut mean = ImuSample::default();
                for (m, s) in mean.values.iter_mut().zip(self.sum) {
                    *m = s / n;
                }
                done = Some((start, mean));
            }
            self.sum = [0.0; CHANNELS];
            self.count = 0;
        }
        self.window_start = Some(window);
        if let Some(sample) = held {
            for (s, v) in self.sum.iter_mut().zip(sample.values) {
                *s += v;
            }
            self.count += 1;
        }
        done
    }

    /// Forgets the window being summed.
    pub fn reset(&mut self) {
        *self = FrameBuilder::new(self.frame_ms as u32);
    }
}

/// The head at rest: the gyro's bias and the gravity vector, tracked
/// while at rest. RT-safe.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RestEstimate {
    /// Gyro bias, rad/s.
    pub bias: [f64; 3],
    /// Gravity as the accelerometer reads it at rest, m/s².
    pub gravity: [f64; 3],
    /// Whether a first frame has set them.
    started: bool,
}

impl Default for RestEstimate {
    fn default() -> Self {
        RestEstimate {
            bias: [0.0; 3],
            gravity: [0.0; 3],
            started: false,
        }
    }
}

impl RestEstimate {
    /// The features of `mean` (a frame's mean sample) against this rest:
    /// [`rate_feature`] of each bias-free rate, then the gravity
    /// deviation in g.
    pub fn features(&self, mean: &ImuSample) -> Frame {
        let mut frame = [0.0f32; FEATURES];
        let (rates, tilts) = frame.split_at_mut(3);
        for (f, r) in rates.iter_mut().zip(self.rate(mean)) {
            *f = rate_feature(r) as f32;
        }
        for (f, t) in tilts.iter_mut().zip(self.tilt(mean)) {
            *f = t as f32;
        }
        frame
    }

    /// The angular rate of `mean` less the gyro's bias, rad/s.
    pub fn rate(&self, mean: &ImuSample) -> [f64; 3] {
        let mut rate = mean.rate();
        for (r, b) in rate.iter_mut().zip(self.bias) {
            *r -= b;
        }
        rate
    }

    /// The acceleration of `mean` less the resting gravity, in g.
    pub fn tilt(&self, mean: &ImuSample) -> [f64; 3] {
        let mut tilt = mean.acceleration();
        for (t, g) in tilt.iter_mut().zip(self.gravity) {
            *t = (*t - g) / GRAVITY;
        }
        tilt
    }

    /// Moves bias and gravity towards `mean` by `alpha` (0–1), or sets
    /// gravity from it on the first frame (the bias starts at zero).
    pub fn track(&mut self, mean: &ImuSample, alpha: f64) {
        if !self.started {
            self.started = true;
            self.gravity = mean.acceleration();
            return;
        }
        for (b, r) in self.bias.iter_mut().zip(mean.rate()) {
            *b += alpha * (r - *b);
        }
        for (g, a) in self.gravity.iter_mut().zip(mean.acceleration()) {
            *g += alpha * (a - *g);
        }
    }

    /// Whether a first frame has set the gravity.
    pub fn started(&self) -> bool {
        self.started
    }

    /// Takes `mean`'s acceleration as the new gravity at once (a new
    /// posture after a too-long segment).
    pub fn reanchor(&mut self, mean: &ImuSample) {
        self.started = true;
        self.gravity = mean.acceleration();
    }
}

/// How many frames [`MovingAverage`] averages: 4 (240 ms with the 60 ms
/// frames). A moving average this long has its nulls at 4.2 and 8.3 Hz
/// and passes at most 27 % of anything from 4 to 9 Hz (tremor, a
/// wheelchair's vibration), while a 1 Hz gesture keeps 90 % of its peak
/// and a 3 Hz one a third of it.
pub const SMOOTHING_FRAMES: usize = 4;

/// The moving average of the last [`SMOOTHING_FRAMES`] vectors (a frame's
/// rates, or its gravity deviation): what the segmenter compares with its
/// thresholds. Averaging the vector (not its magnitude) lets an
/// oscillation cancel itself: a 1° tremor at 4.5 Hz swings the rate by
/// ±0.6 rad/s and, through its linear acceleration, the gravity by
/// ±0.15 g. RT-safe.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MovingAverage {
    recent: [[f64; 3]; SMOOTHING_FRAMES],
    next: usize,
}

impl MovingAverage {
    /// Adds a frame's vector; returns the magnitude of the
    /// mean of the last [`SMOOTHING_FRAMES`] (zeros before the first).
    pub fn push(&mut self, rate: [f64; 3]) -> f64 {
        if let Some(slot) = self.recent.get_mut(self.next) {
            *slot = rate;
        }
        self.next = (self.next + 1) % SMOOTHING_FRAMES;
        self.mean().iter().map(|m| m.powi(2)).sum::<f64>().sqrt()
    }

    /// The mean of the last [`SMOOTHING_FRAMES`] vectors (zeros before
    /// the first).
    pub fn mean(&self) -> [f64; 3] {
        let mut sum = [0.0; 3];
        for r in &self.recent {
            for (s, v) in sum.iter_mut().zip(r) {
                *s += v;
            }
        }
        sum.map(|s| s / SMOOTHING_FRAMES as f64)
    }
}

/// How much the rates weigh against the tilt in a frame (0.7: a rate of
/// 1 rad/s weighs as a tilt of 0.29 rad through [`rate_feature`]'s
/// knee; the tilt, smoothed, is the steadier measure of how far the
/// head went).
pub const RATE_WEIGHT: f64 = 0.7;

/// Where [`rate_feature`] turns from about linear to a square root,
/// rad/s (1: a deliberate nod peaks at 1.5–3 rad/s; an off-axis drift
/// of a few per cent of it, or a tremor's ±0.5 rad/s, stays near the
/// linear part).
pub const RATE_KNEE: f64 = 1.0;

/// A rate's feature, rad/s in, times [`RATE_WEIGHT`]:
/// `sign(r)·(√(|r| + k) − √k)` with `k` = [`RATE_KNEE`]. Above the knee
/// it grows as a square root, which compresses speed: talk's small fast
/// nods (2–5 Hz) reach rates near a deliberate nod's, and plain rates
/// let that speed outweigh the amplitude the tilt shows. Below the knee
/// it is about linear (slope `1/(2√k)`): a plain square root's infinite
/// slope at zero made the few per cent of a gesture that go off its
/// axis, and a tremor's swings, weigh as much as the movement itself.
pub fn rate_feature(rate: f64) -> f64 {
    RATE_WEIGHT * rate.signum() * ((rate.abs() + RATE_KNEE).sqrt() - RATE_KNEE.sqrt())
}

/// The rate, rad/s, whose [`rate_feature`] is `feature` (its inverse).
pub fn feature_rate(feature: f64) -> f64 {
    let root = feature.abs() / RATE_WEIGHT + RATE_KNEE.sqrt();
    feature.signum() * (root * root - RATE_KNEE)
}

/// How far `frames` (of `frame_ms` each) turn the head from where it was
/// at their start, at most, rad: their rates integrated, the largest
/// angle reached. A gesture's size, whatever its speed; a tremor's or
/// a vibration's swings integrate to little. RT-safe.
pub fn excursion(frames: &[Frame], frame_ms: u32) -> f64 {
    let frame_s = f64::from(frame_ms) / 1000.0;
    let mut turned = [0.0f64; 3];
    let mut most = 0.0f64;
    for frame in frames {
        for (a, &f) in turned.iter_mut().zip(frame.iter()) {
            *a += feature_rate(f64::from(f)) * frame_s;
        }
        most = most.max(turned.iter().map(|a| a * a).sum::<f64>());
    }
    most.sqrt()
}

/// The magnitude of a frame's rate features.
pub fn rate_magnitude(frame: &Frame) -> f64 {
    norm(frame.iter().take(3))
}

/// The gravity deviation's magnitude in a frame (≈ the tilt from rest, rad).
pub fn tilt_magnitude(frame: &Frame) -> f64 {
    norm(frame.iter().skip(3))
}

/// The length of a 3-vector (a gravity, an acceleration).
pub fn norm3(v: [f64; 3]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

fn norm<'a>(values: impl Iterator<Item = &'a f32>) -> f64 {
    values
        .map(|&v| f64::from(v) * f64::from(v))
        .sum::<f64>()
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(values: [f64; 6]) -> ImuSample {
        ImuSample { values }
    }

    #[test]
    fn a_frame_is_the_mean_of_the_held_sample_over_its_ticks() {
        let mut builder = FrameBuilder::new(20);
        let a = sample([1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let b = sample([3.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        // 100 Hz: a held for ticks 0–9, b for 10–19.
        for t in 0..20 {
            let held = if t < 10 { &a } else { &b };
            assert_eq!(builder.push(t, Some(held)), None);
        }
        let (start, mean) = builder.push(20, Some(&b)).unwrap();
        assert_eq!(start, 0);
        assert_eq!(mean.values[0], 2.0);
    }

    #[test]
    fn the_moving_average_damps_tremor_and_keeps_a_gesture() {
        // Peak of the smoothed magnitude of a sine sampled every 60 ms.
        let peak = |hz: f64| {
            let mut average = MovingAverage::default();
            (0..200)
                .map(|k| {
                    let t = k as f64 * 0.06;
                    average.push([(std::f64::consts::TAU * hz * t).sin(), 0.0, 0.0])
                })
                .skip(SMOOTHING_FRAMES)
                .fold(0.0, f64::max)
        };
        assert!(peak(1.0) > 0.85, "{}", peak(1.0));
        for hz in [4.5, 6.0, 8.0] {
            assert!(peak(hz) < 0.3, "{hz} Hz: {}", peak(hz));
        }
    }

    #[test]
    fn features_are_bias_free_rates_and_tilt_in_g() {
        let mut rest = RestEstimate::default();
        rest.track(&sample([0.0, 0.0, GRAVITY, 0.0, 0.0, 0.0]), 0.1);
        rest.bias = [0.1, 0.0, 0.0];
        let tilted = sample([0.0, GRAVITY * 0.5, GRAVITY, 1.1, 0.0, 0.0]);
        let frame = rest.features(&tilted);
        let one = rate_feature(1.0) as f32;
        assert_eq!(frame, [one, 0.0, 0.0, 0.0, 0.5, 0.0]);
        assert!((tilt_magnitude(&frame) - 0.5).abs() < 1e-9);
        assert!((rate_magnitude(&frame) - f64::from(one)).abs() < 1e-9);
    }

    #[test]
    fn the_rate_feature_is_linear_when_small_and_a_root_when_large() {
        let slope = RATE_WEIGHT / (2.0 * RATE_KNEE.sqrt());
        assert!((rate_feature(0.01) / 0.01 - slope).abs() < 0.01 * slope);
        assert_eq!(rate_feature(0.0), 0.0);
        assert_eq!(rate_feature(-2.0), -rate_feature(2.0));
        // Four times the rate, about twice the feature, far above the knee.
        let r = 10_000.0 * RATE_KNEE;
        assert!((rate_feature(4.0 * r) / rate_feature(r) - 2.0).abs() < 0.1);
        for rate in [-3.0, -0.2, 0.0, 0.05, 1.0, 2.5] {
            assert!(
                (feature_rate(rate_feature(rate)) - rate).abs() < 1e-12,
                "{rate}"
            );
        }
    }

    #[test]
    fn excursion_is_the_largest_angle_turned() {
        // 0.5 rad/s for 10 frames of 60 ms, then back: 0.3 rad at most.
        let out = [rate_feature(0.5) as f32, 0.0, 0.0, 0.0, 0.0, 0.0];
        let back = [rate_feature(-0.5) as f32, 0.0, 0.0, 0.0, 0.0, 0.0];
        let frames: Vec<Frame> = std::iter::repeat_n(out, 10)
            .chain(std::iter::repeat_n(back, 10))
            .collect();
        assert!((excursion(&frames, 60) - 0.3).abs() < 1e-6);
        assert_eq!(excursion(&[], 60), 0.0);
    }
}
