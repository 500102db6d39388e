//! A gesture set made from a recording that follows the protocol: the
//! front end cuts its movements exactly as it will live, the protocol
//! names each one, every example becomes a template, and the thresholds
//! come from the examples and the ordinary movement recorded after them.

use crate::control::Tick;
use crate::control::gesture::{GestureConfig, MAX_GESTURES, Segment, segments};
use crate::control::imu::{Channel, Channels, ImuSample};
use crate::gestures::front_end::{self, Rest};
use crate::gestures::protocol::{self, EXAMPLES, ProtocolCut, Span};
use crate::gestures::set::{Example, Gesture, GestureSet, is_name};
use crate::gestures::thresholds::{self, Choice};

/// The channels the front end cannot do without.
pub const NEEDED: [Channel; 3] = [Channel::Gx, Channel::Gy, Channel::Gz];

/// A set made from a recording, with what it was made from.
#[derive(Debug, Clone)]
pub struct Recorded {
    /// The set.
    pub set: GestureSet,
    /// Which movement was which example, and the ordinary stretch.
    pub cut: ProtocolCut,
    /// Every movement the front end cut from the recording.
    pub segments: Vec<Segment>,
    /// How each gesture's threshold was chosen.
    pub choices: Vec<Choice>,
    /// The opening rest the front end was fitted to (none if the
    /// recording is too short to hold it: the config given is kept).
    pub rest: Option<Rest>,
}

impl Recorded {
    /// The movements of the ordinary stretch.
    pub fn ordinary(&self) -> impl Iterator<Item = &Segment> {
        let Span { start, end } = self.cut.ordinary;
        self.segments
            .iter()
            .filter(move |s| s.start >= start && s.end <= end + 1)
    }
}

/// The gesture names given, checked: one line naming every bad one.
pub fn check_names(names: &[String]) -> Result<(), String> {
    let mut bad = Vec::new();
    for (i, name) in names.iter().enumerate() {
        if !is_name(name) {
            bad.push(format!(
                "`{name}` is not a name (lower-case letters, digits and _, starting with a letter, at most 15)"
            ));
        } else if names.get(..i).is_some_and(|before| before.contains(name)) {
            bad.push(format!("`{name}` is named twice"));
        }
    }
    if names.is_empty() {
        bad.push("no gesture named".into());
    }
    if names.len() > MAX_GESTURES {
        bad.push(format!(
            "{} gestures; a set holds at most {MAX_GESTURES}",
            names.len()
        ));
    }
    if bad.is_empty() {
        Ok(())
    } else {
        Err(format!("--gestures: {}", bad.join("; ")))
    }
}

/// The set for `names` from `samples` (of `channels`), recorded by the
/// protocol; `recording` names it in the set. `config`'s onset, end and
/// hold thresholds are first fitted to the person's opening rest
/// ([`front_end`]); the set keeps the fitted config.
pub fn record(
    samples: &[(Tick, ImuSample)],
    channels: Channels,
    names: &[String],
    config: GestureConfig,
    recording: Option<String>,
) -> Result<Recorded, String> {
    let fit = fitted(samples, channels, names, config)?;
    let cut = cut_protocol(&fit.0, names, samples)?;
    build(samples, channels, names, fit, recording, cut)
}

/// The set for `names` from a guided live session's `samples`, each
/// gesture's examples where the guide saw them (`examples`, as
/// [`guided::Guided`](super::guided::Guided) labelled them) rather than
/// where the protocol's timing would put them; the ordinary movement is
/// everything after the last example. Otherwise made as [`record`]
/// makes it.
pub fn record_guided(
    samples: &[(Tick, ImuSample)],
    channels: Channels,
    names: &[String],
    config: GestureConfig,
    recording: Option<String>,
    examples: &[Vec<Span>],
) -> Result<Recorded, String> {
    let fit = fitted(samples, channels, names, config)?;
    let segments = segments(&fit.0, samples.iter().copied());
    let mut cut = Vec::with_capacity(names.len());
    let mut last_end = samples.first().map_or(0, |(t, _)| *t);
    for (name, spans) in names.iter().zip(examples) {
        let mut indices = [0usize; EXAMPLES];
        if spans.len() != EXAMPLES {
            return Err(format!(
                "gesture '{name}': {} examples seen, {EXAMPLES} needed",
                spans.len()
            ));
        }
        for (slot, span) in indices.iter_mut().zip(spans) {
            *slot = segments
                .iter()
                .position(|s| s.start == span.start && s.end == span.end)
                .ok_or_else(|| {
                    format!(
                        "gesture '{name}': the movement from tick {} to {} is not one the front end cuts from the recording",
                        span.start, span.end
                    )
                })?;
            last_end = last_end.max(span.end);
        }
        cut.push(indices);
    }
    if cut.len() != names.len() {
        return Err(format!(
            "examples of {} gestures seen, {} named",
            cut.len(),
            names.len()
        ));
    }
    let last = samples.last().map_or(last_end, |(t, _)| *t);
    let cut = ProtocolCut {
        examples: cut,
        ordinary: Span {
            start: last_end,
            end: last,
        },
    };
    build(samples, channels, names, fit, recording, (segments, cut))
}

