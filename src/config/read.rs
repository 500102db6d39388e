//! Reading: TOML text into typed sections, key by key. A missing key takes
//! its default; a value of the wrong type, an unknown key or section is an
//! error naming its key; each section is checked (`super::validate`) as
//! soon as it is read, so every problem is found in one pass, in file
//! order.

use std::collections::HashSet;

use serde::de::DeserializeOwned;
use toml::{Table, Value};

use crate::arm::settings::{
    ArmSettings, KinovaSdkSettings, Ros1Settings, Ros2Message, Ros2Settings,
};
use crate::config::validate::{self, Problems};
use crate::control::action::{Action, ActionSeq, MAX_SEQUENCE_LEN};
use crate::control::core_config::{CoreConfig, InterfaceSection};
use crate::control::detector::DetectorConfig;
use crate::control::mode::Mode;
use crate::control::modes::CommandConfig;
use crate::control::motion::feedback::FeedbackConfig;
use crate::control::motion::home::HomeConfig;
use crate::control::motion::limits::MotionConfig;
use crate::control::motion::workspace::WorkspaceConfig;
use crate::control::selection::matcher::MatcherConfig;
use crate::control::selection::scanning::ScanningConfig;
use crate::control::selection::{Interface, SequenceEntry};
use crate::sensor::settings::{
    EvdevInput, EvdevSettings, IioSettings, SensorSettings, SerialFormat, SerialSettings,
};

/// The sections a file may have, in the order they are read.
pub const SECTIONS: [&str; 10] = [
    "detector",
    "matcher",
    "command",
    "motion",
    "workspace",
    "arm",
    "sequence",
    "interface",
    "scanning",
    "sensor",
];

/// Reads a parsed file over `defaults`. Every problem is in `problems`;
/// the result is only meaningful when there are none.
pub(super) fn core(root: &mut Table, defaults: &CoreConfig, problems: &mut Problems) -> CoreConfig {
    let mut reader = Reader { problems };
    let detector = reader.detector(root, defaults.detector);
    let matcher = reader.matcher(root, defaults.matcher);
    let command = reader.command(root, defaults.command);
    let motion = reader.motion(root, defaults.motion);
    let workspace = reader.workspace(root, defaults.workspace);
    let (home, feedback) = reader.home(root, defaults.home, defaults.feedback, &workspace);
    let sequences = reader
        .sequences(root)
        .unwrap_or_else(|| defaults.sequences.clone());
    let interface = reader.interface(root);
    let scanning = reader.scanning(root, defaults.scanning);
    for key in root.keys() {
        reader.problems.add(
            key.clone(),
            format!("unknown section or key (known: {})", SECTIONS.join(", ")),
        );
    }
    CoreConfig {
        detector,
        matcher,
        command,
        motion,
        workspace,
        home,
        feedback,
        interface: InterfaceSection { kind: interface },
        scanning,
        sequences,
    }
}

