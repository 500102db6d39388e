//! `run`'s session: the display's address taken, the arm and the outputs
//! opened, the sensor opened (a device re-zeroed; an IMU alone or beside
//! a breath sensor), then the loop run on
//! them, its events to the sink given, watched by the display and
//! recorded if asked. The recording ends before the report is returned,
//! its summary in the report (and its `report.json`); the terminal view
//! gives the terminal back before it.

use std::path::Path;

use crate::arm::Arm;
use crate::arm::ArmSpec;
use crate::config::Config;
use crate::output::{Output, OutputSpec};
use crate::rt::output_thread::Serves;
use crate::rt::recorder::SessionRecorder;
use crate::rt::report::RunReport;
use crate::rt::telemetry_thread::{EventSink, Watchers};
use crate::rt::threads::{self, LoopSettings, RunOptions};
use crate::sensor::imu_sensor::ImuSensor;
use crate::sensor::settings::SerialFormat;
use crate::sensor::with_imu::WithImu;
use crate::sensor::{Sensor, SensorSpec};
use crate::session::Console;
use crate::session::gestures;
use crate::session::imu::open_imu_for_set;
use crate::session::showing::{Display, DisplayChoice};
use crate::sim::synthetic_sensor::SyntheticSensor;
use crate::tools::imu_csv::is_imu_csv;
use crate::tools::recording::recorder::Recorder;
use crate::tools::recording::writer::RecordOptions;
use crate::wiring::arm::open_arm;
use crate::wiring::outputs::open_outputs;
use crate::wiring::sensor::{OnSensor, open_sensor};

/// What `run` runs: the backends by their specs (`synthetic` is the
/// built-in scripted user), the loop's settings, the recording and the
/// display asked for.
pub struct RunPlan<'a> {
    /// `--sensor`.
    pub sensor: &'a SensorSpec,
    /// `--imu`: a head-worn IMU beside the breath sensor, if given.
    pub imu: Option<&'a SensorSpec>,
    /// `--arm`.
    pub arm: &'a ArmSpec,
    /// `--output`, each.
    pub outputs: &'a [OutputSpec],
    /// How the loop runs and what stops it.
    pub settings: &'a LoopSettings,
    /// Record the session here (a directory checked before), if asked.
    pub record: Option<Record<'a>>,
    /// The page and the terminal view.
    pub display: DisplayChoice,
    /// The file that set `detector.max_hold_ms` (`None`: built in), for
    /// the report's line on breaths held past it.
    pub max_hold_set_in: Option<&'a Path>,
}

/// `--record DIR`, checked, and the recording's limits.
pub struct Record<'a> {
    /// The directory (created if needed; never over a recording).
    pub dir: &'a Path,
    /// The cap on its size.
    pub options: RecordOptions,
}

/// Runs the session `plan` asks for on `config`; each event goes to
/// `events` as it happens. Returns the report (its recording finished).
pub fn run(
    config: &Config,
    plan: &RunPlan,
    events: &mut dyn EventSink,
    console: &dyn Console,
) -> anyhow::Result<RunReport> {
    let imu = imu_sensor(config, plan.sensor, plan.imu)?;
    // The page's address is taken before anything starts: a clash is an
    // error now, not a display missing later.
    let display = Display::open(&plan.display, console)?;
    let say = |line: &str| console.note(line);
    // The backends; the outputs opened before anything starts (a missing
    // device or an unreachable address is said now).
    let arm = open_arm(plan.arm, config)?;
    let outputs = open_outputs(plan.outputs, config, &say)?;
    let start = Start {
        arm,
        outputs,
        settings: plan.settings,
        events,
        record: plan.record.as_ref(),
        display: &display,
        max_hold_set_in: plan.max_hold_set_in,
    };
    let synthetic = |config: &Config, name: Option<&str>| match name {
        None => Ok((config.clone(), SyntheticSensor::built_in_user(config))),
        Some(name) => {
            let (config, breather) =
                SyntheticSensor::breather_named(config, name).map_err(anyhow::Error::msg)?;
            let user = SyntheticSensor::breather_user(&config, &breather);
            Ok((config, user))
        }
    };
    match imu {
        Some((config, imu, Beside::Nothing)) => start.on(&config, imu),
        Some((config, imu, Beside::Breath)) => {
            let start = WithImuStart { imu, start };
            open_sensor(plan.sensor, &config, synthetic, start, &say)
        }
        None => open_sensor(plan.sensor, config, synthetic, start, &say),
    }
}

