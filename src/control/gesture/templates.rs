//! A person's recorded examples of each gesture, and each gesture's
//! rejection threshold. Built off the control thread (allocates); the
//! [`Recognizer`](super::Recognizer) owns them after construction. No
//! names: those live in the gesture set's file, outside the core.

use std::fmt;

use crate::control::gesture::features::{Frame, MAX_FRAMES};

/// Which gesture: an index into the gesture set (below [`MAX_GESTURES`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct GestureId(pub u8);

/// Gestures a set may hold.
pub const MAX_GESTURES: usize = 16;
/// Templates (examples) per gesture.
pub const MAX_TEMPLATES: usize = 8;
/// A template's fewest frames.
pub const MIN_TEMPLATE_FRAMES: usize = 2;

/// Why a template was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TemplateError {
    /// The gesture's id is not below [`MAX_GESTURES`].
    BadGesture,
    /// The gesture already has [`MAX_TEMPLATES`] templates.
    TooMany,
    /// Fewer than [`MIN_TEMPLATE_FRAMES`] frames.
    TooShort,
    /// More than [`MAX_FRAMES`] frames.
    TooLong,
    /// A feature is NaN or infinite.
    NotFinite,
}

impl fmt::Display for TemplateError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            TemplateError::BadGesture => "gesture id out of range",
            TemplateError::TooMany => "too many templates for this gesture",
            TemplateError::TooShort => "template too short",
            TemplateError::TooLong => "template longer than MAX_FRAMES",
            TemplateError::NotFinite => "template has a non-finite feature",
        })
    }
}

impl std::error::Error for TemplateError {}

/// One example of a gesture.
#[derive(Debug, Clone, PartialEq)]
pub struct Template {
    /// The gesture it shows.
    pub gesture: GestureId,
    /// Its frames.
    pub frames: Vec<Frame>,
}

/// The templates of every gesture and their thresholds.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct GestureTemplates {
    templates: Vec<Template>,
    thresholds: [Option<f64>; MAX_GESTURES],
}

impl GestureTemplates {
    /// No template, no threshold.
    pub fn new() -> Self {
        GestureTemplates::default()
    }

    /// Adds an example of `gesture`.
    pub fn add(&mut self, gesture: GestureId, frames: &[Frame]) -> Result<(), TemplateError> {
        if usize::from(gesture.0) >= MAX_GESTURES {
            return Err(TemplateError::BadGesture);
        }
        if self
            .templates
            .iter()
            .filter(|t| t.gesture == gesture)
            .count()
            >= MAX_TEMPLATES
        {
            return Err(TemplateError::TooMany);
        }
        if frames.len() < MIN_TEMPLATE_FRAMES {
            return Err(TemplateError::TooShort);
        }
        if frames.len() > MAX_FRAMES {
            return Err(TemplateError::TooLong);
        }
        if !frames.iter().flatten().all(|v| v.is_finite()) {
            return Err(TemplateError::NotFinite);
        }
        self.templates.push(Template {
            gesture,
            frames: frames.to_vec(),
        });
        Ok(())
    }

    /// Sets `gesture`'s rejection threshold: a segment further than this
    /// from its nearest template of `gesture` is rejected. A gesture with
    /// no threshold is never recognised. Ignored for an id out of range.
    pub fn set_threshold(&mut self, gesture: GestureId, distance: f64) {
        if let Some(slot) = self.thresholds.get_mut(usize::from(gesture.0)) {
            *slot = Some(distance);
        }
    }

    /// `gesture`'s rejection threshold, if set.
    pub fn threshold(&self, gesture: GestureId) -> Option<f64> {
        self.thresholds
            .get(usize::from(gesture.0))
            .copied()
            .flatten()
    }

    /// How many templates in all.
    pub fn len(&self) -> usize {
        self.templates.len()
    }

    /// Whether there is no template.
    pub fn is_empty(&self) -> bool {
        self.templates.is_empty()
    }

    /// The templates, in the order added.
    pub fn iter(&self) -> impl Iterator<Item = &Template> {
        self.templates.iter()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_templates_are_refused_with_their_reason() {
        let mut set = GestureTemplates::new();
        let ok = vec![[0.0; 6]; 10];
        assert_eq!(set.add(GestureId(16), &ok), Err(TemplateError::BadGesture));
        assert_eq!(
            set.add(GestureId(0), &ok[..1]),
            Err(TemplateError::TooShort)
        );
        let long = vec![[0.0; 6]; MAX_FRAMES + 1];
        assert_eq!(set.add(GestureId(0), &long), Err(TemplateError::TooLong));
        let mut nan = ok.clone();
        nan[3][2] = f32::NAN;
        assert_eq!(set.add(GestureId(0), &nan), Err(TemplateError::NotFinite));
        for _ in 0..MAX_TEMPLATES {
            set.add(GestureId(0), &ok).unwrap();
        }
        assert_eq!(set.add(GestureId(0), &ok), Err(TemplateError::TooMany));
        assert_eq!(set.len(), MAX_TEMPLATES);
        assert_eq!(set.threshold(GestureId(0)), None);
        set.set_threshold(GestureId(0), 0.4);
        assert_eq!(set.threshold(GestureId(0)), Some(0.4));
    }
}
