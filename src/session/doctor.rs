//! `sipnpuff doctor`: what `run` with the same configuration, backends and
//! real-time options would get here, as the user running it, and what it
//! would be denied, each denial with its fix. Run as the service's user
//! under the service's limits, it says before the first start what the
//! service lacks.
//!
//! Every check does what `run` does, without moving anything: the
//! real-time set-up is applied to a scratch thread (and undone), each
//! device is opened (not started, so no re-zero), `/dev/uinput` opened for
//! writing, the broker's port connected to, the page's address bound.

use std::net::{SocketAddr, TcpListener, TcpStream, ToSocketAddrs};
use std::time::Duration;

use crate::arm::{ArmSpec, ThreadRef};
use crate::config::Config;
use crate::output::OutputSpec;
use crate::rt::setup::{
    RtOptions, RtSetting, lock_process_memory, setup_current_thread, setup_serving_thread,
};
use crate::sensor::csv::CsvSensor;
use crate::sensor::evdev::EvdevSensor;
use crate::sensor::iio::IioSensor;
use crate::sensor::serial::SerialSensor;
use crate::sensor::{Sensor, SensorSpec};
use crate::session::run::{Beside, imu_sensor};

/// One thing checked.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct Check {
    /// What, e.g. `SCHED_FIFO priority 80` or `sensor evdev:name=Breeze`.
    pub what: String,
    /// Granted, reachable, opened.
    pub ok: bool,
    /// A deployed controller needs it: missing, the exit status is 1.
    pub needed: bool,
    /// What was found: a device's description, or the refusal.
    pub detail: String,
    /// What grants it, when it is missing.
    pub fix: Option<String>,
}

impl Check {
    fn new(
        what: impl Into<String>,
        needed: bool,
        result: Result<String, (String, String)>,
    ) -> Check {
        let (ok, detail, fix) = match result {
            Ok(detail) => (true, detail, None),
            Err((detail, fix)) => (false, detail, Some(fix)),
        };
        Check {
            what: what.into(),
            ok,
            needed,
            detail,
            fix,
        }
    }
}

/// What to examine: `run`'s backends and real-time options.
pub struct Examined<'a> {
    /// `--sensor`.
    pub sensor: &'a SensorSpec,
    /// `--imu`.
    pub imu: Option<&'a SensorSpec>,
    /// `--arm`.
    pub arm: &'a ArmSpec,
    /// `--output`, each.
    pub outputs: &'a [OutputSpec],
    /// The control thread's priority, CPU and memory locking.
    pub rt: RtOptions,
    /// The page's address, unless `--no-display`.
    pub page: Option<SocketAddr>,
}

/// Every check, in the order a run meets them.
pub fn examine(config: &Config, examined: &Examined) -> Vec<Check> {
    // The threads the loop would wait on: a device's or a recording's
    // reader (the synthetic user is computed in the loop), the arm's
    // streamer, a uinput output's writer.
    let serving = examined.rt.serving;
    let mut threads = Vec::new();
    if !matches!(examined.sensor, SensorSpec::Synthetic(_)) || examined.imu.is_some() {
        threads.push(("sensor", serving.sensor));
    }
    threads.push(("arm", serving.arm));
    if examined.outputs.contains(&OutputSpec::Uinput) {
        threads.push(("output uinput", serving.output));
    }
    let mut checks = real_time(&examined.rt, &threads);
    checks.extend(sensors(config, examined));
    checks.push(arm(examined.arm));
    for output in examined.outputs {
        checks.push(match output {
            OutputSpec::Uinput => uinput(),
            OutputSpec::Mqtt { address } => {
                let mqtt = &config.output().mqtt;
                let (host, port) = address
                    .clone()
                    .unwrap_or_else(|| (mqtt.host.clone(), mqtt.port));
                broker(&host, port, mqtt.credentials_file.as_deref())
            }
        });
    }
    if let Some(page) = examined.page {
        checks.push(display(page));
    }
    checks
}

/// A resource limit's soft value, as text (`unlimited`).
fn limit(resource: libc::__rlimit_resource_t) -> String {
    let mut value = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: `value` is a valid rlimit to fill.
    if unsafe { libc::getrlimit(resource, &mut value) } != 0 {
        return "unknown".into();
    }
    if value.rlim_cur == libc::RLIM_INFINITY {
        "unlimited".into()
    } else {
        value.rlim_cur.to_string()
    }
}

