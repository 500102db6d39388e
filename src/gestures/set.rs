//! A gesture set: the person's gestures by name, each with its recorded
//! examples (the templates, as frames) and its rejection threshold, the
//! front end's settings they were cut with, the channels of the sensor
//! they came from and the recording. Written and read as TOML text; a
//! set read back is the set written, bit for bit.

use std::fmt::Write as _;
use std::ops::Range;

use serde::Deserialize;
use toml::Spanned;

use crate::control::Tick;
use crate::control::gesture::name::GestureName;
use crate::control::gesture::{
    FEATURES, Frame, GestureConfig, GestureId, GestureTemplates, MAX_FRAMES, MAX_GESTURES,
    MAX_TEMPLATES, Recognizer,
};
use crate::control::imu::{Channel, Channels};

/// One recorded example of a gesture.
#[derive(Debug, Clone, PartialEq)]
pub struct Example {
    /// The recording's first tick of the movement.
    pub start: Tick,
    /// The first tick after it.
    pub end: Tick,
    /// Its frames, as the front end cut them.
    pub frames: Vec<Frame>,
}

/// One gesture of a set.
#[derive(Debug, Clone, PartialEq)]
pub struct Gesture {
    /// Its name (`nod`, `tilt_left`): what a library entry names.
    pub name: String,
    /// A movement further than this from its nearest example is not it.
    pub threshold: f64,
    /// Its examples: the templates.
    pub examples: Vec<Example>,
}

/// The version of the frames' features a set's examples hold (the
/// `features` key): a set whose frames another front end computed would
/// be compared feature for feature with frames that mean something else,
/// so it is refused and recorded again.
pub const FEATURES_VERSION: u32 = 2;

/// A person's gesture set.
#[derive(Debug, Clone, PartialEq)]
pub struct GestureSet {
    /// The channels of the sensor it was recorded with.
    pub channels: Channels,
    /// The front end's settings the examples were cut with.
    pub config: GestureConfig,
    /// The recording the examples came from, if known.
    pub recording: Option<String>,
    /// The gestures, in the order recorded.
    pub gestures: Vec<Gesture>,
}

impl GestureSet {
    /// The gesture called `name`.
    pub fn id(&self, name: &str) -> Option<GestureId> {
        self.gestures
            .iter()
            .position(|g| g.name == name)
            .map(|i| GestureId(i as u8))
    }

    /// The name of gesture `id` (`?` out of range).
    pub fn name(&self, id: GestureId) -> &str {
        self.gestures
            .get(usize::from(id.0))
            .map_or("?", |g| g.name.as_str())
    }

    /// The templates and thresholds for the core, without example
    /// `leave_out` (gesture, example) if given, each threshold scaled by
    /// `scale`.
    pub fn templates(&self, leave_out: Option<(usize, usize)>, scale: f64) -> GestureTemplates {
        let mut templates = GestureTemplates::new();
        for (g, gesture) in self.gestures.iter().enumerate() {
            let id = GestureId(g as u8);
            templates.set_threshold(id, gesture.threshold * scale);
            for (e, example) in gesture.examples.iter().enumerate() {
                if leave_out != Some((g, e)) {
                    // A set is checked on reading: every example fits.
                    let _ = templates.add(id, &example.frames);
                }
            }
        }
        templates
    }

    /// The recognizer that runs this set.
    pub fn recognizer(&self) -> Result<Recognizer, Vec<String>> {
        Recognizer::new(self.config, self.templates(None, 1.0))
    }

    /// The set as TOML, after `header` (each line written as a comment).
    pub fn to_toml(&self, header: &[String]) -> String {
        let mut out = String::new();
        for line in header {
            let _ = writeln!(out, "# {line}");
        }
        if !header.is_empty() {
            out.push('\n');
        }
        let _ = writeln!(out, "features = {FEATURES_VERSION}");
        let _ = writeln!(out, "channels = \"{}\"", self.channels);
        if let Some(recording) = &self.recording {
            let _ = writeln!(out, "recording = {}", toml_string(recording));
        }
        let c = &self.config;
        let _ = writeln!(out, "\n# The front end the examples were cut with.");
        let _ = writeln!(out, "[front_end]");
        let _ = writeln!(out, "frame_ms = {}", c.frame_ms);
        let _ = writeln!(out, "motion_on_rad_s = {:?}", c.motion_on_rad_s);
        let _ = writeln!(out, "motion_off_rad_s = {:?}", c.motion_off_rad_s);
        let _ = writeln!(out, "hold_tilt_rad = {:?}", c.hold_tilt_rad);
        let _ = writeln!(out, "rest_ms = {}", c.rest_ms);
        let _ = writeln!(out, "min_ms = {}", c.min_ms);
        let _ = writeln!(out, "max_ms = {}", c.max_ms);
        let _ = writeln!(out, "rest_tracking_ms = {}", c.rest_tracking_ms);
        let _ = writeln!(out, "band_fraction = {:?}", c.band_fraction);
        let _ = writeln!(out, "ambiguity_margin = {:?}", c.ambiguity_margin);
        for gesture in &self.gestures {
            let _ = writeln!(out, "\n[[gesture]]");
            let _ = writeln!(out, "name = {}", toml_string(&gesture.name));
            let _ = writeln!(out, "threshold = {:?}", gesture.threshold);
            for example in &gesture.examples {
                let _ = writeln!(out, "\n[[gesture.example]]");
                let _ = writeln!(out, "start_tick = {}", example.start);
                let _ = writeln!(out, "end_tick = {}", example.end);
                let _ = writeln!(out, "frames = [");
                for frame in &example.frames {
                    let values: Vec<String> = frame.iter().map(|v| format!("{v:?}")).collect();
                    let _ = writeln!(out, "  [{}],", values.join(", "));
                }
                let _ = writeln!(out, "]");
            }
        }
        out
    }

