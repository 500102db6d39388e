//! `sipnpuff run`: the main job.

use std::io;
use std::path::{Path, PathBuf};

use anyhow::Context;

use crate::arm::kinova_sdk::KinovaSdkArm;
use crate::arm::ros1::Ros1Arm;
#[cfg(feature = "ros2")]
use crate::arm::ros2::Ros2Arm;
use crate::arm::sim::SimArm;
use crate::arm::{Arm, ArmSpec};
use crate::cli::args::{
    ConfigArg, InterfaceArg, RtArgs, parse_seconds, with_interface, writable_dir,
};
use crate::cli::display::{Display, DisplayArgs};
use crate::cli::output::{self, StdoutEvents, invalid};
use crate::config::Config;
use crate::control::target::{HomeEvent, Target};
#[cfg(feature = "mqtt")]
use crate::output::mqtt::MqttOutput;
use crate::output::settings::MqttSettings;
use crate::output::uinput::UinputOutput;
use crate::output::{Output, OutputSpec};
use crate::rt::control_loop::StopReason;
use crate::rt::output_thread::Serves;
use crate::rt::recorder::SessionRecorder;
use crate::rt::report::RunReport;
use crate::rt::signals;
use crate::rt::stop::StopRequest;
use crate::rt::telemetry_thread::Watchers;
use crate::rt::threads::{self, LoopSettings, RunOptions};
use crate::sensor::csv::CsvSensor;
use crate::sensor::evdev::EvdevSensor;
use crate::sensor::iio::IioSensor;
use crate::sensor::rezero;
use crate::sensor::serial::SerialSensor;
use crate::sensor::{Prepared, Sensor, SensorSpec};
use crate::sim::synthetic_sensor::SyntheticSensor;
use crate::tools::recording::recorder::{Recorder, check_dir};
use crate::tools::recording::writer::{MIN_BYTES, RecordOptions};

/// `run`'s options.
#[derive(clap::Args, Debug)]
pub struct RunArgs {
    #[command(flatten)]
    config: ConfigArg,
    /// Run this long, s (default: until the sensor ends: the scripted user
    /// or the recording runs out, or a device is lost for good).
    #[arg(long, value_parser = parse_seconds)]
    seconds: Option<f64>,
    /// Where samples come from: `synthetic` (the built-in scripted user),
    /// `csv:PATH` (a recording played in real time), or a device:
    /// `evdev:/dev/input/eventN` or `evdev:name=SUBSTRING` (a USB HID
    /// sip-and-puff device: an analog axis or switches), `serial:PATH[,baud=N]`
    /// (a microcontroller's stream, FLipMouse or LipSync), or
    /// `iio:/sys/bus/iio/devices/iio:deviceN/in_voltageM_raw` (an ADC).
    /// Device settings: `[sensor]` in the config (`sipnpuff sensors`
    /// lists what this machine has).
    #[arg(long, default_value = "synthetic", value_parser = SensorSpec::parse)]
    sensor: SensorSpec,
    /// The arm: `sim` (the simulated JACO2), `ros2:TOPIC` (MoveIt Servo,
    /// ros2_kortex's twist controller, a JACO2 ROS 2 port), `ros1:NAMESPACE`
    /// (kinova-ros's driver, e.g. `ros1:/j2n6s300_driver`; the master from
    /// `ROS_MASTER_URI`) or `kinova-sdk:usb|eth` (Kinova's own library).
    /// Settings: `[arm]` in the config (docs/arms.md).
    #[arg(long, default_value = "sim", value_parser = ArmSpec::parse)]
    arm: ArmSpec,
    /// Also drive the computer or the home (repeatable): `uinput` (a
    /// virtual keyboard and pointer through /dev/uinput: the library's
    /// `key`, `click`, pointer modes and `drag`; settings in
    /// `[output.uinput]`) or `mqtt` / `mqtt:HOST:PORT` (Home Assistant
    /// over MQTT: the library's `event`s; settings in `[output.mqtt]`).
    /// Set-up for each, the udev rule and a Home Assistant automation:
    /// docs/outputs.md.
    #[arg(long = "output", value_name = "OUTPUT", value_parser = OutputSpec::parse)]
    outputs: Vec<OutputSpec>,
    /// Selection interface (default: the config's `interface.kind`).
    #[arg(long, value_enum)]
    interface: Option<InterfaceArg>,
    /// Write each histogram in HdrHistogram's `.hgrm` text format here.
    #[arg(long, value_name = "DIR")]
    histogram_dir: Option<PathBuf>,
    /// Print the final report as one JSON object (after the event lines).
    #[arg(long)]
    json: bool,
    /// Record the session into this directory (created if needed; never
    /// over an existing recording): what the control loop saw, the
    /// configuration, the events, the arm commands and the report, for
    /// `sipnpuff replay DIR`.
    #[arg(long, value_name = "DIR")]
    record: Option<PathBuf>,
    /// Cap on the recording's samples, commands and events, MB (10^6
    /// bytes); past it recording stops and the run goes on.
    #[arg(long, value_name = "MB", default_value = "200", requires = "record", value_parser = parse_megabytes)]
    record_max_mb: u64,
    #[command(flatten)]
    display: DisplayArgs,
    #[command(flatten)]
    rt: RtArgs,
}

