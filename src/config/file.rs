//! The configuration file's layout: each section and key is a serde field
//! of these types or of the settings they hold, so reading
//! ([`super::read`]) and printing ([`super::print`]) share one name for
//! every key.

use serde::{Deserialize, Serialize};

use crate::arm::settings::ArmSettings;
use crate::config::defaults;
use crate::config::library::LibraryEntry;
use crate::config::realtime::RtSettings;
use crate::control::core_config::{CoreConfig, GesturesSection, InterfaceSection};
use crate::control::detector::DetectorConfig;
use crate::control::modes::CommandConfig;
use crate::control::motion::feedback::FeedbackConfig;
use crate::control::motion::home::HomeConfig;
use crate::control::motion::limits::MotionConfig;
use crate::control::motion::workspace::WorkspaceConfig;
use crate::control::pointer::PointerConfig;
use crate::control::selection::matcher::MatcherConfig;
use crate::control::selection::scanning::ScanningConfig;
use crate::output::settings::{MqttSettings, OutputSettings, UinputSettings};
use crate::sensor::settings::SensorSettings;

/// The whole file, section by section, in the order `sipnpuff config`
/// prints them. A missing section or key takes the built-in value.
#[derive(Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub(super) struct File {
    detector: DetectorConfig,
    matcher: MatcherConfig,
    command: CommandConfig,
    motion: MotionConfig,
    workspace: WorkspaceConfig,
    arm: ArmSection,
    interface: InterfaceSection,
    scanning: ScanningConfig,
    /// `[[sequence]]`: the library, replacing the built-in one whole.
    #[serde(rename = "sequence")]
    sequences: Vec<LibraryEntry>,
    sensor: SensorSettings,
    gestures: GesturesSection,
    output: OutputSection,
    rt: RtSettings,
}

/// `[output]`: the uinput device (its name and the pointer's speeds) and
/// the MQTT broker.
#[derive(Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct OutputSection {
    uinput: UinputSection,
    mqtt: MqttSettings,
}

/// `[output.uinput]`: the device's settings and the pointer's speeds, in
/// one table.
#[derive(Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct UinputSection {
    #[serde(flatten)]
    device: UinputSettings,
    #[serde(flatten)]
    pointer: PointerConfig,
}

/// `[arm]`: the arm at power-up, the checks on a measured pose (its
/// `feedback` table) and the backends' settings, in one table.
#[derive(Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
struct ArmSection {
    #[serde(flatten)]
    home: HomeConfig,
    feedback: FeedbackConfig,
    #[serde(flatten)]
    backends: ArmSettings,
}

impl Default for File {
    fn default() -> Self {
        File::new(
            defaults::core(),
            SensorSettings::default(),
            ArmSettings::default(),
            OutputSettings::default(),
            RtSettings::default(),
        )
    }
}

impl File {
    /// The file that holds these settings.
    pub(super) fn new(
        core: CoreConfig,
        sensor: SensorSettings,
        arm: ArmSettings,
        output: OutputSettings,
        rt: RtSettings,
    ) -> File {
        File {
            detector: core.detector,
            matcher: core.matcher,
            command: core.command,
            motion: core.motion,
            workspace: core.workspace,
            arm: ArmSection {
                home: core.home,
                feedback: core.feedback,
                backends: arm,
            },
            interface: core.interface,
            scanning: core.scanning,
            sequences: core.sequences.into_iter().map(LibraryEntry).collect(),
            sensor,
            gestures: core.gesture_section,
            output: OutputSection {
                uinput: UinputSection {
                    device: output.uinput,
                    pointer: core.pointer,
                },
                mqtt: output.mqtt,
            },
            rt,
        }
    }

    /// The settings the file holds, not yet validated.
    pub(super) fn into_parts(
        self,
    ) -> (
        CoreConfig,
        SensorSettings,
        ArmSettings,
        OutputSettings,
        RtSettings,
    ) {
        let core = CoreConfig {
            detector: self.detector,
            matcher: self.matcher,
            command: self.command,
            motion: self.motion,
            workspace: self.workspace,
            home: self.arm.home,
            feedback: self.arm.feedback,
            interface: self.interface,
            scanning: self.scanning,
            sequences: self.sequences.into_iter().map(|e| e.0).collect(),
            pointer: self.output.uinput.pointer,
            gesture_section: self.gestures,
            gestures: None,
            breath: true,
        };
        let output = OutputSettings {
            uinput: self.output.uinput.device,
            mqtt: self.output.mqtt,
        };
        (core, self.sensor, self.arm.backends, output, self.rt)
    }

    /// The built-in configuration as a TOML tree: what a file's key is
    /// checked against (is it known, what replaces a wrong value). Keys
    /// unset by default are there with a value of their kind.
    pub(super) fn sample() -> toml::Value {
        let mut file = File::default();
        file.output.mqtt.credentials_file = Some(std::path::PathBuf::from("credentials.toml"));
        file.gestures.set = Some(std::path::PathBuf::from("gestures.toml"));
        file.rt.control_cpu = Some(1);
        let mut sample =
            toml::Value::try_from(file).unwrap_or_else(|_| toml::Value::Table(toml::Table::new()));
        if let Some(toml::Value::Table(detector)) = sample.get_mut("detector") {
            let shared = detector.get("hysteresis_volts").cloned();
            if let Some(value) = shared {
                detector.insert("sip_hysteresis_volts".into(), value);
            }
        }
        sample
    }
}
