//! Configuration: TOML read once, through serde, into validated types.
//!
//! Every problem is collected with its key (and its line in the file) and
//! reported at once, so a clinician fitting the interface fixes a file in
//! one pass. Unknown keys are errors (a misspelt key must never be silently
//! ignored). The key names are a contract: keys are added, never renamed.
//! Nothing here runs on the control thread: it may allocate.
//!
//! * `file`: the file's layout, whose serde field names are the keys;
//! * `read`: TOML → that layout, every problem found, defaults for
//!   missing keys; `names`: values given by name or action code;
//! * [`validate`]: the checks, on typed values;
//! * `defaults`: the built-in configuration;
//! * [`print`](mod@print): the effective configuration back as TOML,
//!   through the same layout;
//! * [`diff`]: what a file changes from the built-in configuration, with
//!   the reasons written in it, compared through that same layout;
//! * [`realtime`]: `[rt]`, the threads' priorities and CPUs;
//! * [`layers`]: a setup from several files (`--config A --config B`),
//!   later over earlier, each setting with the file it came from;
//! * [`invalid`](mod@invalid): the mark of a configuration or an option
//!   found wrong before anything started.

mod defaults;
pub mod diff;
pub mod error;
mod file;
pub mod invalid;
pub mod layers;
pub(crate) mod library;
mod lines;
mod names;
pub mod print;
mod read;
pub mod realtime;
pub mod validate;

use std::path::{Path, PathBuf};

use toml::Table;

use crate::arm::settings::ArmSettings;
use crate::control::core_config::{CoreConfig, InterfaceSection};
use crate::control::detector::DetectorConfig;
use crate::control::head::GestureSetup;
use crate::control::selection::scanning::ScanningConfig;
use crate::control::selection::{Interface, SequenceEntry};
use crate::output::settings::OutputSettings;
use crate::sensor::settings::SensorSettings;
use error::Problems;
pub use error::{ConfigError, ConfigErrors, ConfigFileError};
use file::File;
use realtime::RtSettings;

/// The whole validated configuration. Only [`Config::default`],
/// [`Config::from_toml_str`] (and [`Config::from_file`]) and the `with_*`
/// methods make one, and each validates it, so every `Config` is valid.
#[derive(Debug, Clone, PartialEq)]
pub struct Config {
    core: CoreConfig,
    sensor: SensorSettings,
    arm: ArmSettings,
    output: OutputSettings,
    rt: RtSettings,
}

/// The built-in configuration (see `defaults`).
impl Default for Config {
    fn default() -> Self {
        let (core, sensor, arm, output, rt) = File::default().into_parts();
        Config {
            core,
            sensor,
            arm,
            output,
            rt,
        }
    }
}

impl Config {
    /// Reads and validates a configuration file.
    pub fn from_file(path: &Path) -> Result<Config, ConfigFileError> {
        Config::from_file_with_text(path).map(|(config, _)| config)
    }

    /// Reads and validates a configuration file as [`Config::from_file`]
    /// does (the same errors), keeping its text: its comments are the
    /// reasons [`diff`] shows.
    pub fn from_file_with_text(path: &Path) -> Result<(Config, String), ConfigFileError> {
        let text = std::fs::read_to_string(path).map_err(|error| ConfigFileError::Read {
            path: path.to_path_buf(),
            error,
        })?;
        match Config::from_toml_str(&text) {
            Ok(config) => Ok((config, text)),
            Err(errors) => Err(ConfigFileError::Invalid {
                path: path.to_path_buf(),
                errors,
            }),
        }
    }

    /// Parses and validates TOML text. Missing keys take the built-in
    /// defaults; a `[[sequence]]` list, if present, replaces the built-in
    /// library entirely.
    pub fn from_toml_str(text: &str) -> Result<Config, ConfigErrors> {
        let root: Table = text
            .parse()
            .map_err(|e: toml::de::Error| ConfigErrors(vec![lines::syntax_error(text, &e)]))?;
        let sections: Vec<String> = root.keys().cloned().collect();
        let mut problems = Problems::default();
        let (core, sensor, arm, output, rt) = read::file(root, &mut problems).into_parts();
        validate::config(&mut problems, &core, &sensor, &arm, &output, &rt);
        if problems.errors.is_empty() {
            Ok(Config {
                core,
                sensor,
                arm,
                output,
                rt,
            })
        } else {
            Err(lines::in_file_order(text, &sections, problems.errors))
        }
    }

    /// Validates settings built in code.
    fn into_validated(self) -> Result<Config, ConfigErrors> {
        let mut problems = Problems::default();
        validate::config(
            &mut problems,
            &self.core,
            &self.sensor,
            &self.arm,
            &self.output,
            &self.rt,
        );
        if problems.errors.is_empty() {
            Ok(self)
        } else {
            Err(ConfigErrors(problems.errors))
        }
    }

