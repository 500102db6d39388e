//! Options several commands share, parsed and checked before anything
//! runs: a bad value is an error at start, naming the choices or the
//! range, never a surprise after a 20 s run.

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::ValueEnum;

use crate::arm::ArmSpec;
use crate::cli::output::invalid;
use crate::config::Config;
use crate::config::layers::Layered;
use crate::config::realtime::RtSettings;
use crate::control::selection::Interface;
use crate::output::OutputSpec;
use crate::rt::setup::{RtOptions, ServingPriorities, machine_cpus};
use crate::rt::signals;
use crate::rt::threads::LoopSettings;
use crate::sensor::SensorSpec;
use crate::tools::recording::recorder::check_dir;

/// `--config FILE`, as often as needed: a person's setup from several
/// files (a profile, then a library, …), read by [`Layered::read`].
#[derive(clap::Args, Clone, Debug)]
pub struct ConfigArg {
    /// TOML configuration (default: built-in; `sipnpuff config` prints it).
    /// Give it again to layer files: a later file overrides an earlier one
    /// key by key, and a later library (`[[sequence]]`) replaces the whole
    /// library.
    #[arg(long, value_name = "FILE", action = clap::ArgAction::Append)]
    pub config: Vec<PathBuf>,
}

impl ConfigArg {
    /// The files' configuration, or the built-in one. An error is an
    /// invalid configuration (exit status 2).
    pub fn load(&self) -> anyhow::Result<Config> {
        self.layered().map(Layered::into_config)
    }

    /// The files' configuration with the file each setting came from.
    pub fn layered(&self) -> anyhow::Result<Layered> {
        invalid(Layered::read(&self.config).map_err(anyhow::Error::from))
    }

    /// Whether any file was given.
    pub fn given(&self) -> bool {
        !self.config.is_empty()
    }
}

/// The backends a run reads and drives: `--sensor`, `--imu`, `--arm`,
/// `--output`. Each may also come from the environment
/// (`SIPNPUFF_SENSOR`, `SIPNPUFF_IMU`, `SIPNPUFF_ARM`, `SIPNPUFF_OUTPUTS`
/// as a comma-separated list): the service's `/etc/default/sipnpuff`.
#[derive(clap::Args, Clone, Debug)]
pub struct BackendArgs {
    /// Where samples come from: `synthetic` (the built-in scripted user),
    /// `synthetic:NAME` (a built-in breather, e.g. `tremor_4hz`, in two
    /// minutes of ordinary use of the library; `sipnpuff generate --help`
    /// lists them), `csv:PATH` (a recording played in real time), or a
    /// device:
    /// `evdev:/dev/input/eventN` or `evdev:name=SUBSTRING` (a USB HID
    /// sip-and-puff device: an analog axis or switches), `serial:PATH[,baud=N]`
    /// (a microcontroller's stream, FLipMouse or LipSync), or
    /// `iio:/sys/bus/iio/devices/iio:deviceN/in_voltageM_raw` (an ADC).
    /// Device settings: `[sensor]` in the config (`sipnpuff sensors`
    /// lists what this machine has).
    #[arg(long, default_value = "synthetic", env = "SIPNPUFF_SENSOR", value_parser = SensorSpec::parse)]
    pub sensor: SensorSpec,
    /// A head-worn IMU read beside the breath sensor, so the library may
    /// mix breaths and gestures (`[gestures] set` in the config):
    /// `evdev:name=SUBSTRING` or `evdev:/dev/input/eventN` (an input
    /// device with the accelerometer property), `iio:/sys/bus/iio/devices/iio:deviceN`,
    /// `serial:PATH[,baud=N]` (lines `ax,ay,az,gx,gy,gz`) or `csv:IMU.csv`
    /// (a recording played live). For the IMU alone, give it as --sensor.
    #[arg(long, value_name = "SENSOR", env = "SIPNPUFF_IMU", value_parser = SensorSpec::parse)]
    pub imu: Option<SensorSpec>,
    /// The arm: `sim` (the simulated JACO2), `ros2:TOPIC` (MoveIt Servo,
    /// ros2_kortex's twist controller, a JACO2 ROS 2 port), `ros1:NAMESPACE`
    /// (kinova-ros's driver, e.g. `ros1:/j2n6s300_driver`; the master from
    /// `ROS_MASTER_URI`) or `kinova-sdk:usb|eth` (Kinova's own library).
    /// Settings: `[arm]` in the config (docs/arms.md).
    #[arg(long, default_value = "sim", env = "SIPNPUFF_ARM", value_parser = ArmSpec::parse)]
    pub arm: ArmSpec,
    /// Also drive the computer or the home (repeatable): `uinput` (a
    /// virtual keyboard and pointer through /dev/uinput: the library's
    /// `key`, `click`, pointer modes and `drag`; settings in
    /// `[output.uinput]`) or `mqtt` / `mqtt:HOST:PORT` (Home Assistant
    /// over MQTT: the library's `event`s; settings in `[output.mqtt]`).
    /// Set-up for each, the udev rule and a Home Assistant automation:
    /// docs/outputs.md.
    #[arg(long = "output", value_name = "OUTPUT", env = "SIPNPUFF_OUTPUTS", value_delimiter = ',', value_parser = OutputSpec::parse)]
    pub outputs: Vec<OutputSpec>,
}

