//! `--arm kinova-sdk:usb|eth`: a JACO2 through Kinova's own command layer
//! (`Kinova.API.USBCommandLayerUbuntu.so` or
//! `Kinova.API.EthCommandLayerUbuntu.so`), loaded at run time as
//! kinova-ros does (docs/arm-kinova-sdk.md).
//!
//! Files by role: [`abi`] (the C structures and codes), [`library`] (the
//! loaded library, one safe method per call), [`worker`] (the SDK thread
//! that makes every call) and this backend, which the arm thread drives.
//!
//! Threads: the arm thread never calls the library. `send` queues the
//! command for the SDK thread (`try_send`, never blocks), which sends one
//! `CARTESIAN_VELOCITY` point per command and then reads
//! `GetCartesianPosition` once (so at most once per 10 ms cycle); a USB
//! call that hangs holds up only the SDK thread, and `check_link` reports
//! it after `[arm.kinova_sdk] call_timeout_ms`. A return code other than
//! `NO_ERROR_KINOVA` from any call after connecting is a lost link
//! (`ArmError::Disconnected`, naming the call and the code).

pub mod abi;
pub mod library;
pub mod worker;

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender, TrySendError, sync_channel};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use self::abi::{EthernetCommConfig, inet_addr};
use self::library::{KinovaLibrary, command_layer_names};
use self::worker::{Busy, SdkRequest, SdkStatus, Worker, elapsed_ns};
use crate::arm::settings::ArmSettings;
use crate::arm::{Arm, ArmError, ArmState, SdkLink, ThreadRef};
use crate::control::motion::stream::ArmCommand;

/// Commands the SDK thread may fall behind by (640 ms): more than the
/// call timeout allows, so a stall is reported by its age first.
const QUEUE: usize = 64;

/// How long `stop` waits for the SDK thread beyond the call timeout.
const STOP_GRACE: Duration = Duration::from_millis(1000);

/// The backend (not connected until [`Arm::connect`]).
pub struct KinovaSdkArm {
    link: SdkLink,
    dir: PathBuf,
    settings: ArmSettings,
    epoch: Instant,
    running: Option<Running>,
    /// The SDK's worker thread, once started.
    worker: Option<std::thread::JoinHandle<()>>,
    /// The newest state, kept for the report after the stop.
    last: Option<ArmState>,
}

/// A connected SDK thread.
struct Running {
    requests: SyncSender<SdkRequest>,
    stopped: Receiver<Result<(), String>>,
    shared: Arc<Mutex<SdkStatus>>,
    busy: Arc<Busy>,
    stopping: bool,
    /// Requests queued so far.
    pushed: u64,
    /// When request `n` was queued (ns after the epoch), at `n % QUEUE`.
    pushed_at: [u64; QUEUE],
}

impl KinovaSdkArm {
    /// The backend for `link` with these settings; nothing is loaded
    /// until `connect` (on the arm thread).
    pub fn new(link: SdkLink, settings: &ArmSettings) -> KinovaSdkArm {
        KinovaSdkArm {
            link,
            dir: PathBuf::from(&settings.kinova_sdk.library_dir),
            settings: settings.clone(),
            epoch: Instant::now(),
            running: None,
            worker: None,
            last: None,
        }
    }

    fn call_timeout(&self) -> Duration {
        Duration::from_millis(u64::from(self.settings.kinova_sdk.call_timeout_ms))
    }

