//! Configuration: TOML read once, key by key, into validated types.
//!
//! Every problem is collected with the key it belongs to and reported at
//! once, so a clinician fitting the interface fixes a file in one pass.
//! Unknown keys are errors (a misspelt key must never be silently ignored).
//! Nothing here runs on the control thread: it may allocate.

use std::collections::HashSet;
use std::fmt;
use std::path::Path;

use serde::de::DeserializeOwned;
use toml::{Table, Value};

use crate::action::{Action, ActionSeq, MAX_SEQUENCE_LEN};
use crate::modes::Mode;

/// Largest library the matcher accepts.
pub const MAX_SEQUENCES: usize = 256;

/// Upper bound for every timer, to catch unit mistakes (seconds typed as
/// milliseconds ×1000) and keep tick arithmetic far from overflow.
pub const MAX_TIMER_MS: u32 = 600_000;

/// Burst detector settings (`[detector]`), validated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectorConfig {
    /// Sensor output at rest, in volts. The detector starts from it and then
    /// tracks slow drift.
    pub neutral_volts: f64,
    /// A puff starts above this voltage (relative to the tracked neutral, it
    /// moves with the neutral by the same offset).
    pub puff_threshold_volts: f64,
    /// A sip starts below this voltage (moves with the neutral likewise).
    pub sip_threshold_volts: f64,
    /// A burst ends when the signal is back past its threshold by this much.
    pub hysteresis_volts: f64,
    /// Bursts shorter than this are ignored.
    pub min_burst_ms: u32,
    /// Bursts at least this long are long; shorter ones are short.
    pub long_burst_ms: u32,
    /// Longest glitch (spike, dropout) ignored: a change of state must last
    /// longer than this to count.
    pub glitch_ms: u32,
    /// Time constant of the neutral tracker (exponential average of the
    /// resting signal, updated only while no breath is in progress).
    pub neutral_tracking_ms: u32,
    /// Samples further than this outside 0–5 V are sensor faults.
    pub fault_margin_volts: f64,
    /// After a fault, the signal must be valid and at rest this long before
    /// detection resumes.
    pub fault_recovery_ms: u32,
    /// No sample for this long is a sensor fault (stale sensor).
    pub stale_ms: u32,
}

impl Default for DetectorConfig {
    fn default() -> Self {
        DetectorConfig {
            neutral_volts: 2.5,
            puff_threshold_volts: 3.0,
            sip_threshold_volts: 2.0,
            hysteresis_volts: 0.1,
            min_burst_ms: 40,
            long_burst_ms: 500,
            glitch_ms: 5,
            neutral_tracking_ms: 1000,
            fault_margin_volts: 0.5,
            fault_recovery_ms: 250,
            stale_ms: 50,
        }
    }
}

/// Sequence matcher settings (`[matcher]`), validated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MatcherConfig {
    /// How long the matcher waits for the next burst of a sequence that is a
    /// prefix of a longer one, counted from the end of the last burst.
    pub sequence_timeout_ms: u32,
}

impl Default for MatcherConfig {
    fn default() -> Self {
        MatcherConfig {
            sequence_timeout_ms: 1000,
        }
    }
}

/// Command mode settings (`[command]`), validated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CommandConfig {
    /// No breath for this long (from the match or the end of the last breath)
    /// returns to detection mode.
    pub inactivity_timeout_ms: u32,
}

impl Default for CommandConfig {
    fn default() -> Self {
        CommandConfig {
            inactivity_timeout_ms: 2000,
        }
    }
}

/// How the user selects a mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Interface {
    /// Advanced sip-and-puff: sequences matched against the library (the
    /// paper's interface).
    #[default]
    Asp,
    /// Basic sip-and-puff: the modes scroll on their own and a puff enters
    /// the highlighted one (Kinova's classic interface, the paper's
    /// baseline).
    Bsp,
}

impl Interface {
    /// `asp` or `bsp`.
    pub const fn name(self) -> &'static str {
        match self {
            Interface::Asp => "asp",
            Interface::Bsp => "bsp",
        }
    }

    /// Parses `asp` or `bsp`.
    pub fn from_name(name: &str) -> Option<Interface> {
        match name {
            "asp" => Some(Interface::Asp),
            "bsp" => Some(Interface::Bsp),
            _ => None,
        }
    }
}

/// The scanning interface (`[scanning]`), validated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ScanningConfig {
    /// How long each mode stays highlighted.
    pub dwell_ms: u32,
    /// How long the first mode stays highlighted when scanning (re)starts:
    /// time to see where the scan is.
    pub first_dwell_ms: u32,
    /// The modes in scan order (each once), as a fixed array and its length.
    pub order: [Mode; 9],
    /// Modes used in `order`.
    pub order_len: usize,
}

impl ScanningConfig {
    /// The modes in scan order.
    pub fn modes(&self) -> &[Mode] {
        &self.order[..self.order_len]
    }
}

impl Default for ScanningConfig {
    fn default() -> Self {
        ScanningConfig {
            dwell_ms: 1500,
            first_dwell_ms: 3000,
            order: Mode::ALL,
            order_len: Mode::ALL.len(),
        }
    }
}