/// Opens the `--arm` backend (not yet connected: the arm thread connects
/// it, with `[arm] connect_timeout_ms`).
fn open_arm(spec: &ArmSpec, config: &Config) -> anyhow::Result<Box<dyn Arm>> {
    Ok(match spec {
        ArmSpec::Sim => Box::new(SimArm::new(config.core())),
        #[cfg(feature = "ros2")]
        ArmSpec::Ros2 { topic } => {
            let settings = config.arm();
            Box::new(Ros2Arm::new(
                topic,
                &settings.ros2,
                settings.connect_timeout_ms,
            ))
        }
        #[cfg(not(feature = "ros2"))]
        ArmSpec::Ros2 { .. } => anyhow::bail!(
            "--arm {spec}: this sipnpuff was built without the `ros2` feature (it is on by default: build without --no-default-features)"
        ),
        ArmSpec::Ros1 { namespace } => Box::new(Ros1Arm::new(
            namespace,
            &config.arm().ros1,
            config.arm().connect_timeout_ms,
        )),
        ArmSpec::KinovaSdk { link } => Box::new(KinovaSdkArm::new(*link, config.arm())),
    })
}

/// Opens the `--output` backends, each with what it serves; says which
/// of the library's entries would do nothing without one.
fn open_outputs(
    specs: &[OutputSpec],
    config: &Config,
) -> anyhow::Result<Vec<(Serves, Box<dyn Output>)>> {
    let library = config.core().sequences();
    let computer = library.iter().any(|e| match e.target {
        Target::Mode(mode) => mode.is_pointer(),
        Target::Home(_) => false,
        _ => true,
    });
    let events: Vec<HomeEvent> = library
        .iter()
        .filter_map(|e| match e.target {
            Target::Home(event) => Some(event),
            _ => None,
        })
        .collect();
    let given = |kind: &str| specs.iter().any(|s| s.kind() == kind);
    if computer && !given("uinput") {
        note!(
            "sipnpuff: the library types keys, clicks or moves the pointer, but no `--output uinput` is given: those entries will do nothing"
        );
    }
    if !events.is_empty() && !given("mqtt") {
        note!(
            "sipnpuff: the library sends home events, but no `--output mqtt` is given: they will go nowhere"
        );
    }
    let mut opened: Vec<(Serves, Box<dyn Output>)> = Vec::new();
    for (i, spec) in specs.iter().enumerate() {
        if specs[..i].iter().any(|s| s.kind() == spec.kind()) {
            anyhow::bail!("--output {}: given twice", spec.kind());
        }
        opened.push(match spec {
            OutputSpec::Uinput => (Serves::Computer, open_uinput(config)?),
            OutputSpec::Mqtt { address } => {
                let mut settings = config.output().mqtt.clone();
                if let Some((host, port)) = address {
                    settings.host = host.clone();
                    settings.port = *port;
                }
                (Serves::Home, open_mqtt(&settings, &events)?)
            }
        });
    }
    Ok(opened)
}

/// `--output uinput`.
fn open_uinput(config: &Config) -> anyhow::Result<Box<dyn Output>> {
    Ok(Box::new(UinputOutput::open(&config.output().uinput)?))
}

/// `--output mqtt`: connects now, so a wrong address, a broker that is
/// down or refused credentials stop the run before it starts.
#[cfg(feature = "mqtt")]
fn open_mqtt(settings: &MqttSettings, events: &[HomeEvent]) -> anyhow::Result<Box<dyn Output>> {
    Ok(Box::new(MqttOutput::open(settings, events)?))
}