/// Reads `[sensor]` (and its `evdev`, `serial`, `iio` tables) out of a
/// parsed file over `defaults`.
pub(super) fn sensor(
    root: &mut Table,
    defaults: &SensorSettings,
    problems: &mut Problems,
) -> SensorSettings {
    let mut reader = Reader { problems };
    let mut t = reader.section(root, "sensor");
    let evdev_table = t.table_key("evdev");
    let serial_table = t.table_key("serial");
    let iio_table = t.table_key("iio");
    let mut c = SensorSettings {
        rezero: t.get("rezero", defaults.rezero),
        rezero_ms: t.get("rezero_ms", defaults.rezero_ms),
        rezero_timeout_ms: t.get("rezero_timeout_ms", defaults.rezero_timeout_ms),
        rezero_max_shift_fraction: t.get(
            "rezero_max_shift_fraction",
            defaults.rezero_max_shift_fraction,
        ),
        reconnect: t.get("reconnect", defaults.reconnect),
        ..defaults.clone()
    };
    t.finish();

    let mut t = reader.subsection(evdev_table, "sensor.evdev");
    let d = &defaults.evdev;
    let input: String = t.get("input", d.input.name().to_string());
    c.evdev = EvdevSettings {
        input: d.input,
        axis: t.get("axis", d.axis.clone()),
        volts_at_min: t.get("volts_at_min", d.volts_at_min),
        volts_at_max: t.get("volts_at_max", d.volts_at_max),
        sip_keys: t.get("sip_keys", d.sip_keys.clone()),
        puff_keys: t.get("puff_keys", d.puff_keys.clone()),
        grab: t.get("grab", d.grab),
    };
    t.finish();
    match [EvdevInput::Axis, EvdevInput::Switches]
        .into_iter()
        .find(|i| i.name() == input)
    {
        Some(i) => c.evdev.input = i,
        None => reader.problems.add(
            "sensor.evdev.input",
            format!("{input:?} is not `axis` or `switches`"),
        ),
    }

    let mut t = reader.subsection(serial_table, "sensor.serial");
    let d = &defaults.serial;
    let format: String = t.get("format", d.format.name().to_string());
    c.serial = SerialSettings {
        baud: t.get("baud", d.baud),
        format: d.format,
        full_scale: t.get("full_scale", d.full_scale),
        volts_per_hpa: t.get("volts_per_hpa", d.volts_per_hpa),
        answer_timeout_ms: t.get("answer_timeout_ms", d.answer_timeout_ms),
        silence_ms: t.get("silence_ms", d.silence_ms),
    };
    t.finish();
    match SerialFormat::from_name(&format) {
        Some(f) => c.serial.format = f,
        None => reader.problems.add(
            "sensor.serial.format",
            format!(
                "{format:?} is not a format (known: {})",
                SerialFormat::ALL.map(SerialFormat::name).join(", ")
            ),
        ),
    }

    let mut t = reader.subsection(iio_table, "sensor.iio");
    let d = &defaults.iio;
    c.iio = IioSettings {
        gain: t.get("gain", d.gain),
        offset_volts: t.get("offset_volts", d.offset_volts),
        rate_hz: t.get("rate_hz", d.rate_hz),
    };
    t.finish();
    validate::sensor(reader.problems, &c);
    c
}

/// Reads the arm backends' settings out of `[arm]` (`connect_timeout_ms`
/// and the `ros2`, `ros1`, `kinova_sdk` tables) over `defaults`, leaving
/// the rest of `[arm]` to the core.
pub(super) fn arm(
    root: &mut Table,
    defaults: &ArmSettings,
    problems: &mut Problems,
) -> ArmSettings {
    let mut reader = Reader { problems };
    let mut taken = Table::new();
    if let Some(Value::Table(arm)) = root.get_mut("arm") {
        for key in ["connect_timeout_ms", "ros2", "ros1", "kinova_sdk"] {
            if let Some(value) = arm.remove(key) {
                taken.insert(key.into(), value);
            }
        }
    }
    let mut t = reader.subsection(taken, "arm");
    let ros2_table = t.table_key("ros2");
    let ros1_table = t.table_key("ros1");
    let sdk_table = t.table_key("kinova_sdk");
    let mut c = ArmSettings {
        connect_timeout_ms: t.get("connect_timeout_ms", defaults.connect_timeout_ms),
        ..defaults.clone()
    };
    t.finish();

    let mut t = reader.subsection(ros2_table, "arm.ros2");
    let d = &defaults.ros2;
    let message: String = t.get("message", d.message.name().to_string());
    c.ros2 = Ros2Settings {
        message: d.message,
        frame_id: t.get("frame_id", d.frame_id.clone()),
        pose_topic: t.get("pose_topic", d.pose_topic.clone()),
        domain_id: t.get("domain_id", d.domain_id),
    };
    t.finish();
    match Ros2Message::from_name(&message) {
        Some(m) => c.ros2.message = m,
        None => reader.problems.add(
            "arm.ros2.message",
            format!(
                "{message:?} is not a message (known: {})",
                Ros2Message::ALL.map(Ros2Message::name).join(", ")
            ),
        ),
    }

    let mut t = reader.subsection(ros1_table, "arm.ros1");
    let d = &defaults.ros1;
    c.ros1 = Ros1Settings {
        fingers: t.get("fingers", d.fingers),
        tool_pose: t.get("tool_pose", d.tool_pose),
        master_check_ms: t.get("master_check_ms", d.master_check_ms),
    };
    t.finish();

    let mut t = reader.subsection(sdk_table, "arm.kinova_sdk");
    let d = &defaults.kinova_sdk;
    c.kinova_sdk = KinovaSdkSettings {
        library_dir: t.get("library_dir", d.library_dir.clone()),
        serial_number: t.get("serial_number", d.serial_number.clone()),
        call_timeout_ms: t.get("call_timeout_ms", d.call_timeout_ms),
        local_ip: t.get("local_ip", d.local_ip.clone()),
        subnet_mask: t.get("subnet_mask", d.subnet_mask.clone()),
        robot_ip: t.get("robot_ip", d.robot_ip.clone()),
        robot_port: t.get("robot_port", d.robot_port),
        local_cmd_port: t.get("local_cmd_port", d.local_cmd_port),
        local_broadcast_port: t.get("local_broadcast_port", d.local_broadcast_port),
    };
    t.finish();
    validate::arm(reader.problems, &c);
    c
}