/// Hard caps no configuration may exceed: the Kinova JACO2's client limits
/// (ISO 10218's reduced speed, 0.25 m/s, is above them).
pub mod caps {
    /// Linear speed, m/s.
    pub const LINEAR_SPEED_MPS: f64 = 0.20;
    /// Slowest linear speed the JACO2 executes (its dead band is ~0.03 m/s).
    pub const MIN_LINEAR_SPEED_MPS: f64 = 0.04;
    /// Angular speed, rad/s.
    pub const ANGULAR_SPEED_RADPS: f64 = 1.07;
    /// Slowest angular speed the JACO2 executes (dead band).
    pub const MIN_ANGULAR_SPEED_RADPS: f64 = 0.2;
    /// Linear acceleration, m/s².
    pub const LINEAR_ACCELERATION_MPS2: f64 = 0.64;
    /// Angular acceleration, rad/s².
    pub const ANGULAR_ACCELERATION_RADPS2: f64 = 2.75;
    /// Linear jerk, m/s³ (our choice: full acceleration in 64 ms at most).
    pub const LINEAR_JERK_MPS3: f64 = 10.0;
    /// Angular jerk, rad/s³ (our choice: full acceleration in 55 ms at most).
    pub const ANGULAR_JERK_RADPS3: f64 = 50.0;
    /// Finger speed, JACO2 finger units/s (0 = open … 6800 = closed).
    pub const FINGER_SPEED: f64 = 6800.0;
    /// Finger acceleration, units/s².
    pub const FINGER_ACCELERATION: f64 = 100_000.0;
    /// Finger jerk, units/s³.
    pub const FINGER_JERK: f64 = 2_000_000.0;
    /// Reach of the arm, m.
    pub const REACH_M: f64 = 0.9;
}

/// Motion settings (`[motion]`), validated against [`caps`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionConfig {
    /// Speed of a translation mode, m/s.
    pub linear_speed_mps: f64,
    /// Speed of a rotation mode, rad/s.
    pub angular_speed_radps: f64,
    /// Per-axis linear acceleration limit, m/s².
    pub linear_acceleration_mps2: f64,
    /// Per-axis angular acceleration limit, rad/s².
    pub angular_acceleration_radps2: f64,
    /// Per-axis linear jerk limit, m/s³.
    pub linear_jerk_mps3: f64,
    /// Per-axis angular jerk limit, rad/s³.
    pub angular_jerk_radps3: f64,
    /// Finger speed, units/s.
    pub finger_speed: f64,
    /// Finger acceleration limit, units/s².
    pub finger_acceleration: f64,
    /// Finger jerk limit, units/s³.
    pub finger_jerk: f64,
    /// Scale speed with how hard the user sips or puffs.
    pub proportional_speed: bool,
    /// Pressure past the threshold that gives full speed, volts.
    pub proportional_full_scale_volts: f64,
    /// Fraction of full speed at the threshold itself.
    pub proportional_min_fraction: f64,
}

impl Default for MotionConfig {
    fn default() -> Self {
        MotionConfig {
            linear_speed_mps: caps::LINEAR_SPEED_MPS,
            angular_speed_radps: caps::ANGULAR_SPEED_RADPS,
            linear_acceleration_mps2: caps::LINEAR_ACCELERATION_MPS2,
            angular_acceleration_radps2: caps::ANGULAR_ACCELERATION_RADPS2,
            linear_jerk_mps3: 3.2,
            angular_jerk_radps3: 14.0,
            finger_speed: 3000.0,
            finger_acceleration: 20_000.0,
            finger_jerk: 200_000.0,
            proportional_speed: false,
            proportional_full_scale_volts: 1.0,
            proportional_min_fraction: 0.25,
        }
    }
}

/// Where the tool may go (`[workspace]`), in the base frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorkspaceConfig {
    /// Largest distance from the base, m.
    pub reach_m: f64,
    /// Smallest distance from the base, m.
    pub min_radius_m: f64,
    /// Height of the table plane, m (the tool stays above it).
    pub table_z_m: f64,
    /// The tool stops at least this far from any boundary, m.
    pub stop_margin_m: f64,
    /// Finger position when closed, units (open is 0).
    pub finger_closed: f64,
}

impl Default for WorkspaceConfig {
    fn default() -> Self {
        WorkspaceConfig {
            reach_m: caps::REACH_M,
            min_radius_m: 0.2,
            table_z_m: 0.0,
            stop_margin_m: 0.005,
            finger_closed: 6800.0,
        }
    }
}

/// The arm at power-up (`[arm]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmConfig {
    /// Tool position at power-up, m, base frame.
    pub home_position_m: [f64; 3],
    /// Tool orientation at power-up, as a rotation vector, rad.
    pub home_rotation_vector_rad: [f64; 3],
    /// Finger position at power-up, units.
    pub home_fingers: f64,
}

impl Default for ArmConfig {
    fn default() -> Self {
        ArmConfig {
            home_position_m: [0.21, -0.26, 0.48],
            home_rotation_vector_rad: [0.0, 0.0, 0.0],
            home_fingers: 0.0,
        }
    }
}

/// One user-defined sequence and the mode it selects.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SequenceEntry {
    /// The actions, non-empty, at most [`MAX_SEQUENCE_LEN`].
    pub actions: ActionSeq,
    /// The arm mode it selects.
    pub mode: Mode,
}

/// The built-in library: prefix-free (no selection ever waits for the
/// timeout), two bursts each so a single cough or sigh never changes mode.
/// Two short bursts select the most used modes (translations, fingers); a
/// long puff first selects a rotation; a long sip first a saved point.
pub const DEFAULT_SEQUENCES: [(&[Action], Mode); 9] = {
    use Action::{LongPuff, LongSip, ShortPuff, ShortSip};
    [
        (&[ShortPuff, ShortPuff], Mode::TranslateX),
        (&[ShortPuff, ShortSip], Mode::TranslateY),
        (&[ShortSip, ShortSip], Mode::TranslateZ),
        (&[ShortSip, ShortPuff], Mode::Fingers),
        (&[LongPuff, ShortPuff], Mode::RotateX),
        (&[LongPuff, ShortSip], Mode::RotateY),
        (&[LongPuff, LongPuff], Mode::RotateZ),
        (&[LongSip, ShortPuff], Mode::SavePoint),
        (&[LongSip, ShortSip], Mode::GotoPoint),
    ]
};