/// `--output mqtt` in a build without it.
#[cfg(not(feature = "mqtt"))]
fn open_mqtt(_settings: &MqttSettings, _events: &[HomeEvent]) -> anyhow::Result<Box<dyn Output>> {
    anyhow::bail!("--output mqtt: this sipnpuff was built without the `mqtt` feature")
}

/// Runs the loop with the chosen sensor and arm; prints events as they
/// happen, then the report. Returns the exit status ([`output`]): 0
/// completed, 1 failed, 128 + N stopped by signal N, 141 stdout's reader
/// went away. If stdout fails, the arm is stopped safely and the report
/// goes to stderr.
pub fn run(args: RunArgs) -> anyhow::Result<u8> {
    let config = with_interface(args.config.load()?, args.interface)?;
    if let Some(dir) = &args.histogram_dir {
        writable_dir(dir)?;
    }
    // The directory is checked now; the recording starts with the
    // configuration the core gets (a device's measured neutral in it).
    if let Some(dir) = &args.record {
        invalid(check_dir(dir).map_err(|e| anyhow::Error::new(e).context("--record")))?;
    }
    let record = args.record.as_deref().map(|dir| Record {
        dir,
        options: RecordOptions {
            max_bytes: args.record_max_mb,
            ..RecordOptions::default()
        },
    });
    let record = record.as_ref();
    let options = LoopSettings {
        seconds: args.seconds,
        rt: args.rt.options()?,
        spin_margin_ns: args.rt.spin_margin_ns(),
        stop: stop_request()?,
    };
    // The page's address is taken before anything starts: a clash is an
    // error now, not a display missing later.
    let display = Display::open(&args.display)?;
    let display = &display;
    // The backends, one line each; the outputs opened before anything
    // starts (a missing device or an unreachable address is said now).
    let arm = open_arm(&args.arm, &config)?;
    let outputs = open_outputs(&args.outputs, &config)?;
    let mut events = StdoutEvents {
        quiet: args.display.tui,
        ..StdoutEvents::default()
    };
    let start = Start {
        arm,
        outputs,
        settings: &options,
        events: &mut events,
        record,
        display,
    };
    let report = open_sensor(
        &args.sensor,
        &config,
        || SyntheticSensor::built_in_user(&config),
        start,
    )?;
    let text = if args.json {
        serde_json::to_string(&report)? + "\n"
    } else {
        report.to_text()
    };
    // The report on stdout while it works; on stderr, saying why, if not.
    let mut stdout_failed = events.failed;
    let why = match (&report.output_error, stdout_failed) {
        (Some(error), _) if report.stop_reason == StopReason::OutputFailed => Some(format!(
            "stdout failed ({error}): stopped printing and stopped the arm safely"
        )),
        (Some(error), _) => Some(format!("stdout failed ({error}): stopped printing")),
        (None, Some(kind)) => Some(format!("stdout failed ({kind})")),
        (None, None) => match output::stdout(&text) {
            Ok(()) => None,
            Err(e) => {
                stdout_failed = Some(e.kind());
                Some(format!("stdout failed ({e}) while printing the report"))
            }
        },
    };
    if let Some(why) = why {
        note!("sipnpuff: {why}; the report follows on stderr");
        output::progress(format_args!("{text}"));
    }
    let mut histograms_failed = false;
    if let Some(dir) = &args.histogram_dir {
        match report.write_histograms(dir) {
            Ok(paths) => {
                for path in paths {
                    note!("wrote {}", path.display());
                }
            }
            Err(e) => {
                note!("error: --histogram-dir {}: {e}", dir.display());
                histograms_failed = true;
            }
        }
    }
    let recording_failed = report.recording.as_ref().is_some_and(|r| r.error.is_some());
    let status = exit_status(&report, stdout_failed);
    Ok(
        if (histograms_failed || recording_failed) && status == output::COMPLETED {
            output::FAILED
        } else {
            status
        },
    )
}

/// `--record DIR`, checked.
struct Record<'a> {
    dir: &'a Path,
    options: RecordOptions,
}

/// What runs on the sensor `--sensor` opened, whatever its type: `run`
/// and `fit` open sensors alike.
pub trait OnSensor {
    /// What it gives back.
    type Output;

    /// Runs on `sensor`; `config` is the configuration in effect (with a
    /// device's measured neutral).
    fn on<S: Sensor>(self, config: &Config, sensor: S) -> anyhow::Result<Self::Output>;
}