    /// The Ethernet settings as `InitEthernetAPI` takes them (the addresses
    /// were validated with the configuration).
    fn ethernet(&self) -> Result<EthernetCommConfig, ArmError> {
        let s = &self.settings.kinova_sdk;
        let ip = |key: &str, text: &str| {
            text.parse::<std::net::Ipv4Addr>()
                .map(inet_addr)
                .map_err(|_| ArmError::Unavailable {
                    detail: format!("`[arm.kinova_sdk] {key}` = {text:?} is not an IPv4 address"),
                })
        };
        Ok(EthernetCommConfig {
            localIpAddress: ip("local_ip", &s.local_ip)?,
            subnetMask: ip("subnet_mask", &s.subnet_mask)?,
            robotIpAddress: ip("robot_ip", &s.robot_ip)?,
            localCmdport: s.local_cmd_port,
            localBcastPort: s.local_broadcast_port,
            robotPort: s.robot_port,
            // kinova-ros's value.
            rxTimeOutInMs: 1000,
        })
    }

    /// The failure the SDK thread reported, or a call hanging past the
    /// call timeout, as `Disconnected`.
    fn link_failure(&self) -> Option<ArmError> {
        let running = self.running.as_ref()?;
        if let Ok(shared) = running.shared.lock()
            && let Some(failure) = &shared.failure
        {
            return Some(ArmError::Disconnected {
                detail: format!("{}: {failure}", self.describe()),
            });
        }
        let limit = self.call_timeout();
        if let Some((call, ns)) = running.busy.current(self.epoch)
            && Duration::from_nanos(ns) > limit
        {
            return Some(self.hanging(call, ns));
        }
        // The oldest command not yet taken, whatever holds it up (a call,
        // or the thread not running).
        let taken = running.busy.taken();
        if running.pushed > taken {
            let pushed_at = running.pushed_at[(taken % QUEUE as u64) as usize];
            let ns = elapsed_ns(self.epoch).saturating_sub(pushed_at);
            if Duration::from_nanos(ns) > limit {
                return Some(ArmError::Disconnected {
                    detail: format!(
                        "{}: the SDK thread has not taken a command for {} ms                          (`[arm.kinova_sdk] call_timeout_ms` = {}; {} commands waiting)",
                        self.describe(),
                        ns / 1_000_000,
                        self.settings.kinova_sdk.call_timeout_ms,
                        running.pushed - taken
                    ),
                });
            }
        }
        None
    }

    fn hanging(&self, call: worker::Call, ns: u64) -> ArmError {
        ArmError::Disconnected {
            detail: format!(
                "{}: {} has not returned for {} ms (`[arm.kinova_sdk] call_timeout_ms` = {}): \
                 the {} link or the arm hangs",
                self.describe(),
                call.name(self.link),
                ns / 1_000_000,
                self.settings.kinova_sdk.call_timeout_ms,
                match self.link {
                    SdkLink::Usb => "USB",
                    SdkLink::Eth => "Ethernet",
                }
            ),
        }
    }
}

impl Arm for KinovaSdkArm {
    fn describe(&self) -> String {
        let link = match self.link {
            SdkLink::Usb => "usb",
            SdkLink::Eth => "eth",
        };
        format!(
            "kinova-sdk:{link} ({})",
            self.dir.join(command_layer_names(self.link)[0]).display()
        )
    }