/// The whole validated configuration. Only [`Config::default`] and
/// [`Config::from_toml_str`] make one, so every `Config` is valid.
#[derive(Debug, Clone, PartialEq)]
pub struct Config {
    detector: DetectorConfig,
    matcher: MatcherConfig,
    command: CommandConfig,
    motion: MotionConfig,
    workspace: WorkspaceConfig,
    arm: ArmConfig,
    sequences: Vec<SequenceEntry>,
    interface: Interface,
    scanning: ScanningConfig,
}

impl Default for Config {
    fn default() -> Self {
        let sequences = DEFAULT_SEQUENCES
            .iter()
            .map(|&(actions, mode)| SequenceEntry {
                actions: ActionSeq::from_slice(actions).expect("default sequences are short"),
                mode,
            })
            .collect();
        Config {
            detector: DetectorConfig::default(),
            matcher: MatcherConfig::default(),
            command: CommandConfig::default(),
            motion: MotionConfig::default(),
            workspace: WorkspaceConfig::default(),
            arm: ArmConfig::default(),
            sequences,
            interface: Interface::default(),
            scanning: ScanningConfig::default(),
        }
    }
}

/// One problem in a configuration: the key and what is wrong with it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConfigError {
    /// Dotted key, e.g. `detector.min_burst_ms` or `sequence #3.mode`
    /// (sequences counted from 1 in file order).
    pub key: String,
    /// What is wrong, in plain words.
    pub message: String,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.key, self.message)
    }
}

/// All the problems found in a configuration, in file order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConfigErrors(pub Vec<ConfigError>);

impl fmt::Display for ConfigErrors {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let count = self.0.len();
        writeln!(
            f,
            "{count} problem{} in the configuration:",
            if count == 1 { "" } else { "s" }
        )?;
        for error in &self.0 {
            writeln!(f, "  - {error}")?;
        }
        Ok(())
    }
}

impl std::error::Error for ConfigErrors {}

impl Config {
    /// Reads and validates a configuration file.
    pub fn from_file(path: &Path) -> anyhow::Result<Config> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| anyhow::anyhow!("cannot read config {}: {e}", path.display()))?;
        Config::from_toml_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
    }

    /// Parses and validates TOML text. Missing keys take the built-in
    /// defaults; a `[[sequence]]` list, if present, replaces the built-in
    /// library entirely.
    pub fn from_toml_str(text: &str) -> Result<Config, ConfigErrors> {
        let mut root: Table = text.parse().map_err(|e: toml::de::Error| {
            ConfigErrors(vec![ConfigError {
                key: "(file)".into(),
                message: format!("not valid TOML: {}", e.message().trim()),
            }])
        })?;
        let mut reader = Reader::default();
        let defaults = Config::default();

        let detector = reader.detector(&mut root, defaults.detector);
        let matcher = reader.matcher(&mut root, defaults.matcher);
        let command = reader.command(&mut root, defaults.command);
        let motion = reader.motion(&mut root, defaults.motion);
        let workspace = reader.workspace(&mut root, defaults.workspace);
        let arm = reader.arm(&mut root, defaults.arm, &workspace);
        let sequences = reader.sequences(&mut root).unwrap_or(defaults.sequences);
        let interface = reader.interface(&mut root);
        let scanning = reader.scanning(&mut root, defaults.scanning);
        for key in root.keys() {
            reader.error(
                key.clone(),
                "unknown section or key (known: detector, matcher, command, motion, workspace, arm, sequence, interface, scanning)",
            );
        }

        if reader.errors.is_empty() {
            Ok(Config {
                detector,
                matcher,
                command,
                motion,
                workspace,
                arm,
                sequences,
                interface,
                scanning,
            })
        } else {
            Err(ConfigErrors(reader.errors))
        }
    }

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

    /// Motion settings.
    pub fn motion(&self) -> &MotionConfig {
        &self.motion
    }

    /// Workspace limits.
    pub fn workspace(&self) -> &WorkspaceConfig {
        &self.workspace
    }

    /// The arm at power-up.
    pub fn arm(&self) -> &ArmConfig {
        &self.arm
    }

    /// The user-defined sequences, in file order.
    pub fn sequences(&self) -> &[SequenceEntry] {
        &self.sequences
    }

    /// How the user selects a mode.
    pub fn interface(&self) -> Interface {
        self.interface
    }

    /// The scanning interface's settings (used when the interface is BSP).
    pub fn scanning(&self) -> &ScanningConfig {
        &self.scanning
    }

    /// The same configuration with another selection interface (the
    /// `--interface` option).
    pub fn with_interface(mut self, interface: Interface) -> Config {
        self.interface = interface;
        self
    }

    /// The same configuration with other scanning settings (the study's
    /// sweeps); they must be valid (`dwell_ms` > 0, at least one mode).
    pub fn with_scanning(mut self, scanning: ScanningConfig) -> Config {
        self.scanning = scanning;
        self
    }

    /// The same configuration with another library; it must be valid (as
    /// a validated config's is).
    pub fn with_sequences(mut self, sequences: Vec<SequenceEntry>) -> Config {
        self.sequences = sequences;
        self
    }

    /// The same configuration with another sequence timeout, ms (> 0).
    pub fn with_sequence_timeout_ms(mut self, ms: u32) -> Config {
        self.matcher.sequence_timeout_ms = ms;
        self
    }
}