/// The names checked, the channels the front end needs present, and
/// `config` fitted to the recording's opening rest (with the rest).
fn fitted(
    samples: &[(Tick, ImuSample)],
    channels: Channels,
    names: &[String],
    config: GestureConfig,
) -> Result<(GestureConfig, Option<Rest>), String> {
    check_names(names)?;
    let missing: Vec<&str> = NEEDED
        .iter()
        .filter(|c| !channels.contains(**c))
        .map(|c| c.name())
        .collect();
    if !missing.is_empty() {
        return Err(format!(
            "the recording has {channels} but the gesture front end needs the angular rates too (missing: {})",
            missing.join(", ")
        ));
    }
    if samples.is_empty() {
        return Err("the recording has no sample".into());
    }
    // The front end fitted to the person's rest before anything is cut.
    let rest = front_end::rest(&config, samples);
    let config = rest.map_or(config, |rest| front_end::fit(&config, &rest));
    Ok((config, rest))
}

/// The set from the front end as fitted (`config` and the rest it was
/// fitted to), the movements cut and which is which: every example a
/// template, each threshold from the examples and the ordinary movement.
fn build(
    samples: &[(Tick, ImuSample)],
    channels: Channels,
    names: &[String],
    (config, rest): (GestureConfig, Option<Rest>),
    recording: Option<String>,
    (segments, cut): (Vec<Segment>, ProtocolCut),
) -> Result<Recorded, String> {
    let first = samples.first().map_or(0, |(t, _)| *t);
    let mut gestures = Vec::with_capacity(names.len());
    for (name, indices) in names.iter().zip(&cut.examples) {
        let mut examples = Vec::with_capacity(EXAMPLES);
        for (k, &i) in indices.iter().enumerate() {
            let Some(segment) = segments.get(i) else {
                return Err(format!("gesture '{name}': example {} not found", k + 1));
            };
            if segment.too_long {
                return Err(format!(
                    "gesture '{name}': example {} at {:.1} s lasts {:.1} s, longer than the front end's {:.1} s (max_ms): make it quicker, or hold it less",
                    k + 1,
                    (segment.start - first) as f64 / 1000.0,
                    (segment.end - segment.start) as f64 / 1000.0,
                    f64::from(config.max_ms) / 1000.0
                ));
            }
            examples.push(Example {
                start: segment.start,
                end: segment.end,
                frames: segment.frames.clone(),
            });
        }
        gestures.push(Gesture {
            name: name.clone(),
            threshold: f64::INFINITY,
            examples,
        });
    }
    let mut set = GestureSet {
        channels,
        config,
        recording,
        gestures,
    };
    let mut recorded = Recorded {
        set: set.clone(),
        cut,
        segments,
        choices: Vec::new(),
        rest,
    };
    let ordinary: Vec<_> = recorded
        .ordinary()
        .filter(|s| !s.too_long)
        .map(|s| s.frames.clone())
        .collect();
    let choices = thresholds::choose(&set, &ordinary);
    for (gesture, choice) in set.gestures.iter_mut().zip(&choices) {
        gesture.threshold = choice.threshold;
    }
    recorded.set = set;
    recorded.choices = choices;
    Ok(recorded)
}

/// The movements the front end cuts from `samples` with `config`, and the
/// protocol's cut of them for `names`: which movement is which example,
/// and the ordinary stretch. The front end sees a movement begin and end
/// a little away from the head, by up to its rest time and two frames.
pub fn cut_protocol(
    config: &GestureConfig,
    names: &[String],
    samples: &[(Tick, ImuSample)],
) -> Result<(Vec<Segment>, ProtocolCut), String> {
    let (Some(&(first, _)), Some(&(last, _))) = (samples.first(), samples.last()) else {
        return Err("the recording has no sample".into());
    };
    let segments = segments(config, samples.iter().copied());
    let spans: Vec<Span> = segments
        .iter()
        .map(|s| Span {
            start: s.start,
            end: s.end,
        })
        .collect();
    let slack = Tick::from(config.rest_ms) + 2 * Tick::from(config.frame_ms);
    let cut = protocol::cut(names, first, last, &spans, slack).map_err(|e| e.to_string())?;
    Ok((segments, cut))
}