/// `--interface asp|bsp`.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum InterfaceArg {
    /// Sequences matched against the library (the paper's interface).
    Asp,
    /// The modes scroll; a puff enters the highlighted one (the baseline).
    Bsp,
}

impl From<InterfaceArg> for Interface {
    fn from(arg: InterfaceArg) -> Interface {
        match arg {
            InterfaceArg::Asp => Interface::Asp,
            InterfaceArg::Bsp => Interface::Bsp,
        }
    }
}

/// The config with the `--interface` choice, if given.
pub fn with_interface(config: Config, interface: Option<InterfaceArg>) -> anyhow::Result<Config> {
    match interface {
        None => Ok(config),
        Some(arg) => invalid(
            config
                .with_interface(arg.into())
                .map_err(anyhow::Error::from),
        ),
    }
}

/// A positive, finite number of seconds.
pub fn parse_seconds(text: &str) -> Result<f64, String> {
    let seconds: f64 = text
        .parse()
        .map_err(|_| format!("{text:?} is not a number of seconds"))?;
    if seconds.is_finite() && seconds > 0.0 {
        Ok(seconds)
    } else {
        Err(format!("{text} s: must be a positive number of seconds"))
    }
}

/// A finite level in volts, 0 or more.
pub fn parse_volts(text: &str) -> Result<f64, String> {
    let volts: f64 = text
        .parse()
        .map_err(|_| format!("{text:?} is not a number of volts"))?;
    if volts.is_finite() && volts >= 0.0 {
        Ok(volts)
    } else {
        Err(format!("{text} V: must be finite and 0 or more"))
    }
}

/// Real-time settings of the control thread, over the configuration's
/// `[rt]`.
#[derive(clap::Args, Clone, Debug)]
pub struct RtArgs {
    /// SCHED_FIFO priority of the control thread (1–99; 0: don't ask);
    /// the sensor, arm and uinput threads get 10, 20 and 30 less
    /// (default: `[rt]`, 80, 70, 60, 50).
    #[arg(long, value_parser = clap::value_parser!(i32).range(0..=99))]
    pub priority: Option<i32>,
    /// CPU to pin the control thread to (default: `[rt] control_cpu`, or
    /// the last one).
    #[arg(long)]
    pub cpu: Option<usize>,
    /// Don't lock memory (mlockall).
    #[arg(long)]
    pub no_mlock: bool,
    /// Hybrid wait: sleep until this many µs before each deadline, then
    /// spin (1–999: less than the 1 ms period).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..1000))]
    pub spin_margin_us: Option<u64>,
}

impl RtArgs {
    /// The settings to ask for: the configuration's `[rt]`, these options
    /// over it; an error if a CPU does not exist on this machine.
    pub fn options(&self, rt: &RtSettings) -> anyhow::Result<RtOptions> {
        let defaults = RtOptions::default();
        let ids = machine_cpus();
        let missing = |what: String, cpu: usize| {
            invalid(Err(anyhow::anyhow!(
                "{what}: no such CPU {cpu} (this machine has CPUs {ids:?})"
            )))
        };
        if let Some(cpu) = self.cpu.filter(|cpu| !ids.contains(cpu)) {
            return missing(format!("--cpu {cpu}"), cpu);
        }
        if self.cpu.is_none()
            && let Some(cpu) = rt.control_cpu.filter(|cpu| !ids.contains(cpu))
        {
            return missing(format!("[rt] control_cpu = {cpu}"), cpu);
        }
        if let Some(&cpu) = rt.serving_cpus.iter().find(|cpu| !ids.contains(cpu)) {
            return missing(format!("[rt] serving_cpus = {:?}", rt.serving_cpus), cpu);
        }
        let priority = |p: i32| (p > 0).then_some(p);
        let (fifo_priority, serving) = match self.priority {
            Some(control) => (
                priority(control),
                ServingPriorities::below(priority(control)),
            ),
            None => (
                priority(rt.control_priority),
                ServingPriorities {
                    sensor: priority(rt.sensor_priority),
                    arm: priority(rt.arm_priority),
                    output: priority(rt.output_priority),
                },
            ),
        };
        let cpu = self.cpu.or(rt.control_cpu).or(defaults.cpu);
        let serving_cpus = rt
            .serving_cpus
            .iter()
            .copied()
            .filter(|&id| Some(id) != cpu)
            .collect();
        Ok(RtOptions {
            fifo_priority,
            cpu,
            lock_memory: !self.no_mlock,
            serving,
            serving_cpus,
            ..defaults
        })
    }