/// Walks the TOML table, taking known keys out and collecting errors.
#[derive(Default)]
struct Reader {
    errors: Vec<ConfigError>,
}

impl Reader {
    fn error(&mut self, key: impl Into<String>, message: impl Into<String>) {
        self.errors.push(ConfigError {
            key: key.into(),
            message: message.into(),
        });
    }

    /// Opens a section of `root`; an absent section is empty.
    fn section<'r>(&'r mut self, root: &mut Table, name: &'static str) -> Section<'r> {
        let table = match root.remove(name) {
            None => Table::new(),
            Some(Value::Table(table)) => table,
            Some(other) => {
                self.error(name, format!("must be a table, found {}", other.type_str()));
                Table::new()
            }
        };
        Section {
            reader: self,
            table,
            path: name.to_string(),
            known: Vec::new(),
        }
    }

    /// Checks `low < value ≤ high` (or `low ≤ value` when `low_inclusive`).
    fn range(
        &mut self,
        key: &str,
        value: f64,
        low: f64,
        low_inclusive: bool,
        high: f64,
        unit: &str,
    ) {
        let above_low = if low_inclusive {
            value >= low
        } else {
            value > low
        };
        if !(above_low && value <= high) {
            let bound = if low_inclusive { "at least" } else { "above" };
            self.error(
                key,
                format!("{value} {unit} must be {bound} {low} {unit} and at most {high} {unit}"),
            );
        }
    }

    fn positive_ms(&mut self, key: &str, value: u32) {
        if value == 0 {
            self.error(key, "must be greater than 0 ms");
        } else if value > MAX_TIMER_MS {
            self.error(
                key,
                format!("{value} ms is more than the {MAX_TIMER_MS} ms allowed"),
            );
        }
    }

    fn detector(&mut self, root: &mut Table, d: DetectorConfig) -> DetectorConfig {
        let mut t = self.section(root, "detector");
        let c = DetectorConfig {
            neutral_volts: t.get("neutral_volts", d.neutral_volts),
            puff_threshold_volts: t.get("puff_threshold_volts", d.puff_threshold_volts),
            sip_threshold_volts: t.get("sip_threshold_volts", d.sip_threshold_volts),
            hysteresis_volts: t.get("hysteresis_volts", d.hysteresis_volts),
            min_burst_ms: t.get("min_burst_ms", d.min_burst_ms),
            long_burst_ms: t.get("long_burst_ms", d.long_burst_ms),
            glitch_ms: t.get("glitch_ms", d.glitch_ms),
            neutral_tracking_ms: t.get("neutral_tracking_ms", d.neutral_tracking_ms),
            fault_margin_volts: t.get("fault_margin_volts", d.fault_margin_volts),
            fault_recovery_ms: t.get("fault_recovery_ms", d.fault_recovery_ms),
            stale_ms: t.get("stale_ms", d.stale_ms),
        };
        t.finish();
        self.validate_detector(&c);
        c
    }

    fn validate_detector(&mut self, c: &DetectorConfig) {
        for (key, v) in [
            ("detector.neutral_volts", c.neutral_volts),
            ("detector.puff_threshold_volts", c.puff_threshold_volts),
            ("detector.sip_threshold_volts", c.sip_threshold_volts),
        ] {
            if !(0.0..=5.0).contains(&v) {
                self.error(key, format!("{v} V is outside the sensor's 0–5 V range"));
            }
        }
        if c.puff_threshold_volts <= c.neutral_volts {
            self.error(
                "detector.puff_threshold_volts",
                format!(
                    "{} V must be above detector.neutral_volts ({} V): a puff raises the voltage",
                    c.puff_threshold_volts, c.neutral_volts
                ),
            );
        }
        if c.sip_threshold_volts >= c.neutral_volts {
            self.error(
                "detector.sip_threshold_volts",
                format!(
                    "{} V must be below detector.neutral_volts ({} V): a sip lowers the voltage",
                    c.sip_threshold_volts, c.neutral_volts
                ),
            );
        }
        let nearest =
            (c.puff_threshold_volts - c.neutral_volts).min(c.neutral_volts - c.sip_threshold_volts);
        if c.hysteresis_volts.is_nan() || c.hysteresis_volts < 0.0 {
            self.error("detector.hysteresis_volts", "must be 0 V or more");
        } else if nearest > 0.0 && c.hysteresis_volts >= nearest {
            self.error(
                "detector.hysteresis_volts",
                format!(
                    "{} V must be smaller than the distance from the neutral to the nearest threshold ({nearest:.3} V)",
                    c.hysteresis_volts
                ),
            );
        }
        if !(c.fault_margin_volts > 0.0 && c.fault_margin_volts <= 5.0) {
            self.error(
                "detector.fault_margin_volts",
                format!(
                    "{} V must be above 0 V and at most 5 V",
                    c.fault_margin_volts
                ),
            );
        }
        self.positive_ms("detector.min_burst_ms", c.min_burst_ms);
        self.positive_ms("detector.long_burst_ms", c.long_burst_ms);
        self.positive_ms("detector.neutral_tracking_ms", c.neutral_tracking_ms);
        self.positive_ms("detector.fault_recovery_ms", c.fault_recovery_ms);
        self.positive_ms("detector.stale_ms", c.stale_ms);
        if c.long_burst_ms <= c.min_burst_ms {
            self.error(
                "detector.long_burst_ms",
                format!(
                    "{} ms must be greater than detector.min_burst_ms ({} ms)",
                    c.long_burst_ms, c.min_burst_ms
                ),
            );
        }
        if c.glitch_ms >= c.min_burst_ms {
            self.error(
                "detector.glitch_ms",
                format!(
                    "{} ms must be smaller than detector.min_burst_ms ({} ms): a glitch is shorter than any burst",
                    c.glitch_ms, c.min_burst_ms
                ),
            );
        }
    }

