//! Rest/motion segmentation of the frames, with hysteresis.
//!
//! * The rate compared with the thresholds is smoothed ([`MovingAverage`]:
//!   the mean rate vector of the last 200 ms), so tremor and vibration at
//!   4–9 Hz neither start a segment at rest nor keep one open, while a
//!   gesture's 0.5–3 Hz movement passes.
//! * At rest, a frame whose smoothed rate exceeds `motion_on_rad_s`
//!   starts a segment; the [`LEAD_FRAMES`] frames before it (the
//!   movement's beginning, which the smoothing delays) open it.
//! * The segment ends once the head has been quiet (smoothed rate below
//!   `motion_off_rad_s`) *and* back near its orientation at the start for
//!   `rest_ms`; it ends where that quiet run began, and the quiet frames
//!   are not part of it. Near means both the gravity's deviation from rest
//!   and the rate about the vertical integrated since the segment began
//!   (the yaw) are below `hold_tilt_rad`: a tilt, look or turn held for a
//!   second does not split its gesture (the rates die down, the
//!   orientation stays; a held turn changes no gravity, so only the
//!   integrated yaw shows it).
//! * A sensor without gyros (its rates read exactly zero) starts and ends
//!   segments on the rate at which the gravity's direction changes. That
//!   sees nods and tilts but never a pure turn or shake: yaw about the
//!   vertical leaves gravity where it is.
//! * A segment shorter than `min_ms` is ignored (a twitch). One longer
//!   than `max_ms` ends at once as too long (the recognizer rejects it);
//!   the next starts only after `rest_ms` of quiet (any orientation: the
//!   person may have settled in a new posture, which becomes the rest).
//! * The gyro bias and the gravity are tracked only at rest.
//! * A frame's gravity deviation (its last three features) is the
//!   smoothed one the hold test sees ([`MovingAverage`]), so a tremor's
//!   or vibration's linear acceleration does not enter the distance.

use crate::control::Tick;
use crate::control::gesture::config::GestureConfig;
use crate::control::gesture::features::{
    FEATURES, Frame, FrameBuilder, MAX_FRAMES, MovingAverage, RestEstimate, norm3,
};
use crate::control::imu::ImuSample;

/// A segment just ended: its frames are [`Segmenter::frames`]. `Copy`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SegmentEnd {
    /// First tick of its first frame.
    pub start: Tick,
    /// First tick after its last frame.
    pub end: Tick,
    /// How many frames it holds.
    pub frames: usize,
    /// It lasted longer than `max_ms` (its frames are the first
    /// `max_ms`); never to be recognised.
    pub too_long: bool,
}

/// How many frames before the onset frame open a segment: 2, half the
/// smoothing's length, which is about how late the smoothed rate crosses
/// the onset threshold.
pub const LEAD_FRAMES: usize = 2;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    /// At rest: tracking the rest estimate.
    Rest,
    /// In a segment that began at `start`; `quiet` is the start of the
    /// current quiet run and how many frames the segment had then.
    Motion {
        start: Tick,
        quiet: Option<(Tick, usize)>,
    },
    /// After a too-long segment: waiting for quiet since `quiet`.
    TooLong { quiet: Option<Tick> },
}

/// Cuts the frames into segments. Construct once; [`Segmenter::step`] is
/// RT-safe (no allocation, no panic).
#[derive(Debug, Clone)]
pub struct Segmenter {
    config: GestureConfig,
    builder: FrameBuilder,
    held: Option<ImuSample>,
    rest: RestEstimate,
    state: State,
    buffer: [Frame; MAX_FRAMES],
    len: usize,
    /// The smoothed rate and gravity deviation the thresholds see.
    smoother: MovingAverage,
    tilt_smoother: MovingAverage,
    /// Whether the sensor has shown a non-zero rate (it has gyros).
    gyro: bool,
    /// The last frame's gravity deviation (for a sensor without gyros).
    last_tilt: [f64; 3],
    /// The last [`LEAD_FRAMES`] frames at rest and their first ticks,
    /// oldest first.
    lead: [(Tick, Frame, [f64; 3]); LEAD_FRAMES],
    /// The rates integrated since the segment began, rad.
    turned: [f64; 3],
}