    /// Reads a set written by [`GestureSet::to_toml`] (or by hand):
    /// every problem at once, each naming its key and line.
    pub fn from_toml(text: &str) -> Result<GestureSet, Vec<String>> {
        let file: SetFile = toml::from_str(text).map_err(|e| {
            let at = e
                .span()
                .map(|span| format!("line {}: ", line_of(text, span.start)))
                .unwrap_or_default();
            vec![format!("{at}{}", e.message().trim())]
        })?;
        let mut problems = Vec::new();
        let mut problem = |span: Range<usize>, message: String| {
            problems.push(format!("line {}: {message}", line_of(text, span.start)));
        };
        let version = file.features.as_ref().map(|v| *v.get_ref());
        if version != Some(FEATURES_VERSION) {
            let span = file.features.as_ref().map_or(0..0, Spanned::span);
            problem(
                span,
                format!(
                    "features: the examples' frames were computed by {} front end (this one is version {FEATURES_VERSION}): record the gestures again with `sipnpuff gestures record`",
                    version.map_or_else(
                        || "an earlier".to_string(),
                        |v| format!("version {v} of the")
                    )
                ),
            );
        }
        let mut channels = Channels::NONE;
        for name in file.channels.get_ref().split(',').map(str::trim) {
            match Channel::from_name(name) {
                Some(channel) => channels = channels.with(channel),
                None => problem(
                    file.channels.span(),
                    format!("channels: `{name}` is not a channel (known: ax, ay, az, gx, gy, gz)"),
                ),
            }
        }
        let f = file.front_end.get_ref();
        let config = GestureConfig {
            frame_ms: f.frame_ms,
            motion_on_rad_s: f.motion_on_rad_s,
            motion_off_rad_s: f.motion_off_rad_s,
            hold_tilt_rad: f.hold_tilt_rad,
            rest_ms: f.rest_ms,
            min_ms: f.min_ms,
            max_ms: f.max_ms,
            rest_tracking_ms: f.rest_tracking_ms,
            band_fraction: f.band_fraction,
            ambiguity_margin: f.ambiguity_margin,
        };
        if let Err(errors) = config.validate() {
            for error in errors {
                problem(file.front_end.span(), format!("front_end.{error}"));
            }
        }
        if file.gesture.is_empty() || file.gesture.len() > MAX_GESTURES {
            problem(
                0..0,
                format!(
                    "gesture: {} gestures; a set holds 1–{MAX_GESTURES}",
                    file.gesture.len()
                ),
            );
        }
        let mut gestures: Vec<Gesture> = Vec::with_capacity(file.gesture.len());
        for (g, entry) in file.gesture.into_iter().enumerate() {
            let key = format!("gesture #{}", g + 1);
            let name = entry.name.get_ref().clone();
            if !is_name(&name) {
                problem(
                    entry.name.span(),
                    format!(
                        "{key}.name: `{name}` is not a name (lower-case letters, digits and _, starting with a letter, at most 15)"
                    ),
                );
            } else if gestures.iter().any(|other| other.name == name) {
                problem(
                    entry.name.span(),
                    format!("{key}.name: `{name}` is named twice"),
                );
            }
            let threshold = *entry.threshold.get_ref();
            if !(threshold.is_finite() && threshold > 0.0) {
                problem(
                    entry.threshold.span(),
                    format!("{key}.threshold: {threshold} is not a distance > 0"),
                );
            }
            if entry.example.is_empty() || entry.example.len() > MAX_TEMPLATES {
                problem(
                    entry.name.span(),
                    format!(
                        "{key} ({name}): {} examples; a gesture has 1–{MAX_TEMPLATES}",
                        entry.example.len()
                    ),
                );
            }
            let mut examples = Vec::with_capacity(entry.example.len());
            for (e, example) in entry.example.into_iter().enumerate() {
                let span = example.frames.span();
                let rows = example.frames.into_inner();
                let key = format!("{key} ({name}) example #{}.frames", e + 1);
                if rows.len() < 2 || rows.len() > MAX_FRAMES {
                    problem(
                        span.clone(),
                        format!(
                            "{key}: {} frames; an example has 2–{MAX_FRAMES}",
                            rows.len()
                        ),
                    );
                }
                let mut frames = Vec::with_capacity(rows.len());
                for row in rows {
                    let frame: Option<Frame> = row.try_into().ok();
                    match frame {
                        Some(frame) if frame.iter().all(|v| v.is_finite()) => frames.push(frame),
                        _ => {
                            problem(
                                span.clone(),
                                format!("{key}: every frame is {FEATURES} finite numbers"),
                            );
                            break;
                        }
                    }
                }
                examples.push(Example {
                    start: example.start_tick,
                    end: example.end_tick,
                    frames,
                });
            }
            gestures.push(Gesture {
                name,
                threshold,
                examples,
            });
        }
        if problems.is_empty() {
            Ok(GestureSet {
                channels,
                config,
                recording: file.recording,
                gestures,
            })
        } else {
            Err(problems)
        }
    }
}