    fn matcher(&mut self, root: &mut Table, d: MatcherConfig) -> MatcherConfig {
        let mut t = self.section(root, "matcher");
        let c = MatcherConfig {
            sequence_timeout_ms: t.get("sequence_timeout_ms", d.sequence_timeout_ms),
        };
        t.finish();
        self.positive_ms("matcher.sequence_timeout_ms", c.sequence_timeout_ms);
        c
    }

    fn command(&mut self, root: &mut Table, d: CommandConfig) -> CommandConfig {
        let mut t = self.section(root, "command");
        let c = CommandConfig {
            inactivity_timeout_ms: t.get("inactivity_timeout_ms", d.inactivity_timeout_ms),
        };
        t.finish();
        self.positive_ms("command.inactivity_timeout_ms", c.inactivity_timeout_ms);
        c
    }

    fn interface(&mut self, root: &mut Table) -> Interface {
        let mut t = self.section(root, "interface");
        let kind: String = t.get("kind", Interface::default().name().to_string());
        t.finish();
        Interface::from_name(&kind).unwrap_or_else(|| {
            self.error("interface.kind", format!("{kind:?} is not `asp` or `bsp`"));
            Interface::default()
        })
    }

    fn scanning(&mut self, root: &mut Table, d: ScanningConfig) -> ScanningConfig {
        let mut t = self.section(root, "scanning");
        let dwell_ms = t.get("dwell_ms", d.dwell_ms);
        let first_dwell_ms = t.get("first_dwell_ms", d.first_dwell_ms);
        let names: Vec<String> = t.get(
            "order",
            d.modes().iter().map(|m| m.name().to_string()).collect(),
        );
        t.finish();
        self.positive_ms("scanning.dwell_ms", dwell_ms);
        self.positive_ms("scanning.first_dwell_ms", first_dwell_ms);
        let mut c = ScanningConfig {
            dwell_ms,
            first_dwell_ms,
            order: d.order,
            order_len: 0,
        };
        for name in &names {
            match Mode::from_name(name) {
                None => self.error(
                    "scanning.order",
                    format!(
                        "{name:?} is not a mode (known: {})",
                        Mode::ALL.map(Mode::name).join(", ")
                    ),
                ),
                Some(mode) if c.modes().contains(&mode) => {
                    self.error("scanning.order", format!("{name:?} appears twice"))
                }
                Some(mode) => {
                    c.order[c.order_len] = mode;
                    c.order_len += 1;
                }
            }
        }
        if names.is_empty() {
            self.error("scanning.order", "must list at least one mode");
        }
        if c.order_len == 0 {
            c = d;
        }
        c
    }

    fn motion(&mut self, root: &mut Table, d: MotionConfig) -> MotionConfig {
        let mut t = self.section(root, "motion");
        let c = MotionConfig {
            linear_speed_mps: t.get("linear_speed_mps", d.linear_speed_mps),
            angular_speed_radps: t.get("angular_speed_radps", d.angular_speed_radps),
            linear_acceleration_mps2: t.get("linear_acceleration_mps2", d.linear_acceleration_mps2),
            angular_acceleration_radps2: t
                .get("angular_acceleration_radps2", d.angular_acceleration_radps2),
            linear_jerk_mps3: t.get("linear_jerk_mps3", d.linear_jerk_mps3),
            angular_jerk_radps3: t.get("angular_jerk_radps3", d.angular_jerk_radps3),
            finger_speed: t.get("finger_speed", d.finger_speed),
            finger_acceleration: t.get("finger_acceleration", d.finger_acceleration),
            finger_jerk: t.get("finger_jerk", d.finger_jerk),
            proportional_speed: t.get("proportional_speed", d.proportional_speed),
            proportional_full_scale_volts: t.get(
                "proportional_full_scale_volts",
                d.proportional_full_scale_volts,
            ),
            proportional_min_fraction: t
                .get("proportional_min_fraction", d.proportional_min_fraction),
        };
        t.finish();
        let speed_note = "m/s (the JACO2 executes 0.04–0.20 m/s)";
        self.range(
            "motion.linear_speed_mps",
            c.linear_speed_mps,
            caps::MIN_LINEAR_SPEED_MPS,
            true,
            caps::LINEAR_SPEED_MPS,
            speed_note,
        );
        self.range(
            "motion.angular_speed_radps",
            c.angular_speed_radps,
            caps::MIN_ANGULAR_SPEED_RADPS,
            true,
            caps::ANGULAR_SPEED_RADPS,
            "rad/s",
        );
        for (key, value, cap, unit) in [
            (
                "motion.linear_acceleration_mps2",
                c.linear_acceleration_mps2,
                caps::LINEAR_ACCELERATION_MPS2,
                "m/s²",
            ),
            (
                "motion.angular_acceleration_radps2",
                c.angular_acceleration_radps2,
                caps::ANGULAR_ACCELERATION_RADPS2,
                "rad/s²",
            ),
            (
                "motion.linear_jerk_mps3",
                c.linear_jerk_mps3,
                caps::LINEAR_JERK_MPS3,
                "m/s³",
            ),
            (
                "motion.angular_jerk_radps3",
                c.angular_jerk_radps3,
                caps::ANGULAR_JERK_RADPS3,
                "rad/s³",
            ),
            (
                "motion.finger_speed",
                c.finger_speed,
                caps::FINGER_SPEED,
                "units/s",
            ),
            (
                "motion.finger_acceleration",
                c.finger_acceleration,
                caps::FINGER_ACCELERATION,
                "units/s²",
            ),
            (
                "motion.finger_jerk",
                c.finger_jerk,
                caps::FINGER_JERK,
                "units/s³",
            ),
            (
                "motion.proportional_full_scale_volts",
                c.proportional_full_scale_volts,
                5.0,
                "V",
            ),
        ] {
            self.range(key, value, 0.0, false, cap, unit);
        }
        self.range(
            "motion.proportional_min_fraction",
            c.proportional_min_fraction,
            0.0,
            true,
            1.0,
            "",
        );
        c
    }