    /// Loads the library, then connects on the SDK thread; gives up after
    /// `[arm] connect_timeout_ms` (the real `InitAPI` may block) with what
    /// to check.
    fn connect(&mut self) -> Result<(), ArmError> {
        if self.running.is_some() {
            return Ok(());
        }
        let ethernet = self.ethernet()?;
        let library = KinovaLibrary::load(&self.dir, self.link)?;
        let (requests, requests_rx) = sync_channel(QUEUE);
        let (connected_tx, connected) = sync_channel(1);
        let (stopped_tx, stopped) = sync_channel(1);
        let shared = Arc::new(Mutex::new(SdkStatus::default()));
        let busy = Arc::new(Busy::default());
        let abandoned = Arc::new(AtomicBool::new(false));
        let worker = Worker {
            library,
            link: self.link,
            ethernet,
            serial_number: self.settings.kinova_sdk.serial_number.clone(),
            requests: requests_rx,
            connected: connected_tx,
            stopped: stopped_tx,
            shared: shared.clone(),
            busy: busy.clone(),
            epoch: self.epoch,
            abandoned: abandoned.clone(),
        };
        let worker = std::thread::Builder::new()
            .name("kinova-sdk".into())
            .spawn(move || worker.run())
            .map_err(|e| ArmError::Unavailable {
                detail: format!("could not start the SDK thread: {e}"),
            })?;
        // Dropped with the backend: the worker ends on its own.
        self.worker = Some(worker);
        let timeout = Duration::from_millis(u64::from(self.settings.connect_timeout_ms));
        match connected.recv_timeout(timeout) {
            Ok(Ok(())) => {
                self.running = Some(Running {
                    requests,
                    stopped,
                    shared,
                    busy,
                    stopping: false,
                    pushed: 0,
                    pushed_at: [0; QUEUE],
                });
                Ok(())
            }
            Ok(Err(error)) => Err(error),
            Err(RecvTimeoutError::Timeout) => {
                abandoned.store(true, Ordering::Release);
                let call = busy
                    .current(self.epoch)
                    .map_or("the connection", |(c, _)| c.name(self.link));
                let hint = match self.link {
                    SdkLink::Usb => "no JACO2 found on USB: is it powered and plugged in? \
                                     permissions: the udev rule 10-kinova-arm.rules (from \
                                     kinova-ros's kinova_driver/udev/) in /etc/udev/rules.d/"
                        .to_string(),
                    SdkLink::Eth => format!(
                        "no JACO2 answered at {}: check it is powered and on this network, \
                         and `[arm.kinova_sdk] robot_ip`, `local_ip`, `subnet_mask`",
                        self.settings.kinova_sdk.robot_ip
                    ),
                };
                Err(ArmError::Unavailable {
                    detail: format!(
                        "{}: {call} did not return within {} ms (`[arm] connect_timeout_ms`): {hint}",
                        self.describe(),
                        self.settings.connect_timeout_ms
                    ),
                })
            }
            Err(RecvTimeoutError::Disconnected) => Err(ArmError::Unavailable {
                detail: format!("{}: the SDK thread ended while connecting", self.describe()),
            }),
        }
    }

    /// Queues the command for the SDK thread; never blocks. After a lost
    /// link only a zero command is still queued (the stop's).
    fn send(&mut self, command: &ArmCommand) -> Result<(), ArmError> {
        let failure = self.link_failure();
        let describe = self.describe();
        let Some(running) = self.running.as_mut() else {
            return Err(ArmError::Unavailable {
                detail: format!("{describe}: not connected"),
            });
        };
        if running.stopping {
            return Err(ArmError::Unavailable {
                detail: format!("{describe}: already stopped"),
            });
        }
        if let Some(failure) = failure
            && !command.is_zero()
        {
            return Err(failure);
        }
        match running.requests.try_send(SdkRequest::Point(*command)) {
            Ok(()) => {
                running.pushed_at[(running.pushed % QUEUE as u64) as usize] =
                    elapsed_ns(self.epoch);
                running.pushed += 1;
                Ok(())
            }
            Err(TrySendError::Full(_)) => {
                let busy = running.busy.current(self.epoch);
                Err(match busy {
                    Some((call, ns)) => self.hanging(call, ns),
                    None => ArmError::Disconnected {
                        detail: format!("{describe}: the SDK thread is {QUEUE} commands behind"),
                    },
                })
            }
            Err(TrySendError::Disconnected(_)) => Err(ArmError::Disconnected {
                detail: format!("{describe}: the SDK thread has ended"),
            }),
        }
    }

    /// The newest measured state (`GetCartesianPosition` after the
    /// latest point); after the stop, the last one measured, once.
    fn feedback(&mut self) -> Option<ArmState> {
        let running = self.running.as_ref()?;
        let fresh = running.shared.lock().ok().and_then(|mut s| s.state.take());
        match fresh {
            Some(state) => {
                self.last = Some(state);
                Some(state)
            }
            None if running.stopping => self.last.take(),
            None => None,
        }
    }