impl Segmenter {
    /// A segmenter at rest, with no sample yet. `config` should be valid
    /// ([`GestureConfig::validate`]).
    pub fn new(config: &GestureConfig) -> Self {
        Segmenter {
            config: *config,
            builder: FrameBuilder::new(config.frame_ms),
            held: None,
            rest: RestEstimate::default(),
            state: State::Rest,
            buffer: [[0.0; FEATURES]; MAX_FRAMES],
            len: 0,
            smoother: MovingAverage::default(),
            tilt_smoother: MovingAverage::default(),
            gyro: false,
            last_tilt: [0.0; 3],
            lead: [(0, [0.0; FEATURES], [0.0; 3]); LEAD_FRAMES],
            turned: [0.0; 3],
        }
    }

    /// Tick `now`, with the sensor's new sample if one arrived (else the
    /// last is held; a non-finite sample is ignored and the last held).
    /// Ticks must increase. Returns the segment that ended on this tick.
    pub fn step(&mut self, now: Tick, sample: Option<&ImuSample>) -> Option<SegmentEnd> {
        if let Some(s) = sample.filter(|s| s.is_finite()) {
            self.held = Some(*s);
        }
        let (start, mean) = self.builder.push(now, self.held.as_ref())?;
        self.frame(start, &mean)
    }

    /// The frames of the last segment that ended (valid until the next
    /// segment starts).
    pub fn frames(&self) -> &[Frame] {
        self.buffer.get(..self.len).unwrap_or(&[])
    }

    /// A movement is under way (a segment begun, or a too-long one not yet
    /// quiet): a sequence's timeout waits for it.
    pub fn in_motion(&self) -> bool {
        !matches!(self.state, State::Rest)
    }

    /// The head at rest, as last tracked.
    pub fn rest(&self) -> &RestEstimate {
        &self.rest
    }

    /// Back to rest with no sample, forgetting the rest estimate.
    pub fn reset(&mut self) {
        *self = Segmenter::new(&self.config);
    }

    /// Back to rest with no sample, keeping the gyro's bias (the
    /// sensor's, whatever the head did): the next frame's gravity is the
    /// rest, as a new posture.
    pub fn restart(&mut self) {
        let bias = self.rest.bias;
        self.reset();
        self.rest.bias = bias;
    }

    /// One frame beginning at `start` with mean sample `mean`.
    fn frame(&mut self, start: Tick, mean: &ImuSample) -> Option<SegmentEnd> {
        if !self.rest.started() {
            // The first frame is the rest: nothing to compare it with.
            self.rest.track(mean, self.config.rest_alpha());
            return None;
        }
        let mut frame = self.rest.features(mean);
        let frame_ms = u64::from(self.config.frame_ms.max(1));
        let frame_s = frame_ms as f64 / 1000.0;
        let mut rate = self.rest.rate(mean);
        let tilt = self.rest.tilt(mean);
        self.gyro |= mean.rate().iter().any(|&r| r != 0.0);
        if !self.gyro {
            // No gyros: the gravity direction's rate of change stands in.
            for ((r, t), last) in rate.iter_mut().zip(tilt).zip(self.last_tilt) {
                *r = (t - last) / frame_s;
            }
        }
        self.last_tilt = tilt;
        let smoothed = self.smoother.push(rate);
        for (a, r) in self.turned.iter_mut().zip(rate) {
            *a += r * frame_s;
        }
        let quiet = smoothed < self.config.motion_off_rad_s;
        let away = self.tilt_smoother.push(tilt).max(self.yaw().abs());
        // The frame's tilt is the smoothed one: a tremor's or vibration's
        // linear acceleration swings the gravity by up to ±0.15 g at
        // 4–9 Hz, as much as a gesture's tilt, and averages out.
        for (f, t) in frame.iter_mut().skip(3).zip(self.tilt_smoother.mean()) {
            *f = t as f32;
        }
        let near_rest = away < self.config.hold_tilt_rad;
        let rest_ms = u64::from(self.config.rest_ms);
        match self.state {
            State::Rest => {
                if smoothed > self.config.motion_on_rad_s {
                    self.len = 0;
                    self.turned = [0.0; 3];
                    let mut seg_start = start;
                    for (tick, lead, lead_rate) in self.lead {
                        if tick < start && start - tick <= LEAD_FRAMES as u64 * frame_ms {
                            seg_start = seg_start.min(tick);
                            self.push(lead);
                            self.integrate(lead_rate, frame_s);
                        }
                    }
                    self.push(frame);
                    self.integrate(rate, frame_s);
                    self.state = State::Motion {
                        start: seg_start,
                        quiet: None,
                    };
                } else {
                    self.rest.track(mean, self.config.rest_alpha());
                    self.lead.rotate_left(1);
                    if let Some(last) = self.lead.last_mut() {
                        *last = (start, frame, rate);
                    }
                }
                None
            }
            State::Motion {
                start: seg_start,
                quiet: quiet_run,
            } => {
                let end = start + frame_ms;
                if quiet && near_rest {
                    let (since, frames) = quiet_run.unwrap_or((start, self.len));
                    self.state = State::Motion {
                        start: seg_start,
                        quiet: Some((since, frames)),
                    };
                    if end - since >= rest_ms {
                        self.len = frames;
                        self.state = State::Rest;
                        return (since - seg_start >= u64::from(self.config.min_ms)).then_some(
                            SegmentEnd {
                                start: seg_start,
                                end: since,
                                frames,
                                too_long: false,
                            },
                        );
                    }
                } else {
                    self.state = State::Motion {
                        start: seg_start,
                        quiet: None,
                    };
                }
                if end - seg_start > u64::from(self.config.max_ms) || !self.push(frame) {
                    self.state = State::TooLong { quiet: None };
                    return Some(SegmentEnd {
                        start: seg_start,
                        end,
                        frames: self.len,
                        too_long: true,
                    });
                }
                None
            }
            State::TooLong { quiet: quiet_run } => {
                if quiet {
                    let since = quiet_run.unwrap_or(start);
                    if start + frame_ms - since >= rest_ms {
                        self.rest.reanchor(mean);
                        self.state = State::Rest;
                    } else {
                        self.state = State::TooLong { quiet: Some(since) };
                    }
                } else {
                    self.state = State::TooLong { quiet: None };
                }
                None
            }
        }
    }

