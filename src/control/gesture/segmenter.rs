//! Rest/motion segmentation of the frames, with hysteresis.
//!
//! * At rest, a frame whose angular rate exceeds `motion_on_rad_s` starts
//!   a segment (dated to that frame's first tick).
//! * The segment ends once the head has been quiet (rate below
//!   `motion_off_rad_s`) *and* back near its rest orientation (tilt below
//!   `hold_tilt_rad`) for `rest_ms`; it ends where that quiet run began,
//!   and the quiet frames are not part of it. So a tilt or look held for a
//!   second does not split its gesture: the rates die down, the tilt stays.
//! * A segment shorter than `min_ms` is ignored (a twitch). One longer
//!   than `max_ms` ends at once as too long (the recognizer rejects it);
//!   the next starts only after `rest_ms` of quiet (any orientation: the
//!   person may have settled in a new posture, which becomes the rest).
//! * The gyro bias and the gravity are tracked only at rest.

use crate::control::Tick;
use crate::control::gesture::config::GestureConfig;
use crate::control::gesture::features::{
    FEATURES, Frame, FrameBuilder, MAX_FRAMES, RestEstimate, rate_magnitude, tilt_magnitude,
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

    /// Back to rest with no sample, forgetting the rest estimate.
    pub fn reset(&mut self) {
        *self = Segmenter::new(&self.config);
    }

    /// One frame beginning at `start` with mean sample `mean`.
    fn frame(&mut self, start: Tick, mean: &ImuSample) -> Option<SegmentEnd> {
        let frame = self.rest.features(mean);
        let frame_ms = u64::from(self.config.frame_ms.max(1));
        let rate = rate_magnitude(&frame);
        let quiet = rate < self.config.motion_off_rad_s;
        let near_rest = tilt_magnitude(&frame) < self.config.hold_tilt_rad;
        let rest_ms = u64::from(self.config.rest_ms);
        match self.state {
            State::Rest => {
                if rate > self.config.motion_on_rad_s {
                    self.len = 0;
                    self.push(frame);
                    self.state = State::Motion { start, quiet: None };
                } else {
                    self.rest.track(mean, self.config.rest_alpha());
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
