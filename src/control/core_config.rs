//! Everything the core needs to run, validated: the settings of each stage
//! and the user's library.
//!
//! Only `crate::config` builds one (from TOML or the built-in defaults,
//! after checking every value), so a [`CoreConfig`] in hand is valid: the
//! limits are within the JACO2's caps, the thresholds on the right sides of
//! the neutral, the library non-empty and free of duplicates.

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::control::detector::DetectorConfig;
use crate::control::head::{GestureSetup, HeadConfig};
use crate::control::modes::CommandConfig;
use crate::control::motion::feedback::FeedbackConfig;
use crate::control::motion::home::HomeConfig;
use crate::control::motion::limits::MotionConfig;
use crate::control::motion::workspace::WorkspaceConfig;
use crate::control::pointer::PointerConfig;
use crate::control::selection::matcher::MatcherConfig;
use crate::control::selection::scanning::ScanningConfig;
use crate::control::selection::{Interface, SequenceEntry};

/// The validated settings of the whole core (`config::file` lays them out
/// as the file's sections).
#[derive(Debug, Clone, PartialEq)]
pub struct CoreConfig {
    pub(crate) detector: DetectorConfig,
    pub(crate) matcher: MatcherConfig,
    pub(crate) command: CommandConfig,
    pub(crate) motion: MotionConfig,
    pub(crate) workspace: WorkspaceConfig,
    pub(crate) home: HomeConfig,
    /// `[arm.feedback]`.
    pub(crate) feedback: FeedbackConfig,
    pub(crate) interface: InterfaceSection,
    pub(crate) scanning: ScanningConfig,
    pub(crate) sequences: Vec<SequenceEntry>,
    /// The pointer's speeds (`[output.uinput]`).
    pub(crate) pointer: PointerConfig,
    /// `[gestures]`: the gesture set's file and the head's settings.
    pub(crate) gesture_section: GesturesSection,
    /// The person's gestures, once their set is loaded.
    pub(crate) gestures: Option<GestureSetup>,
    /// A breath sensor feeds the core (without one, the detector is not
    /// run and its silence is no fault).
    pub(crate) breath: bool,
}

/// The `[gestures]` section: the person's gesture set (written by
/// `sipnpuff gestures record`) and the head's settings.
#[derive(Debug, Clone, PartialEq, Default, Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub(crate) struct GesturesSection {
    /// The gesture set's file, if the person uses gestures.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) set: Option<PathBuf>,
    #[serde(flatten)]
    pub(crate) head: HeadConfig,
}

/// The `[interface]` section.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub(crate) struct InterfaceSection {
    pub(crate) kind: Interface,
}

impl CoreConfig {
    /// Burst detector settings.
    pub fn detector(&self) -> &DetectorConfig {
        &self.detector
    }

    /// Sequence matcher settings.
    pub fn matcher(&self) -> &MatcherConfig {
        &self.matcher
    }

    /// Command mode settings.
    pub fn command(&self) -> &CommandConfig {
        &self.command
    }

    /// Motion limits.
    pub fn motion(&self) -> &MotionConfig {
        &self.motion
    }

    /// Workspace limits.
    pub fn workspace(&self) -> &WorkspaceConfig {
        &self.workspace
    }

    /// The arm at power-up (the `[arm]` section).
    pub fn home(&self) -> &HomeConfig {
        &self.home
    }

    /// How a measured arm pose is checked (`[arm.feedback]`).
    pub fn feedback(&self) -> &FeedbackConfig {
        &self.feedback
    }

    /// The user-defined sequences, in file order.
    pub fn sequences(&self) -> &[SequenceEntry] {
        &self.sequences
    }

    /// The pointer's speeds.
    pub fn pointer(&self) -> &PointerConfig {
        &self.pointer
    }

    /// The person's gestures, once loaded ([`CoreConfig::with_gestures`]).
    pub fn gestures(&self) -> Option<&GestureSetup> {
        self.gestures.as_ref()
    }

    /// The gesture set's file (`[gestures] set`), if any.
    pub fn gesture_set_file(&self) -> Option<&Path> {
        self.gesture_section.set.as_deref()
    }

    /// The head's settings (`[gestures]`).
    pub fn head(&self) -> &HeadConfig {
        &self.gesture_section.head
    }

    /// The same settings with the person's gestures loaded (the caller
    /// checks the library's gestures are in the set).
    pub fn with_gestures(mut self, setup: GestureSetup) -> CoreConfig {
        self.gestures = Some(setup);
        self
    }

    /// Whether a breath sensor feeds the core.
    pub fn has_breath_sensor(&self) -> bool {
        self.breath
    }

    /// The same settings for a run whose only sensor is the IMU.
    pub fn without_breath_sensor(mut self) -> CoreConfig {
        self.breath = false;
        self
    }

    /// How the user selects a mode.
    pub fn interface(&self) -> Interface {
        self.interface.kind
    }

    /// The scanning interface's settings (used when the interface is BSP).
    pub fn scanning(&self) -> &ScanningConfig {
        &self.scanning
    }
}