/// Walks the TOML table, taking known keys out.
struct Reader<'p> {
    problems: &'p mut Problems,
}

impl Reader<'_> {
    /// Opens a section of `root`; an absent section is empty.
    fn section<'r>(&'r mut self, root: &mut Table, name: &'static str) -> Section<'r> {
        let table = match root.remove(name) {
            None => Table::new(),
            Some(Value::Table(table)) => table,
            Some(other) => {
                self.problems
                    .add(name, format!("must be a table, found {}", other.type_str()));
                Table::new()
            }
        };
        Section {
            problems: &mut *self.problems,
            table,
            path: name.to_string(),
            known: Vec::new(),
        }
    }

    /// A table found inside a section, read like a section named `path`.
    fn subsection<'r>(&'r mut self, table: Table, path: &'static str) -> Section<'r> {
        Section {
            problems: &mut *self.problems,
            table,
            path: path.to_string(),
            known: Vec::new(),
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
            max_hold_ms: t.get("max_hold_ms", d.max_hold_ms),
            rezero_ms: t.get("rezero_ms", d.rezero_ms),
        };
        t.finish();
        validate::detector(self.problems, &c);
        c
    }

    fn matcher(&mut self, root: &mut Table, d: MatcherConfig) -> MatcherConfig {
        let mut t = self.section(root, "matcher");
        let c = MatcherConfig {
            sequence_timeout_ms: t.get("sequence_timeout_ms", d.sequence_timeout_ms),
        };
        t.finish();
        validate::matcher(self.problems, &c);
        c
    }

    fn command(&mut self, root: &mut Table, d: CommandConfig) -> CommandConfig {
        let mut t = self.section(root, "command");
        let c = CommandConfig {
            inactivity_timeout_ms: t.get("inactivity_timeout_ms", d.inactivity_timeout_ms),
            motion_onset_ms: t.get("motion_onset_ms", d.motion_onset_ms),
        };
        t.finish();
        validate::command(self.problems, &c);
        c
    }

    fn interface(&mut self, root: &mut Table) -> Interface {
        let mut t = self.section(root, "interface");
        let kind: String = t.get("kind", Interface::default().name().to_string());
        t.finish();
        Interface::from_name(&kind).unwrap_or_else(|| {
            self.problems
                .add("interface.kind", format!("{kind:?} is not `asp` or `bsp`"));
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
        validate::scanning_dwell(self.problems, dwell_ms, first_dwell_ms);
        let mut modes = Vec::new();
        for name in &names {
            match Mode::from_name(name) {
                Some(mode) => modes.push(mode),
                None => self.problems.add(
                    "scanning.order",
                    format!(
                        "{name:?} is not a mode (known: {})",
                        Mode::ALL.map(Mode::name).join(", ")
                    ),
                ),
            }
        }
        validate::scan_order(self.problems, &modes);
        let mut c = ScanningConfig {
            dwell_ms,
            first_dwell_ms,
            order: d.order,
            order_len: 0,
        };
        // Each mode once (duplicates were reported): at most nine.
        for mode in modes {
            if !c.modes().contains(&mode)
                && let Some(slot) = c.order.get_mut(c.order_len)
            {
                *slot = mode;
                c.order_len += 1;
            }
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
        validate::motion(self.problems, &c);
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
            max_tilt_rad: t.get("max_tilt_rad", d.max_tilt_rad),
            max_twist_rad: t.get("max_twist_rad", d.max_twist_rad),
        };
        t.finish();
        validate::workspace(self.problems, &c);
        c
    }

    /// `[arm]`'s home pose and its `feedback` table (the backends' keys
    /// were taken out by [`arm`]).
    fn home(
        &mut self,
        root: &mut Table,
        d: HomeConfig,
        fd: FeedbackConfig,
        workspace: &WorkspaceConfig,
    ) -> (HomeConfig, FeedbackConfig) {
        let mut t = self.section(root, "arm");
        // Known here, read by `arm`: for the unknown-key message.
        t.known
            .extend(["connect_timeout_ms", "ros2", "ros1", "kinova_sdk"]);
        let feedback_table = t.table_key("feedback");
        let c = HomeConfig {
            home_position_m: t.get("home_position_m", d.home_position_m),
            home_rotation_vector_rad: t.get("home_rotation_vector_rad", d.home_rotation_vector_rad),
            home_fingers: t.get("home_fingers", d.home_fingers),
        };
        t.finish();
        validate::home(self.problems, &c, workspace);
        let mut t = self.subsection(feedback_table, "arm.feedback");
        let f = FeedbackConfig {
            timeout_ms: t.get("timeout_ms", fd.timeout_ms),
            tolerance_m: t.get("tolerance_m", fd.tolerance_m),
            tolerance_rad: t.get("tolerance_rad", fd.tolerance_rad),
            window_ms: t.get("window_ms", fd.window_ms),
        };
        t.finish();
        validate::feedback(self.problems, &f);
        (c, f)
    }

    /// `[[sequence]]` entries; `None` when the file has none (use defaults).
    fn sequences(&mut self, root: &mut Table) -> Option<Vec<SequenceEntry>> {
        let list = match root.remove("sequence")? {
            Value::Array(list) => list,
            other => {
                self.problems.add(
                    "sequence",
                    format!(
                        "must be an array of tables ([[sequence]]), found {}",
                        other.type_str()
                    ),
                );
                return None;
            }
        };
        validate::library_size(self.problems, list.len());
        let mut entries = Vec::with_capacity(list.len());
        let mut seen: HashSet<ActionSeq> = HashSet::new();
        for (i, item) in list.into_iter().enumerate() {
            let path = format!("sequence #{}", i + 1);
            let table = match item {
                Value::Table(t) => t,
                other => {
                    self.problems
                        .add(path, format!("must be a table, found {}", other.type_str()));
                    continue;
                }
            };
            let mut t = Section {
                problems: &mut *self.problems,
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
                    self.problems.add(
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
                    self.problems
                        .add(format!("{path}.actions"), validate::listed_twice(&seq));
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
            self.problems.add(key, "must hold at least one action");
            return None;
        }
        if codes.len() > MAX_SEQUENCE_LEN {
            self.problems.add(
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
            self.problems.add(
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
    problems: &'r mut Problems,
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
                self.problems.add(
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
            self.problems.add(format!("{}.{key}", self.path), "missing");
            return None;
        }
        let found = self.table.get(key).map(Value::type_str).unwrap_or("?");
        let value = self.table.remove(key)?;
        self.known.push(key);
        match value.try_into::<T>() {
            Ok(v) => Some(v),
            Err(e) => {
                self.problems.add(
                    format!("{}.{key}", self.path),
                    format!("wrong type ({found}): {}", e.message().trim()),
                );
                None
            }
        }
    }

    /// The table under `key` (empty if absent; reported if not a table).
    fn table_key(&mut self, key: &'static str) -> Table {
        self.known.push(key);
        match self.table.remove(key) {
            None => Table::new(),
            Some(Value::Table(table)) => table,
            Some(other) => {
                self.problems.add(
                    format!("{}.{key}", self.path),
                    format!("must be a table, found {}", other.type_str()),
                );
                Table::new()
            }
        }
    }

    /// Reports every key that was not read.
    fn finish(self) {
        for key in self.table.keys() {
            self.problems.add(
                format!("{}.{key}", self.path),
                format!("unknown key (known: {})", self.known.join(", ")),
            );
        }
    }
}