    /// The same configuration for a person fed by a head-worn IMU alone:
    /// their gestures loaded (checked against the library by
    /// `gestures::setup`), no breath sensor.
    pub fn for_imu(mut self, gestures: GestureSetup) -> Config {
        self.core = self.core.without_breath_sensor().with_gestures(gestures);
        self
    }

    /// The same configuration for a run on a breath sensor with an IMU
    /// beside it: the person's gestures loaded, the breath sensor kept.
    pub fn for_breath_and_imu(mut self, gestures: GestureSetup) -> Config {
        self.core = self.core.with_gestures(gestures);
        self
    }

    /// The core's settings: what the pipeline and the runtime are built
    /// from.
    pub fn core(&self) -> &CoreConfig {
        &self.core
    }

    /// How sensor devices are read (`[sensor]`).
    pub fn sensor(&self) -> &SensorSettings {
        &self.sensor
    }

    /// How arm backends are reached (`[arm]`'s `connect_timeout_ms` and
    /// its `ros2`, `ros1`, `kinova_sdk` tables).
    pub fn arm(&self) -> &ArmSettings {
        &self.arm
    }

    /// How the outputs beyond the arm are reached (`[output]`'s `uinput`
    /// and `mqtt` tables).
    pub fn output(&self) -> &OutputSettings {
        &self.output
    }

    /// The threads' real-time priorities and CPUs (`[rt]`).
    pub fn rt(&self) -> &RtSettings {
        &self.rt
    }

    /// The same configuration with other output settings, validated.
    pub fn with_output(mut self, output: OutputSettings) -> Result<Config, ConfigErrors> {
        self.output = output;
        self.into_validated()
    }

    /// The same configuration with other arm settings, validated.
    pub fn with_arm(mut self, arm: ArmSettings) -> Result<Config, ConfigErrors> {
        self.arm = arm;
        self.into_validated()
    }

    /// The same configuration with the neutral measured at start: the
    /// detector's thresholds keep their distances from it. An error if
    /// that puts a threshold outside 0–5 V (the device's mapping is off).
    pub fn with_neutral_volts(mut self, neutral_volts: f64) -> Result<Config, ConfigErrors> {
        self.core.detector = self.core.detector.with_neutral(neutral_volts);
        self.into_validated()
    }

    /// The same configuration with other detector settings (a fitted
    /// profile's), validated.
    pub fn with_detector(mut self, detector: DetectorConfig) -> Result<Config, ConfigErrors> {
        self.core.detector = detector;
        self.into_validated()
    }

    /// The same configuration with other sensor settings, validated.
    pub fn with_sensor(mut self, sensor: SensorSettings) -> Result<Config, ConfigErrors> {
        self.sensor = sensor;
        self.into_validated()
    }

    /// The same configuration with another selection interface (the
    /// `--interface` option).
    pub fn with_interface(mut self, interface: Interface) -> Result<Config, ConfigErrors> {
        self.core.interface = InterfaceSection { kind: interface };
        self.into_validated()
    }

    /// The same configuration with the person's gesture set at `path`
    /// (the `--gestures` option), checked as the file's would be.
    pub fn with_gesture_set(mut self, path: PathBuf) -> Result<Config, ConfigErrors> {
        self.core.gesture_section.set = Some(path);
        self.into_validated()
    }

    /// The same configuration with other scanning settings (the study's
    /// sweeps), checked as the file's would be.
    pub fn with_scanning(mut self, scanning: ScanningConfig) -> Result<Config, ConfigErrors> {
        self.core.scanning = scanning;
        self.into_validated()
    }

    /// The same configuration with another library, checked as the file's
    /// would be.
    pub fn with_sequences(mut self, sequences: Vec<SequenceEntry>) -> Result<Config, ConfigErrors> {
        self.core.sequences = sequences;
        self.into_validated()
    }

    /// The same configuration with another sequence timeout, ms.
    pub fn with_sequence_timeout_ms(mut self, ms: u32) -> Result<Config, ConfigErrors> {
        self.core.matcher.sequence_timeout_ms = ms;
        self.into_validated()
    }

    /// The same configuration with another inactivity timeout, ms.
    pub fn with_inactivity_timeout_ms(mut self, ms: u32) -> Result<Config, ConfigErrors> {
        self.core.command.inactivity_timeout_ms = ms;
        self.into_validated()
    }

    /// This config with another `command.motion_onset_ms` (0 = off),
    /// validated.
    pub fn with_motion_onset_ms(mut self, ms: u32) -> Result<Config, ConfigErrors> {
        self.core.command.motion_onset_ms = ms;
        self.into_validated()
    }
}

#[cfg(test)]
mod key_tests;
#[cfg(test)]
mod tests;