/// Opens the `--sensor` backend and runs `on` on it: `synthetic` is the
/// command's scripted user (`synthetic()`); a device is started and, if
/// analog, its neutral measured first ([`prepare_device`]).
pub fn open_sensor<O: OnSensor>(
    spec: &SensorSpec,
    config: &Config,
    synthetic: impl FnOnce() -> SyntheticSensor,
    on: O,
) -> anyhow::Result<O::Output> {
    let settings = config.sensor();
    let neutral = config.core().detector().neutral_volts;
    match spec {
        SensorSpec::Synthetic => on.on(config, synthetic()),
        SensorSpec::Csv(path) => on.on(config, CsvSensor::open(path)?),
        SensorSpec::Evdev(target) => {
            let sensor = EvdevSensor::open(target, &settings.evdev, neutral, settings.reconnect)?;
            let analog = sensor.is_analog();
            let (config, sensor) = prepare_device(config, sensor, analog)?;
            on.on(&config, sensor)
        }
        SensorSpec::Serial { path, baud } => {
            let sensor =
                SerialSensor::open(path, *baud, &settings.serial, neutral, settings.reconnect)?;
            let detector = config.core().detector();
            if let Some(note) = sensor.rate_note(detector.min_burst_ms, detector.long_burst_ms) {
                note!("sipnpuff: {note}");
            }
            let (config, sensor) = prepare_device(config, sensor, true)?;
            on.on(&config, sensor)
        }
        SensorSpec::Iio(path) => {
            let sensor = IioSensor::open(path, &settings.iio, settings.reconnect)?;
            let (config, sensor) = prepare_device(config, sensor, true)?;
            on.on(&config, sensor)
        }
    }
}

/// `run` on the sensor opened: the loop on it, the core built from the
/// configuration in effect, with the display and the recording asked
/// for: the recording ends before the report is printed, its summary in
/// the report (and its `report.json`); the terminal view gives the
/// terminal back before it.
struct Start<'a> {
    arm: Box<dyn Arm>,
    outputs: Vec<(Serves, Box<dyn Output>)>,
    settings: &'a LoopSettings,
    events: &'a mut StdoutEvents,
    record: Option<&'a Record<'a>>,
    display: &'a Display,
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
        if let Some(recorder) = recorder {
            recorder.finish(&mut report);
        }
        Ok(report)
    }
}

/// `--record-max-mb`: a positive number of megabytes (10^6 bytes), at
/// least 0.001 (the streams' headers and ends), as bytes.
fn parse_megabytes(text: &str) -> Result<u64, String> {
    let mb: f64 = text
        .parse()
        .map_err(|_| format!("{text:?} is not a number of megabytes"))?;
    let bytes = mb * 1e6;
    if bytes.is_finite() && bytes >= MIN_BYTES as f64 && bytes <= u64::MAX as f64 {
        Ok(bytes.round() as u64)
    } else {
        Err(format!(
            "{text} MB: must be at least {} MB",
            MIN_BYTES as f64 / 1e6
        ))
    }
}

/// Starts a device and, if it is analog and `[sensor] rezero` is on,
/// measures its neutral at rest before anything can move (waiting, and
/// saying why, while the user breathes into it). Returns the configuration
/// with the measured neutral (the thresholds keep their distances from
/// it) and the started device, described with what was measured.
fn prepare_device<S: Sensor>(
    config: &Config,
    sensor: S,
    analog: bool,
) -> anyhow::Result<(Config, Prepared<S::Samples>)> {
    let mut description = sensor.describe();
    let mut started = sensor.start()?;
    let settings = config.sensor();
    if !(analog && settings.rezero) {
        return Ok((
            config.clone(),
            Prepared {
                description,
                started,
            },
        ));
    }
    note!(
        "sipnpuff: measuring the sensor's neutral for {} ms: please rest (no sip or puff)",
        settings.rezero_ms
    );
    let neutral = rezero::measure(
        &mut started.samples,
        settings,
        config.core().detector(),
        |why| note!("sipnpuff: {why}"),
    )?;
    note!("sipnpuff: {neutral}");
    let config = config
        .clone()
        .with_neutral_volts(neutral.volts)
        .map_err(|errors| {
            anyhow::anyhow!(
                "the measured neutral {:.4} V puts a detector threshold outside 0–5 V: check the sensor's mapping ([sensor.evdev] volts_at_min/max, [sensor.serial] full_scale/volts_per_hpa, [sensor.iio] gain/offset_volts):\n{errors}",
                neutral.volts
            )
        })?;
    description += &format!("; {neutral}");
    Ok((
        config,
        Prepared {
            description,
            started,
        },
    ))
}

