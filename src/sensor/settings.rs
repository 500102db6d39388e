//! The `[sensor]` settings: how a device's readings become volts, and how
//! the run treats the device (re-zero at start, reconnect). Read and
//! validated by `config/` like every other section; used only when opening
//! a device (never on the control thread).

use serde::{Deserialize, Serialize};

/// `[sensor]` and its backend sub-tables.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensorSettings {
    /// Measure the neutral from the sensor at rest before anything can
    /// move (analog devices; switches and recordings have no neutral).
    pub rezero: bool,
    /// How long the sensor must be at rest to measure the neutral, ms.
    pub rezero_ms: u32,
    /// Give up (an error at start) if the sensor has not been at rest for
    /// `rezero_ms` within this long, ms.
    pub rezero_timeout_ms: u32,
    /// Largest distance from the configured `detector.neutral_volts` a
    /// measured rest level may be, as a fraction of the distance from the
    /// neutral to the nearer threshold: further is taken for a breath held
    /// during the measurement, and measuring waits.
    pub rezero_max_shift_fraction: f64,
    /// When the device goes away mid-run, keep looking for it and resume
    /// when it returns (the core recovers after `fault_recovery_ms` at
    /// rest); otherwise the run ends safely.
    pub reconnect: bool,
    /// `--sensor evdev:…`.
    pub evdev: EvdevSettings,
    /// `--sensor serial:…`.
    pub serial: SerialSettings,
    /// `--sensor iio:…`.
    pub iio: IioSettings,
}

impl Default for SensorSettings {
    fn default() -> Self {
        SensorSettings {
            rezero: true,
            rezero_ms: 1000,
            rezero_timeout_ms: 30_000,
            rezero_max_shift_fraction: 0.5,
            reconnect: false,
            evdev: EvdevSettings::default(),
            serial: SerialSettings::default(),
            iio: IioSettings::default(),
        }
    }
}

/// What an input device reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum EvdevInput {
    /// Pressure on one absolute axis (e.g. the Origin Breeze in Joystick
    /// Plus mode).
    Axis,
    /// Sip and puff as key or button closures.
    Switches,
}

impl EvdevInput {
    /// Both kinds, for messages.
    pub const ALL: [EvdevInput; 2] = [EvdevInput::Axis, EvdevInput::Switches];

    /// The config name.
    pub fn name(self) -> &'static str {
        match self {
            EvdevInput::Axis => "axis",
            EvdevInput::Switches => "switches",
        }
    }
}

/// `[sensor.evdev]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EvdevSettings {
    /// `axis` or `switches`.
    pub input: EvdevInput,
    /// The absolute axis carrying pressure, by its Linux name.
    pub axis: String,
    /// Volts at the axis's reported minimum.
    pub volts_at_min: f64,
    /// Volts at the axis's reported maximum.
    pub volts_at_max: f64,
    /// Keys or buttons that mean "sip" (soft and hard, if the device has
    /// both), by their Linux names.
    pub sip_keys: Vec<String>,
    /// Keys or buttons that mean "puff".
    pub puff_keys: Vec<String>,
    /// Take the device for this program alone (`EVIOCGRAB`): a puff does
    /// not also click or move the desktop pointer.
    pub grab: bool,
}

impl Default for EvdevSettings {
    fn default() -> Self {
        EvdevSettings {
            input: EvdevInput::Axis,
            axis: "ABS_X".into(),
            volts_at_min: 0.0,
            volts_at_max: 5.0,
            sip_keys: vec!["BTN_TRIGGER".into()],
            puff_keys: vec!["BTN_THUMB".into()],
            grab: true,
        }
    }
}

/// What a serial device sends.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SerialFormat {
    /// One value per line, volts (a microcontroller on an analog sensor).
    Volts,
    /// One value per line, ADC counts; volts = counts / `full_scale` × 5.
    Counts,
    /// FLipMouse/FABI: `AT SR` starts `VALUES:<pressure 0–1023>,…` lines
    /// about every 50 ms.
    Flipmouse,
    /// LipSync: `DM,1:2` starts `SUCCESS,0:DEBUG,2:<mouthpiece>,<ambient>,
    /// <diff>,<offset>` lines (hPa) every 100 ms.
    Lipsync,
    /// A head-worn IMU: `ax,ay,az,gx,gy,gz` per line, m/s² (gravity
    /// included) and rad/s, for a person with gestures.
    Imu,
}

impl SerialFormat {
    /// Every format, for messages.
    pub const ALL: [SerialFormat; 5] = [
        SerialFormat::Volts,
        SerialFormat::Counts,
        SerialFormat::Flipmouse,
        SerialFormat::Lipsync,
        SerialFormat::Imu,
    ];

    /// The config name.
    pub fn name(self) -> &'static str {
        match self {
            SerialFormat::Volts => "volts",
            SerialFormat::Counts => "counts",
            SerialFormat::Flipmouse => "flipmouse",
            SerialFormat::Lipsync => "lipsync",
            SerialFormat::Imu => "imu",
        }
    }

    /// The format called `name`.
    pub fn from_name(name: &str) -> Option<SerialFormat> {
        SerialFormat::ALL.into_iter().find(|f| f.name() == name)
    }
}

/// `[sensor.serial]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SerialSettings {
    /// Line speed (`serial:PATH,baud=N` overrides it).
    pub baud: u32,
    /// What each line holds.
    pub format: SerialFormat,
    /// `counts`: the count that means 5 V (and FLipMouse's pressure: 1023).
    pub full_scale: f64,
    /// `lipsync`: volts per hPa of pressure difference, around
    /// `detector.neutral_volts`.
    pub volts_per_hpa: f64,
    /// A port that sends no sample within this long at start is an error,
    /// ms.
    pub answer_timeout_ms: u32,
    /// No line for this long mid-run: the samples stop (the core faults
    /// after `detector.stale_ms`), ms. Longer than the source's period.
    pub silence_ms: u32,
}

impl Default for SerialSettings {
    fn default() -> Self {
        SerialSettings {
            baud: 115_200,
            format: SerialFormat::Volts,
            full_scale: 1023.0,
            volts_per_hpa: 0.05,
            answer_timeout_ms: 2000,
            silence_ms: 300,
        }
    }
}

/// `[sensor.iio]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IioSettings {
    /// Volts = raw × scale (mV) / 1000 × `gain` + `offset_volts`: e.g. a
    /// 3.3 V ADC behind a 5 V → 3.3 V divider has gain 5 / 3.3.
    pub gain: f64,
    /// Added after the gain, volts.
    pub offset_volts: f64,
    /// Reads per second of the sysfs value (the ADC's own rate may be
    /// lower: the ADS1115 converts at most 860 times a second).
    pub rate_hz: u32,
    /// An IMU: read its buffer (`/dev/iio:deviceN`), filled at each firing
    /// of its trigger, instead of sysfs at `rate_hz`: for a device on a
    /// bus too slow for six sysfs reads a sample.
    pub buffered: bool,
    /// With `buffered`: the trigger to capture on (a name from
    /// `/sys/bus/iio/devices/trigger*/name`, usually the device's own
    /// data-ready trigger); empty keeps the one the device has.
    pub trigger: String,
}

impl Default for IioSettings {
    fn default() -> Self {
        IioSettings {
            gain: 1.0,
            offset_volts: 0.0,
            rate_hz: 1000,
            buffered: false,
            trigger: String::new(),
        }
    }
}
