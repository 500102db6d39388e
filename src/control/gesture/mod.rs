//! The gesture front end: a head-worn IMU's samples in, recognised (or
//! rejected) gestures out. Pure, deterministic and allocation-free after
//! construction, like the burst detector.
//!
//! ```text
//! ImuSample (held between samples) ─► frames (features, every frame_ms)
//!   ─► segmenter (rest/motion, hysteresis) ─► recognizer (banded DTW
//!      against the person's templates, per-gesture threshold) ─► event
//! ```
//!
//! * [`features`]: what a frame holds (bias-free rates, tilt from rest);
//! * [`segmenter`]: where a gesture starts and ends;
//! * [`dtw`]: the distance between two segments and its lower bound;
//! * [`templates`]: a person's examples and thresholds;
//! * [`recognizer`]: the nearest gesture, or a rejection.
//!
//! Sizes are fixed so the worst tick is bounded: at most [`MAX_FRAMES`]
//! frames a segment or template, [`MAX_GESTURES`] gestures of
//! [`MAX_TEMPLATES`] templates each.

pub mod config;
pub mod dtw;
pub mod features;
pub mod name;
pub mod recognizer;
pub mod segmenter;
pub mod templates;

pub use config::GestureConfig;
pub use dtw::{Envelope, dtw_distance, lb_keogh};
pub use features::{FEATURES, Frame, FrameBuilder, MAX_FRAMES, excursion};
pub use recognizer::{
    Classification, GestureEvent, MIN_SIZE, Recognizer, RejectReason, Verdict, comparable_lengths,
};
pub use segmenter::{Segment, SegmentEnd, Segmenter, segments};
pub use templates::{GestureId, GestureTemplates, MAX_GESTURES, MAX_TEMPLATES, TemplateError};