    fn workspace(&mut self, root: &mut Table, d: WorkspaceConfig) -> WorkspaceConfig {
        let mut t = self.section(root, "workspace");
        let c = WorkspaceConfig {
            reach_m: t.get("reach_m", d.reach_m),
            min_radius_m: t.get("min_radius_m", d.min_radius_m),
            table_z_m: t.get("table_z_m", d.table_z_m),
            stop_margin_m: t.get("stop_margin_m", d.stop_margin_m),
            finger_closed: t.get("finger_closed", d.finger_closed),
        };
        t.finish();
        self.range(
            "workspace.reach_m",
            c.reach_m,
            0.0,
            false,
            caps::REACH_M,
            "m",
        );
        self.range(
            "workspace.min_radius_m",
            c.min_radius_m,
            0.0,
            true,
            c.reach_m,
            "m",
        );
        self.range(
            "workspace.table_z_m",
            c.table_z_m,
            -c.reach_m,
            true,
            c.reach_m,
            "m",
        );
        self.range(
            "workspace.stop_margin_m",
            c.stop_margin_m,
            0.0,
            false,
            0.1,
            "m",
        );
        self.range(
            "workspace.finger_closed",
            c.finger_closed,
            0.0,
            false,
            10_000.0,
            "units",
        );
        c
    }

    fn arm(&mut self, root: &mut Table, d: ArmConfig, workspace: &WorkspaceConfig) -> ArmConfig {
        let mut t = self.section(root, "arm");
        let c = ArmConfig {
            home_position_m: t.get("home_position_m", d.home_position_m),
            home_rotation_vector_rad: t.get("home_rotation_vector_rad", d.home_rotation_vector_rad),
            home_fingers: t.get("home_fingers", d.home_fingers),
        };
        t.finish();
        let [x, y, z] = c.home_position_m;
        let r = (x * x + y * y + z * z).sqrt();
        let w = workspace;
        if !(r.is_finite()
            && r <= w.reach_m - w.stop_margin_m
            && r >= w.min_radius_m + w.stop_margin_m
            && z >= w.table_z_m + w.stop_margin_m)
        {
            self.error(
                "arm.home_position_m",
                format!(
                    "{:?} is not inside the workspace (distance from the base {r:.3} m must be within {:.3}–{:.3} m, z at least {:.3} m)",
                    c.home_position_m,
                    w.min_radius_m + w.stop_margin_m,
                    w.reach_m - w.stop_margin_m,
                    w.table_z_m + w.stop_margin_m
                ),
            );
        }
        if !c.home_rotation_vector_rad.iter().all(|v| v.is_finite()) {
            self.error("arm.home_rotation_vector_rad", "must be finite");
        }
        self.range(
            "arm.home_fingers",
            c.home_fingers,
            0.0,
            true,
            w.finger_closed,
            "units",
        );
        c
    }

    /// `[[sequence]]` entries; `None` when the file has none (use defaults).
    fn sequences(&mut self, root: &mut Table) -> Option<Vec<SequenceEntry>> {
        let list = match root.remove("sequence")? {
            Value::Array(list) => list,
            other => {
                self.error(
                    "sequence",
                    format!(
                        "must be an array of tables ([[sequence]]), found {}",
                        other.type_str()
                    ),
                );
                return None;
            }
        };
        if list.is_empty() {
            self.error("sequence", "the library has no sequence");
        }
        if list.len() > MAX_SEQUENCES {
            self.error(
                "sequence",
                format!("{} sequences, at most {MAX_SEQUENCES} allowed", list.len()),
            );
        }
        let mut entries = Vec::with_capacity(list.len());
        let mut seen: HashSet<ActionSeq> = HashSet::new();
        for (i, item) in list.into_iter().enumerate() {
            let path = format!("sequence #{}", i + 1);
            let table = match item {
                Value::Table(t) => t,
                other => {
                    self.error(path, format!("must be a table, found {}", other.type_str()));
                    continue;
                }
            };
            let mut t = Section {
                reader: self,
                table,
                path: path.clone(),
                known: Vec::new(),
            };
            let codes = t.require::<Vec<i64>>("actions");
            let mode_name = t.require::<String>("mode");
            t.finish();

            let actions = codes.and_then(|codes| self.actions(&path, &codes));
            let mode = mode_name.and_then(|name| {
                let mode = Mode::from_name(&name);
                if mode.is_none() {
                    self.error(
                        format!("{path}.mode"),
                        format!(
                            "unknown mode {name:?} (known: {})",
                            Mode::ALL.map(Mode::name).join(", ")
                        ),
                    );
                }
                mode
            });
            if let Some(seq) = actions {
                if !seen.insert(seq) {
                    self.error(
                        format!("{path}.actions"),
                        format!("{:?} is listed twice", seq),
                    );
                }
                if let Some(mode) = mode {
                    entries.push(SequenceEntry { actions: seq, mode });
                }
            }
        }
        Some(entries)
    }

