//! The sensor `--sensor` names ([`SensorSpec`]), opened and handed,
//! whatever its type, to what runs on it ([`OnSensor`]): a device is
//! started and, if analog, its neutral measured at rest first.

use crate::config::Config;
use crate::sensor::csv::CsvSensor;
use crate::sensor::evdev::EvdevSensor;
use crate::sensor::iio::IioSensor;
use crate::sensor::rezero;
use crate::sensor::serial::SerialSensor;
use crate::sensor::{Prepared, Sensor, SensorSpec};

/// What runs on the sensor opened, whatever its type (`run`'s session
/// and the live calibration open sensors alike).
pub trait OnSensor {
    /// What it gives back.
    type Output;

    /// Runs on `sensor`; `config` is the configuration in effect (with a
    /// device's measured neutral).
    fn on<S: Sensor>(self, config: &Config, sensor: S) -> anyhow::Result<Self::Output>;
}

/// Opens the `--sensor` backend and runs `on` on it: `synthetic` and
/// `synthetic:NAME` are the caller's scripted user (`synthetic(config,
/// name)`, which may set the configuration's neutral to the user's rest
/// level, as a device's is measured); a device is started and, if
/// analog, its neutral measured first (`prepare_device`), saying
/// (`say`) what it waits for.
pub fn open_sensor<O: OnSensor, Synthetic: Sensor>(
    spec: &SensorSpec,
    config: &Config,
    synthetic: impl FnOnce(&Config, Option<&str>) -> anyhow::Result<(Config, Synthetic)>,
    on: O,
    say: &dyn Fn(&str),
) -> anyhow::Result<O::Output> {
    let settings = config.sensor();
    let neutral = config.core().detector().neutral_volts;
    match spec {
        SensorSpec::Synthetic(name) => {
            let (config, sensor) = synthetic(config, name.as_deref())?;
            on.on(&config, sensor)
        }
        SensorSpec::Csv(path) => on.on(config, CsvSensor::open(path)?),
        SensorSpec::Evdev(target) => {
            let sensor = EvdevSensor::open(target, &settings.evdev, neutral, settings.reconnect)?;
            let analog = sensor.is_analog();
            let (config, sensor) = prepare_device(config, sensor, analog, say)?;
            on.on(&config, sensor)
        }
        SensorSpec::Serial { path, baud } => {
            let sensor =
                SerialSensor::open(path, *baud, &settings.serial, neutral, settings.reconnect)?;
            let detector = config.core().detector();
            if let Some(note) = sensor.rate_note(detector.min_burst_ms, detector.long_burst_ms) {
                say(&format!("sipnpuff: {note}"));
            }
            let (config, sensor) = prepare_device(config, sensor, true, say)?;
            on.on(&config, sensor)
        }
        SensorSpec::Iio(path) => {
            let sensor = IioSensor::open(path, &settings.iio, settings.reconnect)?;
            let (config, sensor) = prepare_device(config, sensor, true, say)?;
            on.on(&config, sensor)
        }
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
    say: &dyn Fn(&str),
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
    say(&format!(
        "sipnpuff: measuring the sensor's neutral for {} ms: please rest (no sip or puff)",
        settings.rezero_ms
    ));
    let neutral = rezero::measure(
        &mut started.samples,
        settings,
        config.core().detector(),
        |why| say(&format!("sipnpuff: {why}")),
    )?;
    say(&format!("sipnpuff: {neutral}"));
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