    fn measures_pose(&self) -> bool {
        true
    }

    fn check_link(&mut self) -> Result<(), ArmError> {
        match self.running.as_ref() {
            Some(running) if !running.stopping => self.link_failure().map_or(Ok(()), Err),
            _ => Ok(()),
        }
    }

    /// EraseAllTrajectories, StopControlAPI, CloseAPI on the SDK thread,
    /// after whatever was queued (the zero command); waits for them up to
    /// the call timeout plus a second.
    fn stop(&mut self) -> Result<(), ArmError> {
        let describe = self.describe();
        let wait = self.call_timeout() + STOP_GRACE;
        let Some(running) = self.running.as_mut() else {
            return Ok(());
        };
        if running.stopping {
            return Ok(());
        }
        running.stopping = true;
        let deadline = Instant::now() + wait;
        let mut request = SdkRequest::Stop;
        loop {
            match running.requests.try_send(request) {
                Ok(()) => break,
                Err(TrySendError::Full(back)) if Instant::now() < deadline => {
                    request = back;
                    std::thread::sleep(Duration::from_millis(1));
                }
                Err(TrySendError::Full(_)) => {
                    return Err(ArmError::Disconnected {
                        detail: format!(
                            "{describe}: the SDK thread took no stop within {} ms (a call \
                             hangs); the JACO2 stops when its stream stops",
                            wait.as_millis()
                        ),
                    });
                }
                Err(TrySendError::Disconnected(_)) => {
                    return Err(ArmError::Disconnected {
                        detail: format!("{describe}: the SDK thread has ended"),
                    });
                }
            }
        }
        let outcome = running
            .stopped
            .recv_timeout(deadline.saturating_duration_since(Instant::now()));
        if let Some(state) = running.shared.lock().ok().and_then(|mut s| s.state.take()) {
            self.last = Some(state);
        }
        match outcome {
            Ok(Ok(())) => Ok(()),
            Ok(Err(failures)) => Err(ArmError::Disconnected {
                detail: format!("{describe}: stopping: {failures}"),
            }),
            Err(_) => Err(ArmError::Disconnected {
                detail: format!(
                    "{describe}: the stop did not finish within {} ms (a call hangs); the \
                     JACO2 stops when its stream stops",
                    wait.as_millis()
                ),
            }),
        }
    }

    /// The SDK's worker, which makes every library call (the trajectory
    /// points included), while it runs.
    fn threads(&self) -> Vec<(String, ThreadRef)> {
        use std::os::unix::thread::JoinHandleExt;
        self.worker
            .iter()
            .filter(|worker| !worker.is_finished())
            .map(|worker| {
                (
                    "kinova-sdk".to_string(),
                    ThreadRef::Pthread(worker.as_pthread_t()),
                )
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_library_names_the_file_the_folder_and_the_key() {
        let mut settings = ArmSettings::default();
        settings.kinova_sdk.library_dir = "/nonexistent/kinova".into();
        for (link, file) in [
            (SdkLink::Usb, "Kinova.API.USBCommandLayerUbuntu.so"),
            (SdkLink::Eth, "Kinova.API.EthCommandLayerUbuntu.so"),
        ] {
            let mut arm = KinovaSdkArm::new(link, &settings);
            let Err(ArmError::Unavailable { detail }) = arm.connect() else {
                panic!("connected without a library");
            };
            for part in [file, "/nonexistent/kinova", "JACO SDK", "library_dir"] {
                assert!(detail.contains(part), "{part} in {detail}");
            }
            // Nothing to stop; nothing to send to.
            assert!(arm.stop().is_ok());
            assert!(arm.send(&ArmCommand::default()).is_err());
            assert!(arm.feedback().is_none() && arm.check_link().is_ok());
        }
    }
}