    fn actions(&mut self, path: &str, codes: &[i64]) -> Option<ActionSeq> {
        let key = format!("{path}.actions");
        if codes.is_empty() {
            self.error(key, "must hold at least one action");
            return None;
        }
        if codes.len() > MAX_SEQUENCE_LEN {
            self.error(
                key,
                format!(
                    "{} actions, at most {MAX_SEQUENCE_LEN} allowed",
                    codes.len()
                ),
            );
            return None;
        }
        let bad: Vec<String> = codes
            .iter()
            .filter(|&&c| Action::from_code(c).is_none())
            .map(|c| c.to_string())
            .collect();
        if !bad.is_empty() {
            self.error(
                key,
                format!(
                    "{} not an action (1 = short sip, 2 = long sip, -1 = short puff, -2 = long puff)",
                    bad.join(", ")
                ),
            );
            return None;
        }
        let actions: Vec<Action> = codes.iter().filter_map(|&c| Action::from_code(c)).collect();
        ActionSeq::from_slice(&actions)
    }
}

/// One TOML table being read: takes known keys out, typed, with defaults,
/// and reports whatever is left as unknown.
struct Section<'r> {
    reader: &'r mut Reader,
    table: Table,
    path: String,
    known: Vec<&'static str>,
}

impl Section<'_> {
    /// The value of `key`, or `default` if absent; a value of the wrong type
    /// is reported and replaced by the default so that the remaining checks
    /// still run.
    fn get<T: DeserializeOwned>(&mut self, key: &'static str, default: T) -> T {
        self.known.push(key);
        let Some(value) = self.table.remove(key) else {
            return default;
        };
        let found = value.type_str();
        match value.try_into::<T>() {
            Ok(v) => v,
            Err(e) => {
                self.reader.error(
                    format!("{}.{key}", self.path),
                    format!("wrong type ({found}): {}", e.message().trim()),
                );
                default
            }
        }
    }

    /// Like [`Section::get`] for a required key: `None` (and an error) if absent.
    fn require<T: DeserializeOwned>(&mut self, key: &'static str) -> Option<T> {
        if !self.table.contains_key(key) {
            self.known.push(key);
            self.reader.error(format!("{}.{key}", self.path), "missing");
            return None;
        }
        let found = self.table.get(key).map(Value::type_str).unwrap_or("?");
        let value = self.table.remove(key)?;
        self.known.push(key);
        match value.try_into::<T>() {
            Ok(v) => Some(v),
            Err(e) => {
                self.reader.error(
                    format!("{}.{key}", self.path),
                    format!("wrong type ({found}): {}", e.message().trim()),
                );
                None
            }
        }
    }

    /// Reports every key that was not read.
    fn finish(self) {
        for key in self.table.keys() {
            self.reader.error(
                format!("{}.{key}", self.path),
                format!("unknown key (known: {})", self.known.join(", ")),
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn errors(text: &str) -> Vec<ConfigError> {
        Config::from_toml_str(text).unwrap_err().0
    }

    fn keys(text: &str) -> Vec<String> {
        errors(text).into_iter().map(|e| e.key).collect()
    }

    #[test]
    fn empty_file_is_the_default() {
        assert_eq!(Config::from_toml_str("").unwrap(), Config::default());
    }

    #[test]
    fn the_scanning_interface_and_its_errors() {
        let c = Config::from_toml_str(
            r#"
            [interface]
            kind = "bsp"
            [scanning]
            dwell_ms = 1000
            first_dwell_ms = 2500
            order = ["fingers", "translate_x"]
            "#,
        )
        .unwrap();
        assert_eq!(c.interface(), Interface::Bsp);
        assert_eq!(c.scanning().dwell_ms, 1000);
        assert_eq!(c.scanning().first_dwell_ms, 2500);
        assert_eq!(c.scanning().modes(), [Mode::Fingers, Mode::TranslateX]);
        let e = errors(
            r#"
            [interface]
            kind = "scan"
            [scanning]
            dwell_ms = 0
            order = ["fingers", "fly", "fingers"]
            speed = 1
            "#,
        );
        let found: Vec<(&str, &str)> = e
            .iter()
            .map(|e| (e.key.as_str(), e.message.as_str()))
            .collect();
        assert_eq!(
            found,
            [
                ("interface.kind", "\"scan\" is not `asp` or `bsp`"),
                (
                    "scanning.speed",
                    "unknown key (known: dwell_ms, first_dwell_ms, order)"
                ),
                ("scanning.dwell_ms", "must be greater than 0 ms"),
                (
                    "scanning.order",
                    "\"fly\" is not a mode (known: translate_x, translate_y, translate_z, rotate_x, rotate_y, rotate_z, fingers, save_point, goto_point)"
                ),
                ("scanning.order", "\"fingers\" appears twice"),
            ]
        );
    }

    #[test]
    fn issue_example_parses() {
        let c = Config::from_toml_str(
            r#"
            [detector]
            neutral_volts = 2.5
            puff_threshold_volts = 3.0
            sip_threshold_volts = 2.0
            hysteresis_volts = 0.1
            min_burst_ms = 40
            long_burst_ms = 500

            [matcher]
            sequence_timeout_ms = 1000

            [command]
            inactivity_timeout_ms = 2000

            [[sequence]]
            actions = [1, 1]
            mode = "translate_x"
            "#,
        )
        .unwrap();
        assert_eq!(c.sequences().len(), 1);
        assert_eq!(c.sequences()[0].mode, Mode::TranslateX);
        assert_eq!(
            c.sequences()[0].actions.as_slice(),
            &[Action::ShortSip, Action::ShortSip]
        );
        assert_eq!(c.matcher().sequence_timeout_ms, 1000);
    }

    #[test]
    fn integer_volts_are_accepted() {
        let c = Config::from_toml_str("[detector]\npuff_threshold_volts = 4\n").unwrap();
        assert_eq!(c.detector().puff_threshold_volts, 4.0);
    }

    #[test]
    fn every_error_is_reported_at_once_with_its_key() {
        let e = keys(
            r#"
            colour = "red"
            [detector]
            puff_threshold_volts = 2.0
            sip_threshold_volts = 2.6
            min_burst_ms = 0
            long_burst_ms = "long"
            typo_ms = 3
            [matcher]
            sequence_timeout_ms = -5
            [command]
            inactivity_timeout_ms = 0
            [[sequence]]
            actions = [1, 3]
            mode = "translate_x"
            [[sequence]]
            actions = []
            mode = "dance"
            [[sequence]]
            actions = [1, 1]
            mode = "fingers"
            [[sequence]]
            actions = [1, 1]
            mode = "rotate_z"
            speed = 2
            [[sequence]]
            mode = "rotate_y"
            "#,
        );
        let expected = [
            "detector.long_burst_ms",
            "detector.typo_ms",
            "detector.puff_threshold_volts",
            "detector.sip_threshold_volts",
            "detector.min_burst_ms",
            "detector.glitch_ms",
            "matcher.sequence_timeout_ms",
            "command.inactivity_timeout_ms",
            "sequence #1.actions",
            "sequence #2.actions",
            "sequence #2.mode",
            "sequence #4.speed",
            "sequence #4.actions",
            "sequence #5.actions",
            "colour",
        ];
        for key in expected {
            assert!(e.iter().any(|k| k == key), "no error for {key}: {e:?}");
        }
        assert_eq!(e.len(), expected.len(), "{e:?}");
    }

    #[test]
    fn messages_say_what_is_wrong() {
        let e = errors(
            "[detector]\nhysteresis_volts = 0.6\n[[sequence]]\nactions = [1, 7]\nmode = \"fingers\"\n",
        );
        assert_eq!(e.len(), 2, "{e:?}");
        assert_eq!(e[0].key, "detector.hysteresis_volts");
        assert!(e[0].message.contains("0.500"), "{}", e[0].message);
        assert_eq!(e[1].key, "sequence #1.actions");
        assert!(
            e[1].message.starts_with("7 not an action"),
            "{}",
            e[1].message
        );
        let text = ConfigErrors(e).to_string();
        assert!(
            text.starts_with("2 problems in the configuration:"),
            "{text}"
        );
    }

    #[test]
    fn long_must_exceed_min_and_glitch_must_be_shorter() {
        let e = errors("[detector]\nmin_burst_ms = 40\nlong_burst_ms = 40\nglitch_ms = 40\n");
        let keys: Vec<_> = e.iter().map(|e| e.key.as_str()).collect();
        assert_eq!(keys, ["detector.long_burst_ms", "detector.glitch_ms"]);
    }

    #[test]
    fn too_long_sequence_is_rejected() {
        let codes = vec!["1"; MAX_SEQUENCE_LEN + 1].join(", ");
        let e = errors(&format!(
            "[[sequence]]\nactions = [{codes}]\nmode = \"fingers\"\n"
        ));
        assert_eq!(e.len(), 1);
        assert!(e[0].message.contains("at most 16"), "{}", e[0].message);
    }

    #[test]
    fn nan_and_infinite_settings_are_rejected() {
        let e = keys(
            "[detector]\nneutral_volts = nan\nhysteresis_volts = nan\nfault_margin_volts = inf\n",
        );
        assert_eq!(
            e,
            [
                "detector.neutral_volts",
                "detector.hysteresis_volts",
                "detector.fault_margin_volts"
            ]
        );
    }

    #[test]
    fn syntax_error_is_reported() {
        let e = errors("[detector\n");
        assert_eq!(e[0].key, "(file)");
        assert!(e[0].message.starts_with("not valid TOML"));
    }

    #[test]
    fn default_library_is_prefix_free_and_covers_every_mode() {
        let c = Config::default();
        for mode in Mode::ALL {
            assert!(c.sequences().iter().any(|s| s.mode == mode), "{mode:?}");
        }
        for a in c.sequences() {
            for b in c.sequences() {
                if a != b {
                    assert!(!b.actions.as_slice().starts_with(a.actions.as_slice()));
                }
            }
        }
    }

    #[test]
    fn a_mode_may_have_several_sequences() {
        let c = Config::from_toml_str(
            "[[sequence]]\nactions = [1]\nmode = \"fingers\"\n[[sequence]]\nactions = [2]\nmode = \"fingers\"\n",
        )
        .unwrap();
        assert_eq!(c.sequences().len(), 2);
    }
}