/// The real-time set-up `run` applies to its process and its control
/// thread, applied to a scratch thread (the memory lock undone after).
fn real_time(options: &RtOptions, threads: &[(&str, Option<i32>)]) -> Vec<Check> {
    let control = options.clone();
    let mut setup = std::thread::spawn(move || {
        let mut settings = Vec::new();
        if control.lock_memory {
            settings.push(lock_process_memory());
        }
        settings.extend(setup_current_thread(&control).settings);
        settings
    })
    .join()
    .unwrap_or_default();
    // SAFETY: munlockall has no preconditions; this process needs no lock.
    unsafe { libc::munlockall() };
    setup.extend(serving_threads(threads, options.serving_cpu_list()));
    let rtprio = limit(libc::RLIMIT_RTPRIO);
    let memlock = limit(libc::RLIMIT_MEMLOCK);
    setup
        .into_iter()
        .filter(|s| !s.name.starts_with("pre-faulted"))
        .map(|s| {
            let (needed, fix) = if s.name.contains("SCHED_FIFO") {
                (
                    true,
                    format!(
                        "its RLIMIT_RTPRIO is {rtprio}: the service's unit grants it (LimitRTPRIO=); as another user, run as root or raise `rtprio` in /etc/security/limits.d/"
                    ),
                )
            } else if s.name.starts_with("mlockall") {
                (
                    true,
                    format!(
                        "its RLIMIT_MEMLOCK is {memlock} bytes: the service's unit grants it (LimitMEMLOCK=infinity); as another user, run as root or raise `memlock` in /etc/security/limits.d/"
                    ),
                )
            } else if s.name.starts_with("pinned") || s.name.contains(": CPUs") {
                (
                    true,
                    "the CPU is outside this process's affinity: allow it (the unit's CPUAffinity=, taskset) or pick another with --cpu".to_string(),
                )
            } else if s.name.starts_with("PREEMPT_RT") {
                (
                    false,
                    "install Debian's PREEMPT_RT kernel (apt install linux-image-rt-amd64) and boot it".to_string(),
                )
            } else if s.name.starts_with("/dev/cpu_dma_latency") {
                (
                    false,
                    "optional (it keeps the CPUs out of deep sleep states): run as root, or give the device to the user with a udev rule, KERNEL==\"cpu_dma_latency\", GROUP=\"sipnpuff\", MODE=\"0660\"".to_string(),
                )
            } else {
                (false, String::new())
            };
            Check::new(
                s.name,
                needed,
                if s.granted {
                    Ok(s.detail)
                } else {
                    Err((s.detail, fix))
                },
            )
        })
        .collect()
}

/// The priorities `run` gives the threads its loop waits on (`threads`:
/// name and priority), applied to a scratch thread in turn; their CPUs
/// once, as the first's.
fn serving_threads(threads: &[(&str, Option<i32>)], cpus: Option<Vec<usize>>) -> Vec<RtSetting> {
    use std::os::unix::thread::JoinHandleExt;
    let (done, wait) = std::sync::mpsc::channel::<()>();
    let scratch = std::thread::spawn(move || {
        let _ = wait.recv();
    });
    let mut settings = Vec::new();
    for (i, &(name, priority)) in threads.iter().enumerate() {
        let applied = setup_serving_thread(
            ThreadRef::Pthread(scratch.as_pthread_t()),
            name,
            priority,
            cpus.as_deref(),
        );
        settings.extend(
            applied
                .into_iter()
                .filter(|s| i == 0 || !s.name.contains(": CPUs")),
        );
    }
    drop(done);
    let _ = scratch.join();
    settings
}

/// The sensors `run` would read, opened as it opens them (not started).
fn sensors(config: &Config, examined: &Examined) -> Vec<Check> {
    let what = |spec: &SensorSpec| format!("sensor {spec}");
    let refused = |e: anyhow::Error| {
        (
            format!("{e:#}"),
            "as the error says; `sipnpuff sensors` lists this machine's sensors with their --sensor lines, docs/sensors.md their permissions".to_string(),
        )
    };
    let mut checks = Vec::new();
    let breath = match imu_sensor(config, examined.sensor, examined.imu) {
        Err(e) => {
            let spec = examined.imu.unwrap_or(examined.sensor);
            checks.push(Check::new(what(spec), true, Err(refused(e))));
            examined.imu.is_some()
        }
        Ok(Some((_, imu, beside))) => {
            let spec = examined.imu.unwrap_or(examined.sensor);
            checks.push(Check::new(what(spec), true, Ok(imu.describe())));
            matches!(beside, Beside::Breath)
        }
        Ok(None) => true,
    };
    if breath {
        checks.push(Check::new(
            what(examined.sensor),
            true,
            breath_sensor(examined.sensor, config).map_err(refused),
        ));
    }
    checks
}