/// The exit status of a finished run whose stdout failed with
/// `stdout_failed`, if it did. A fault, or a safe stop that did not end
/// the stream with a zero command, is a failure whatever stopped the run;
/// otherwise the status says what stopped it: a signal (128 + N), the
/// reader of stdout gone (141), another failed output (1), or the run's
/// own end (0, or the output's status if the report could not be
/// printed).
pub fn exit_status(report: &RunReport, stdout_failed: Option<io::ErrorKind>) -> u8 {
    let output_status = |kind: Option<io::ErrorKind>| match kind {
        Some(io::ErrorKind::BrokenPipe) => output::BROKEN_PIPE,
        Some(_) => output::FAILED,
        None => output::COMPLETED,
    };
    if !report.errors.is_empty() || !report.stream_ended_with_zero {
        return output::FAILED;
    }
    match report.stop_reason {
        StopReason::Signal(n) => output::interrupted(n),
        StopReason::ArmFault | StopReason::Running => output::FAILED,
        StopReason::OutputFailed => match stdout_failed {
            None => output::FAILED,
            kind => output_status(kind),
        },
        StopReason::Time | StopReason::SensorEnded | StopReason::Finished => {
            output_status(stdout_failed)
        }
    }
}

/// A stop request that every stop signal sets ([`signals`]): from here on
/// SIGINT, SIGTERM, SIGHUP, SIGQUIT and the others stop the run safely;
/// a repeated signal does not cut the safe stop short.
pub fn stop_request() -> anyhow::Result<StopRequest> {
    let stop = StopRequest::new();
    signals::install(&stop).context("cannot install the signal handlers")?;
    Ok(stop)
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::arm::sim::SimArm;

    /// A real report of a short run, to vary.
    fn report() -> RunReport {
        let config = Config::default();
        let settings = LoopSettings::plain(0.05);
        let sensor = SyntheticSensor::built_in_user(&config);
        let arm = Box::new(SimArm::new(config.core()));
        threads::run(config.core(), RunOptions::new(sensor, arm, settings)).unwrap()
    }

    #[test]
    fn exit_statuses_say_what_stopped_the_run_and_faults_win() {
        let base = report();
        assert_eq!(base.stop_reason, StopReason::Time);
        let with = |reason: StopReason, errors: &[&str], zero: bool| RunReport {
            stop_reason: reason,
            errors: errors.iter().map(|e| e.to_string()).collect(),
            stream_ended_with_zero: zero,
            ..base.clone()
        };
        let pipe = Some(io::ErrorKind::BrokenPipe);
        let full = Some(io::ErrorKind::StorageFull);
        let table = [
            (with(StopReason::Time, &[], true), None, 0),
            (with(StopReason::SensorEnded, &[], true), None, 0),
            (
                with(StopReason::SensorEnded, &["sensor: bad row"], true),
                None,
                1,
            ),
            (with(StopReason::ArmFault, &["arm refused"], true), None, 1),
            (with(StopReason::Signal(libc::SIGHUP), &[], true), None, 129),
            (with(StopReason::Signal(libc::SIGINT), &[], true), full, 130),
            (
                with(StopReason::Signal(libc::SIGQUIT), &[], true),
                None,
                131,
            ),
            (
                with(StopReason::Signal(libc::SIGTERM), &[], true),
                None,
                143,
            ),
            (
                with(StopReason::Signal(libc::SIGTERM), &["arm"], true),
                None,
                1,
            ),
            (with(StopReason::Signal(libc::SIGTERM), &[], false), None, 1),
            (with(StopReason::OutputFailed, &[], true), pipe, 141),
            (with(StopReason::OutputFailed, &[], true), full, 1),
            (with(StopReason::Time, &[], true), pipe, 141),
            (with(StopReason::Time, &[], true), full, 1),
        ];
        for (report, failed, status) in table {
            assert_eq!(
                exit_status(&report, failed),
                status,
                "{} {:?} {:?}",
                report.stop_reason,
                report.errors,
                failed
            );
        }
    }
}