/// For a person with gestures, which sensors `--sensor` (`sensor`) and `--imu` read and the
/// configuration for them (their set loaded): the IMU alone, when
/// `--sensor` is one (an IMU recording `csv:FILE`; a serial port with
/// `[sensor.serial] format = "imu"`; an input device or IIO device, with
/// a set); or a breath sensor with `--imu` beside it. `None` for breaths
/// alone. An error, before anything starts, for gestures without an
/// IMU, an IMU without gestures, `--imu` beside an IMU, or an IMU lacking
/// a channel the set was recorded with.
pub(crate) fn imu_sensor(
    config: &Config,
    sensor: &SensorSpec,
    imu: Option<&SensorSpec>,
) -> anyhow::Result<Option<(Config, ImuSensor, Beside)>> {
    let serial = &config.sensor().serial;
    let gestures = config.core().gesture_set_file();
    let imu_csv = |spec: &SensorSpec| matches!(spec, SensorSpec::Csv(path) if is_imu_csv(path));
    if let Some(imu) = imu {
        if imu_csv(sensor)
            || matches!(sensor, SensorSpec::Serial { .. } if serial.format == SerialFormat::Imu)
        {
            anyhow::bail!(
                "--sensor {}: with --imu, --sensor is the breath sensor (a sip-and-puff device, a breath recording or `synthetic`); give the IMU once, with --imu",
                sensor
            );
        }
        let setup = gestures::load_setup(config.core())
            .map_err(|e| anyhow::anyhow!("--imu {}: {e}", imu))?;
        let config = config.clone().for_breath_and_imu(setup);
        let sensor = open_imu_for_set(imu, &config).map_err(|e| anyhow::anyhow!("--imu {e}"))?;
        return Ok(Some((config, sensor, Beside::Breath)));
    }
    let alone = match sensor {
        SensorSpec::Csv(_) => imu_csv(sensor),
        SensorSpec::Serial { .. } => serial.format == SerialFormat::Imu,
        SensorSpec::Evdev(_) | SensorSpec::Iio(_) => gestures.is_some(),
        SensorSpec::Synthetic(_) => false,
    };
    if !alone {
        if let Some(set) = gestures {
            anyhow::bail!(
                "[gestures] set = {:?}: gestures need an IMU: give --sensor evdev:name=NAME (an input device with the accelerometer property: `sipnpuff sensors` marks them), iio:/sys/bus/iio/devices/iio:deviceN (an IIO IMU), csv:IMU.csv (a recording played live) or serial:PORT with [sensor.serial] format = \"imu\"; to read breaths too, give the breath sensor with --sensor and the IMU with --imu. Leave [gestures] out to run on breaths",
                set.display()
            );
        }
        return Ok(None);
    }
    let setup = gestures::load_setup(config.core())?;
    let config = config.clone().for_imu(setup);
    let sensor = open_imu_for_set(sensor, &config)?;
    Ok(Some((config, sensor, Beside::Nothing)))
}

/// Whether an IMU is read alone or beside a breath sensor.
pub(crate) enum Beside {
    /// The IMU is the run's only sensor.
    Nothing,
    /// The breath sensor `--sensor` names is read too.
    Breath,
}

/// The breath sensor opened, the IMU beside it: the session on both.
struct WithImuStart<'a> {
    imu: ImuSensor,
    start: Start<'a>,
}

impl OnSensor for WithImuStart<'_> {
    type Output = RunReport;

    fn on<S: Sensor>(self, config: &Config, sensor: S) -> anyhow::Result<RunReport> {
        self.start.on(config, WithImu::new(sensor, self.imu))
    }
}

/// The session on the sensor opened: the loop on it, the core built from
/// the configuration in effect, with the display and the recording asked
/// for.
struct Start<'a> {
    arm: Box<dyn Arm>,
    outputs: Vec<(Serves, Box<dyn Output>)>,
    settings: &'a LoopSettings,
    events: &'a mut dyn EventSink,
    record: Option<&'a Record<'a>>,
    display: &'a Display<'a>,
    max_hold_set_in: Option<&'a Path>,
}

impl OnSensor for Start<'_> {
    type Output = RunReport;

    fn on<S: Sensor>(self, config: &Config, sensor: S) -> anyhow::Result<RunReport> {
        let Start {
            arm,
            outputs,
            settings,
            events,
            record,
            display,
            max_hold_set_in,
        } = self;
        let mut recorder = match record {
            Some(record) => Some(
                Recorder::create(record.dir, config, record.options)
                    .map_err(|e| anyhow::Error::new(e).context("--record"))?,
            ),
            None => None,
        };
        let mut showing = display.start(config.core(), &arm.describe())?;
        let options = RunOptions {
            watchers: Watchers {
                events: Some(events),
                recorder: recorder.as_mut().map(|r| r as &mut dyn SessionRecorder),
                observer: showing.observer(),
            },
            outputs,
            ..RunOptions::new(sensor, arm, settings.clone())
        };
        let mut result = threads::run(config.core(), options);
        showing.finish(result.as_mut().ok());
        let mut report = result?;
        report.max_hold = Some(max_hold(config, max_hold_set_in));
        if let Some(recorder) = recorder {
            recorder.finish(&mut report);
        }
        Ok(report)
    }
}

/// `detector.max_hold_ms` and where it came from, for the report's line on
/// breaths held past it: "1000 ms, set in anna.toml" or "6000 ms, the
/// built-in default".
fn max_hold(config: &Config, set_in: Option<&Path>) -> String {
    let ms = config.core().detector().max_hold_ms;
    match set_in {
        Some(path) => format!("{ms} ms, set in {}", path.display()),
        None => format!("{ms} ms, the built-in default"),
    }
}