/// A breath sensor opened (not started: no re-zero) and described.
fn breath_sensor(spec: &SensorSpec, config: &Config) -> anyhow::Result<String> {
    let settings = config.sensor();
    let neutral = config.core().detector().neutral_volts;
    Ok(match spec {
        SensorSpec::Synthetic(_) => "the built-in scripted user (no device)".to_string(),
        SensorSpec::Csv(path) => CsvSensor::open(path)?.describe(),
        SensorSpec::Evdev(target) => {
            EvdevSensor::open(target, &settings.evdev, neutral, settings.reconnect)?.describe()
        }
        SensorSpec::Serial { path, baud } => {
            SerialSensor::open(path, *baud, &settings.serial, neutral, settings.reconnect)?
                .describe()
        }
        SensorSpec::Iio(path) => {
            IioSensor::open(path, &settings.iio, settings.reconnect)?.describe()
        }
    })
}

/// The arm: the simulated one needs nothing; a real one is reached when
/// the run connects.
fn arm(spec: &ArmSpec) -> Check {
    let detail = match spec {
        ArmSpec::Sim => "the simulated JACO2 (nothing to reach)".to_string(),
        other => format!(
            "{other}: not reached here (the run connects at its start, and refuses to start without it)"
        ),
    };
    Check::new(format!("arm {spec}"), false, Ok(detail))
}

/// `/dev/uinput`, opened for writing as the output opens it.
fn uinput() -> Check {
    let path = "/dev/uinput";
    let result = std::fs::OpenOptions::new()
        .write(true)
        .open(path)
        .map(|_| "may be written: the virtual keyboard and pointer can be made".to_string())
        .map_err(|e| {
            let fix = match e.kind() {
                std::io::ErrorKind::NotFound => "load the module: modprobe uinput (and add `uinput` to /etc/modules-load.d/)",
                _ => "install the package's udev rule (KERNEL==\"uinput\", GROUP=\"sipnpuff\", MODE=\"0660\"; docs/outputs.md) or run as root",
            };
            (format!("{path}: {e}"), fix.to_string())
        });
    Check::new("output uinput", true, result)
}

/// The broker's port reached, and the credentials file readable and
/// private. Its password is checked when the run connects.
fn broker(host: &str, port: u16, credentials: Option<&std::path::Path>) -> Check {
    let what = format!("output mqtt {host}:{port}");
    if let Some(path) = credentials
        && let Err(e) = credentials_readable(path)
    {
        return Check::new(
            what,
            true,
            Err((e, "make the file readable by the service's user and no one else: chown sipnpuff, chmod 600".to_string())),
        );
    }
    let reached = (host, port)
        .to_socket_addrs()
        .map_err(|e| (format!("{host}: {e}"), "check [output.mqtt] host (a name this machine resolves, or an address)".to_string()))
        .and_then(|mut addresses| {
            let address = addresses.next().ok_or_else(|| {
                (format!("{host} resolves to no address"), "check [output.mqtt] host".to_string())
            })?;
            TcpStream::connect_timeout(&address, Duration::from_secs(3))
                .map(|_| format!("{address} accepts connections (the password is checked when the run connects)"))
                .map_err(|e| {
                    (
                        format!("{address}: {e}"),
                        "start the broker, or check [output.mqtt] host and port (1883 plain, 8883 TLS) and the firewall".to_string(),
                    )
                })
        });
    Check::new(what, true, reached)
}

/// The credentials file read as the output reads it: private, with a
/// user and a password.
#[cfg(feature = "mqtt")]
fn credentials_readable(path: &std::path::Path) -> Result<(), String> {
    crate::output::mqtt::credentials::Credentials::read(path).map(|_| ())
}

/// A build without MQTT: the output itself refuses to open.
#[cfg(not(feature = "mqtt"))]
fn credentials_readable(_path: &std::path::Path) -> Result<(), String> {
    Ok(())
}

/// The page's address, bound and let go.
fn display(page: SocketAddr) -> Check {
    let result = TcpListener::bind(page)
        .map(|_| "free: the page can be served".to_string())
        .map_err(|e| {
            let fix = match e.kind() {
                std::io::ErrorKind::PermissionDenied => {
                    "a port below 1024 needs root: give a port of 1024 or more (--display, SIPNPUFF_DISPLAY)"
                }
                std::io::ErrorKind::AddrInUse => {
                    "another program (a running sipnpuff?) holds it: stop it, or give another address (--display, SIPNPUFF_DISPLAY); --no-display serves none"
                }
                _ => "give an address of this machine (--display, SIPNPUFF_DISPLAY)",
            };
            (format!("{page}: {e}"), fix.to_string())
        });
    Check::new(format!("display {page}"), false, result)
}

/// Whether every needed check passed.
pub fn all_needed_granted(checks: &[Check]) -> bool {
    checks.iter().all(|c| c.ok || !c.needed)
}