/// A gesture's name: lower-case letters, digits and `_`, starting with
/// a letter, at most
/// [`MAX_GESTURE_NAME`](crate::control::gesture::name::MAX_GESTURE_NAME)
/// bytes (a library entry names it).
pub fn is_name(name: &str) -> bool {
    GestureName::new(name).is_some()
}

/// `text` as a TOML basic string.
fn toml_string(text: &str) -> String {
    toml::Value::String(text.to_string()).to_string()
}

/// The 1-based line of byte `offset` in `text`.
fn line_of(text: &str, offset: usize) -> usize {
    text.get(..offset)
        .map_or(1, |before| before.matches('\n').count() + 1)
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SetFile {
    features: Option<Spanned<u32>>,
    channels: Spanned<String>,
    recording: Option<String>,
    front_end: Spanned<FrontEnd>,
    #[serde(default)]
    gesture: Vec<GestureEntry>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FrontEnd {
    frame_ms: u32,
    motion_on_rad_s: f64,
    motion_off_rad_s: f64,
    hold_tilt_rad: f64,
    rest_ms: u32,
    min_ms: u32,
    max_ms: u32,
    rest_tracking_ms: u32,
    band_fraction: f64,
    ambiguity_margin: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct GestureEntry {
    name: Spanned<String>,
    threshold: Spanned<f64>,
    #[serde(default)]
    example: Vec<ExampleEntry>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ExampleEntry {
    start_tick: Tick,
    end_tick: Tick,
    frames: Spanned<Vec<Vec<f32>>>,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn a_set() -> GestureSet {
        let example = |k: f32| Example {
            start: 4000,
            end: 4800,
            frames: (0..20)
                .map(|i| [k * i as f32 * 0.1, -0.25, 1.0 / 3.0, 0.0, 9.5e-7, -k])
                .collect(),
        };
        GestureSet {
            channels: Channels::ALL,
            config: GestureConfig::default(),
            recording: Some("sam \"protocol\".csv".into()),
            gestures: vec![
                Gesture {
                    name: "nod".into(),
                    threshold: 0.123_456_789,
                    examples: vec![example(1.0), example(1.1)],
                },
                Gesture {
                    name: "tilt_left".into(),
                    threshold: 2.0 / 3.0,
                    examples: vec![example(-1.0)],
                },
            ],
        }
    }

    #[test]
    fn a_set_read_back_is_the_set_written() {
        let set = a_set();
        let text = set.to_toml(&["sam's gestures".into()]);
        assert_eq!(GestureSet::from_toml(&text), Ok(set));
    }

    #[test]
    fn every_problem_is_named_with_its_key_and_line() {
        let text = a_set()
            .to_toml(&[])
            .replace("threshold = 0.123456789", "threshold = -1.0")
            .replace("name = \"tilt_left\"", "name = \"nod\"")
            .replace(
                "channels = \"ax,ay,az,gx,gy,gz\"",
                "channels = \"ax,volts\"",
            );
        let problems = GestureSet::from_toml(&text).unwrap_err();
        assert_eq!(
            problems,
            [
                "line 2: channels: `volts` is not a channel (known: ax, ay, az, gx, gy, gz)",
                "line 20: gesture #1.threshold: -1 is not a distance > 0",
                "line 75: gesture #2.name: `nod` is named twice",
            ]
        );
    }

    #[test]
    fn an_unknown_key_is_named_with_its_line() {
        let text = a_set()
            .to_toml(&[])
            .replace("threshold = 0.1", "treshold = 0.1");
        let problems = GestureSet::from_toml(&text).unwrap_err();
        assert_eq!(problems.len(), 1);
        assert!(
            problems[0].starts_with("line 20: unknown field `treshold`"),
            "{problems:?}"
        );
    }

    #[test]
    fn a_set_from_an_earlier_front_end_is_refused_with_what_to_do() {
        let text = a_set().to_toml(&[]);
        let earlier = text.replace(&format!("features = {FEATURES_VERSION}\n"), "");
        assert_eq!(
            GestureSet::from_toml(&earlier).unwrap_err(),
            [
                "line 1: features: the examples' frames were computed by an earlier front end (this one is version 2): record the gestures again with `sipnpuff gestures record`"
            ]
        );
        let other = text.replace("features = 2", "features = 1");
        assert_eq!(
            GestureSet::from_toml(&other).unwrap_err(),
            [
                "line 1: features: the examples' frames were computed by version 1 of the front end (this one is version 2): record the gestures again with `sipnpuff gestures record`"
            ]
        );
    }
}
