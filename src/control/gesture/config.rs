//! The gesture front end's settings: how samples become frames, when a
//! segment starts and ends, and how strict the matching is.

use crate::control::gesture::features::MAX_FRAMES;

/// Gesture front end settings. `Copy`; check with [`GestureConfig::validate`]
/// before building a [`Segmenter`](super::Segmenter) or
/// [`Recognizer`](super::Recognizer).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GestureConfig {
    /// Length of one frame, ms (60: 16.7 frames a second, well above a
    /// head gesture's 0.5–3.5 Hz; the mean over 60 ms damps vibration at
    /// 17 Hz and above; 3.36 s fit in [`MAX_FRAMES`], the slowest tilt
    /// held for a second, and the worst classifying tick stays within
    /// its budget).
    pub frame_ms: u32,
    /// A segment starts when the smoothed angular rate's magnitude (bias
    /// removed; see the segmenter) exceeds this, rad/s (0.3: a deliberate
    /// nod peaks at 1.5–3 rad/s, a small slow one at 0.6; smoothed tremor
    /// stays below 0.1). Fitted to the person's rest when a set is
    /// recorded (`gestures::front_end`).
    pub motion_on_rad_s: f64,
    /// The smoothed rate must fall below this, rad/s, for the head to be
    /// quiet (0.15: the hysteresis that keeps a gesture's slow middle from
    /// ending it).
    pub motion_off_rad_s: f64,
    /// While the head is tilted further than this from its rest
    /// orientation (rad, from the gravity deviation), it is not at rest:
    /// a held tilt or look keeps its segment open (0.12 ≈ 7°).
    pub hold_tilt_rad: f64,
    /// The head must be quiet and near rest this long, ms, to end a
    /// segment (300: the pause between a slow double nod's two nods is
    /// 200 ms).
    pub rest_ms: u32,
    /// Segments shorter than this, ms, are ignored as twitches (450: the
    /// lead frames and the smoothing's tail add about 300 ms to the
    /// movement, so a 120 ms twitch is cut as 400 ms; a quick nod as 600).
    pub min_ms: u32,
    /// Segments longer than this, ms, end as too long and are rejected;
    /// the next starts only after rest (3360: a slow tilt, 2.9 s with its
    /// hold, fits; at most
    /// `MAX_FRAMES · frame_ms`).
    pub max_ms: u32,
    /// Time constant of the rest estimate (gyro bias, gravity), ms,
    /// tracked only at rest (2000).
    pub rest_tracking_ms: u32,
    /// Half-width of the Sakoe–Chiba band as a fraction of the template's
    /// length (0.07: ±4 frames, ±240 ms, on the longest; at least one
    /// frame). Uniform speed differences are
    /// taken up by the band following the diagonal; the band is for the
    /// uneven ones.
    pub band_fraction: f64,
    /// A match is ambiguous, and rejected, when a different gesture's
    /// best distance is within this fraction of the nearest's (0.1: less
    /// than 10 % further).
    pub ambiguity_margin: f64,
}

impl Default for GestureConfig {
    fn default() -> Self {
        GestureConfig {
            frame_ms: 60,
            motion_on_rad_s: 0.3,
            motion_off_rad_s: 0.15,
            hold_tilt_rad: 0.12,
            rest_ms: 300,
            min_ms: 450,
            max_ms: 3360,
            rest_tracking_ms: 2000,
            band_fraction: 0.07,
            ambiguity_margin: 0.1,
        }
    }
}

impl GestureConfig {
    /// Every bad field, each as `name: why`; empty if valid.
    pub fn validate(&self) -> Result<(), Vec<String>> {
        let mut errors = Vec::new();
        let mut check = |ok: bool, message: String| {
            if !ok {
                errors.push(message);
            }
        };
        check(
            (1..=1000).contains(&self.frame_ms),
            format!("frame_ms: {} is not in 1–1000", self.frame_ms),
        );
        check(
            self.motion_on_rad_s.is_finite() && self.motion_on_rad_s > 0.0,
            format!("motion_on_rad_s: {} is not > 0", self.motion_on_rad_s),
        );
        check(
            self.motion_off_rad_s.is_finite()
                && self.motion_off_rad_s > 0.0
                && self.motion_off_rad_s <= self.motion_on_rad_s,
            format!(
                "motion_off_rad_s: {} is not in 0–motion_on_rad_s",
                self.motion_off_rad_s
            ),
        );
        check(
            self.hold_tilt_rad.is_finite() && self.hold_tilt_rad > 0.0,
            format!("hold_tilt_rad: {} is not > 0", self.hold_tilt_rad),
        );
        check(
            self.rest_ms >= self.frame_ms,
            format!("rest_ms: {} is shorter than a frame", self.rest_ms),
        );
        check(
            self.min_ms >= self.frame_ms,
            format!("min_ms: {} is shorter than a frame", self.min_ms),
        );
        let longest = u64::from(self.frame_ms) * MAX_FRAMES as u64;
        check(
            self.max_ms > self.min_ms && u64::from(self.max_ms) <= longest,
            format!(
                "max_ms: {} is not in min_ms–{longest} (MAX_FRAMES frames)",
                self.max_ms
            ),
        );
        check(
            self.rest_tracking_ms >= self.frame_ms,
            format!(
                "rest_tracking_ms: {} is shorter than a frame",
                self.rest_tracking_ms
            ),
        );
        check(
            self.band_fraction.is_finite() && (0.0..=1.0).contains(&self.band_fraction),
            format!("band_fraction: {} is not in 0–1", self.band_fraction),
        );
        check(
            self.ambiguity_margin.is_finite() && self.ambiguity_margin >= 0.0,
            format!("ambiguity_margin: {} is not ≥ 0", self.ambiguity_margin),
        );
        if errors.is_empty() {
            Ok(())
        } else {
            Err(errors)
        }
    }

    /// The rest estimate's step per frame (exponential average).
    pub(crate) fn rest_alpha(&self) -> f64 {
        f64::from(self.frame_ms) / f64::from(self.rest_tracking_ms.max(1))
    }

    /// The band's half-width, frames, for a template `len` frames long.
    pub fn band_frames(&self, len: usize) -> usize {
        ((self.band_fraction * len as f64).ceil() as usize).max(1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_is_valid_and_bad_fields_are_named() {
        assert_eq!(GestureConfig::default().validate(), Ok(()));
        let bad = GestureConfig {
            motion_off_rad_s: 1.0,
            max_ms: 10_000,
            ..GestureConfig::default()
        };
        let errors = bad.validate().unwrap_err();
        assert_eq!(errors.len(), 2, "{errors:?}");
        assert!(errors[0].starts_with("motion_off_rad_s"));
        assert!(errors[1].starts_with("max_ms"));
    }
}