    /// The hybrid-wait margin, ns.
    fn spin_margin_ns(&self) -> Option<u64> {
        self.spin_margin_us.map(|us| us * 1000)
    }

    /// The loop's settings: these, `seconds` long (`None`: until the
    /// sensor ends), stopped safely from here on by every stop signal.
    pub fn loop_settings(
        &self,
        seconds: Option<f64>,
        rt: &RtSettings,
    ) -> anyhow::Result<LoopSettings> {
        Ok(LoopSettings {
            seconds,
            rt: self.options(rt)?,
            spin_margin_ns: self.spin_margin_ns(),
            stop: signals::stop_request().context("cannot install the signal handlers")?,
        })
    }
}

/// Checks, before a run, that a session can be recorded into `dir`
/// (`--record`): never over a recording.
pub fn record_dir(dir: &Path) -> anyhow::Result<()> {
    invalid(check_dir(dir).map_err(|e| anyhow::Error::new(e).context("--record")))
}

/// Checks, before a run, that histograms can be written into `dir`
/// (created if missing).
pub fn writable_dir(dir: &Path) -> anyhow::Result<()> {
    invalid(writable(dir))
}

fn writable(dir: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("--histogram-dir {}: cannot create it", dir.display()))?;
    let probe = dir.join(format!(".sipnpuff-write-test-{}", std::process::id()));
    std::fs::write(&probe, b"")
        .with_context(|| format!("--histogram-dir {}: cannot write into it", dir.display()))?;
    std::fs::remove_file(&probe).ok();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_checked() {
        assert_eq!(parse_seconds("2.5"), Ok(2.5));
        for bad in ["0", "-1", "inf", "NaN", "x"] {
            assert!(parse_seconds(bad).is_err(), "{bad}");
        }
        assert_eq!(parse_volts("0"), Ok(0.0));
        assert!(parse_volts("-0.1").is_err());
    }

    fn rt_args(priority: Option<i32>, cpu: Option<usize>) -> RtArgs {
        RtArgs {
            priority,
            cpu,
            no_mlock: false,
            spin_margin_us: None,
        }
    }

    #[test]
    fn the_configurations_rt_section_sets_every_thread_and_options_override_it() {
        let cpus = machine_cpus();
        let first = cpus[0];
        let rt = RtSettings {
            control_priority: 90,
            sensor_priority: 85,
            arm_priority: 0,
            output_priority: 40,
            control_cpu: Some(first),
            serving_cpus: Vec::new(),
        };
        let options = rt_args(None, None).options(&rt).unwrap();
        assert_eq!(options.fifo_priority, Some(90));
        assert_eq!(
            options.serving,
            ServingPriorities {
                sensor: Some(85),
                arm: None,
                output: Some(40)
            }
        );
        assert_eq!(options.cpu, Some(first));
        let others: Vec<usize> = cpus.iter().copied().filter(|&c| c != first).collect();
        assert_eq!(
            options.serving_cpu_list(),
            (!others.is_empty()).then_some(others)
        );
        // --priority: the control thread there, the others 10, 20, 30 below.
        let options = rt_args(Some(60), None).options(&rt).unwrap();
        assert_eq!(options.fifo_priority, Some(60));
        assert_eq!(options.serving, ServingPriorities::below(Some(60)));
        // A CPU this machine lacks is named with its key.
        let absent = cpus.iter().max().unwrap() + 1;
        let lacking = RtSettings {
            control_cpu: Some(absent),
            ..RtSettings::default()
        };
        let e = rt_args(None, None)
            .options(&lacking)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with(&format!("[rt] control_cpu = {absent}: no such CPU")),
            "{e}"
        );
        let e = rt_args(Some(80), Some(absent)).options(&RtSettings::default());
        assert!(
            e.unwrap_err()
                .to_string()
                .starts_with(&format!("--cpu {absent}"))
        );
        let given = RtSettings {
            serving_cpus: vec![first],
            control_cpu: None,
            ..RtSettings::default()
        };
        let options = rt_args(None, Some(absent - 1)).options(&given).unwrap();
        if absent - 1 != first {
            assert_eq!(options.serving_cpu_list(), Some(vec![first]));
        }
    }
}