    /// The angle turned since the segment began about the vertical (the
    /// resting gravity's axis), rad: what a held turn shows. The other
    /// axes' turn shows in the gravity itself, without the integration's
    /// error.
    fn yaw(&self) -> f64 {
        let g = self.rest.gravity;
        let norm = norm3(g);
        if norm > 0.0 {
            self.turned.iter().zip(g).map(|(a, g)| a * g).sum::<f64>() / norm
        } else {
            0.0
        }
    }

    /// Adds a frame's rates (with gyros) to the angle turned.
    fn integrate(&mut self, rate: [f64; 3], frame_s: f64) {
        if self.gyro {
            for (a, r) in self.turned.iter_mut().zip(rate) {
                *a += r * frame_s;
            }
        }
    }

    /// Appends a frame; false if the buffer is full.
    fn push(&mut self, frame: Frame) -> bool {
        match self.buffer.get_mut(self.len) {
            Some(slot) => {
                *slot = frame;
                self.len += 1;
                true
            }
            None => false,
        }
    }
}

/// A segment cut from a recording by [`segments`].
#[derive(Debug, Clone, PartialEq)]
pub struct Segment {
    /// First tick of its first frame.
    pub start: Tick,
    /// First tick after its last frame.
    pub end: Tick,
    /// Its frames.
    pub frames: Vec<Frame>,
    /// It lasted longer than `max_ms` (see [`SegmentEnd::too_long`]).
    pub too_long: bool,
}

/// The segments of a recording, cut exactly as the live core cuts them:
/// [`Segmenter::step`] on every tick from the first sample's to the last
/// one's, the last sample held between samples. Samples must be in tick
/// order (a sample not after the previous one is skipped). Not RT-safe
/// (allocates): for offline tools.
pub fn segments(
    config: &GestureConfig,
    samples: impl IntoIterator<Item = (Tick, ImuSample)>,
) -> Vec<Segment> {
    let mut segmenter = Segmenter::new(config);
    let mut out = Vec::new();
    let mut next: Option<Tick> = None;
    let mut record = |segmenter: &Segmenter, end: Option<SegmentEnd>| {
        if let Some(end) = end {
            out.push(Segment {
                start: end.start,
                end: end.end,
                frames: segmenter.frames().to_vec(),
                too_long: end.too_long,
            });
        }
    };
    for (tick, sample) in samples {
        if next.is_some_and(|n| tick < n) {
            continue;
        }
        // The ticks with no sample before this one: the last held.
        let mut t = next.unwrap_or(tick);
        while t < tick {
            let end = segmenter.step(t, None);
            record(&segmenter, end);
            t += 1;
        }
        let end = segmenter.step(tick, Some(&sample));
        record(&segmenter, end);
        next = Some(tick + 1);
    }
    out
}
