//! The SDK thread: the one thread that calls Kinova's library (kinova-ros
//! serialises every call under one mutex; here one thread owns them all).
//! It connects, then for each command the arm thread hands it sends one
//! `CARTESIAN_VELOCITY` point and reads the measured pose once (once per
//! batch when points queued up), and on `Stop` erases the trajectory FIFO
//! and releases the arm. Not RT-safe; never on the control thread.
//!
//! Its state for the arm thread: the newest measured state and the first
//! failure in [`SdkStatus`] (a mutex held only to copy them), and the call in
//! progress with its start in two atomics, so the arm thread can tell a
//! hanging call within [`Arm::check_link`](crate::arm::Arm::check_link)'s
//! poll.

use std::ffi::c_int;
use std::sync::atomic::{AtomicBool, AtomicU8, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use super::abi::{
    CartesianPosition, EthernetCommConfig, KinovaDevice, NO_ERROR_KINOVA, TrajectoryPoint,
    describe_code,
};
use super::library::KinovaLibrary;
use crate::arm::{ArmError, ArmState, SdkLink};
use crate::control::motion::stream::ArmCommand;

/// What the arm thread asks of the SDK thread.
pub enum SdkRequest {
    /// Send this command as one `CARTESIAN_VELOCITY` point.
    Point(ArmCommand),
    /// Erase the FIFO, release the arm and close the API; then end.
    Stop,
}

/// The library calls, numbered for [`Busy`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Call {
    /// `InitAPI` / `InitEthernetAPI`.
    Init = 1,
    /// `GetDevices`.
    GetDevices,
    /// `SetActiveDevice`.
    SetActiveDevice,
    /// `StartControlAPI`.
    StartControlApi,
    /// `StopControlAPI`.
    StopControlApi,
    /// `SetCartesianControl`.
    SetCartesianControl,
    /// `SendAdvanceTrajectory`.
    SendAdvanceTrajectory,
    /// `GetCartesianPosition`.
    GetCartesianPosition,
    /// `EraseAllTrajectories`.
    EraseAllTrajectories,
    /// `CloseAPI`.
    CloseApi,
}

impl Call {
    const ALL: [Call; 10] = [
        Call::Init,
        Call::GetDevices,
        Call::SetActiveDevice,
        Call::StartControlApi,
        Call::StopControlApi,
        Call::SetCartesianControl,
        Call::SendAdvanceTrajectory,
        Call::GetCartesianPosition,
        Call::EraseAllTrajectories,
        Call::CloseApi,
    ];

    /// The function's name in the headers (without `Ethernet_`).
    pub fn name(self, link: SdkLink) -> &'static str {
        match self {
            Call::Init => match link {
                SdkLink::Usb => "InitAPI",
                SdkLink::Eth => "InitEthernetAPI",
            },
            Call::GetDevices => "GetDevices",
            Call::SetActiveDevice => "SetActiveDevice",
            Call::StartControlApi => "StartControlAPI",
            Call::StopControlApi => "StopControlAPI",
            Call::SetCartesianControl => "SetCartesianControl",
            Call::SendAdvanceTrajectory => "SendAdvanceTrajectory",
            Call::GetCartesianPosition => "GetCartesianPosition",
            Call::EraseAllTrajectories => "EraseAllTrajectories",
            Call::CloseApi => "CloseAPI",
        }
    }

    fn from_u8(n: u8) -> Option<Call> {
        Call::ALL.into_iter().find(|c| *c as u8 == n)
    }
}

/// The call in progress: which (0 for none) and since when (ns after the
/// backend's epoch). Written by the SDK thread, read by the arm thread.
#[derive(Default)]
pub struct Busy {
    call: AtomicU8,
    since_ns: AtomicU64,
    /// Requests taken off the queue so far.
    taken: AtomicU64,
}

impl Busy {
    /// The call in progress and for how long, ns.
    pub fn current(&self, epoch: Instant) -> Option<(Call, u64)> {
        let call = Call::from_u8(self.call.load(Ordering::Acquire))?;
        let since = self.since_ns.load(Ordering::Acquire);
        Some((call, elapsed_ns(epoch).saturating_sub(since)))
    }

    /// Requests the SDK thread has taken off the queue.
    pub fn taken(&self) -> u64 {
        self.taken.load(Ordering::Acquire)
    }
}

/// Nanoseconds since `epoch`.
pub fn elapsed_ns(epoch: Instant) -> u64 {
    u64::try_from(epoch.elapsed().as_nanos()).unwrap_or(u64::MAX)
}

/// What the SDK thread reports.
#[derive(Default)]
pub struct SdkStatus {
    /// The newest measured state, taken by `feedback()`.
    pub state: Option<ArmState>,
    /// The first failure after connecting (kept).
    pub failure: Option<String>,
}

/// Everything the SDK thread needs.
pub struct Worker {
    /// The loaded library.
    pub library: KinovaLibrary,
    /// USB or Ethernet.
    pub link: SdkLink,
    /// For `InitEthernetAPI`.
    pub ethernet: EthernetCommConfig,
    /// Empty: the first arm found.
    pub serial_number: String,
    /// Requests from the arm thread.
    pub requests: Receiver<SdkRequest>,
    /// The connection's outcome, once.
    pub connected: SyncSender<Result<(), ArmError>>,
    /// The stop's outcome, once.
    pub stopped: SyncSender<Result<(), String>>,
    /// State for the arm thread.
    pub shared: Arc<Mutex<SdkStatus>>,
    /// The call in progress.
    pub busy: Arc<Busy>,
    /// The backend's epoch for [`Busy`].
    pub epoch: Instant,
    /// Set when `connect` gave up waiting: release the arm and end.
    pub abandoned: Arc<AtomicBool>,
}

/// What was started, to undo on a failed connection.
#[derive(Default)]
struct Opened {
    api: bool,
    control: bool,
}

impl Worker {
    /// One library call, marked busy while it runs.
    fn call<T>(&self, which: Call, f: impl FnOnce(&KinovaLibrary) -> T) -> T {
        self.busy
            .since_ns
            .store(elapsed_ns(self.epoch), Ordering::Release);
        self.busy.call.store(which as u8, Ordering::Release);
        let out = f(&self.library);
        self.busy.call.store(0, Ordering::Release);
        out
    }

    /// A call returning only a code: `Err(description)` unless it is
    /// `NO_ERROR_KINOVA`.
    fn checked(&self, which: Call, f: impl FnOnce(&KinovaLibrary) -> c_int) -> Result<(), String> {
        let code = self.call(which, f);
        if code == NO_ERROR_KINOVA {
            Ok(())
        } else {
            Err(describe_code(
                &self.library.symbol(which.name(self.link)),
                code,
            ))
        }
    }

    /// What to check when no arm answers.
    fn no_arm_hint(&self) -> String {
        match self.link {
            SdkLink::Usb => "no JACO2 found on USB: is it powered and plugged in? permissions: \
                             the udev rule 10-kinova-arm.rules (from kinova-ros's \
                             kinova_driver/udev/) in /etc/udev/rules.d/, then replug"
                .to_string(),
            SdkLink::Eth => format!(
                "no JACO2 answered over Ethernet at {}: is it powered, on this network, its \
                 address set in Kinova's Development Center (General/Ethernet)? check \
                 `[arm.kinova_sdk] robot_ip`, `local_ip` and `subnet_mask`",
                std::net::Ipv4Addr::from((self.ethernet.robotIpAddress as u32).to_ne_bytes())
            ),
        }
    }

    /// Runs the thread: connect, stream, stop.
    pub fn run(self) {
        let mut opened = Opened::default();
        let outcome = self.connect(&mut opened);
        if self.abandoned.load(Ordering::Acquire) || outcome.is_err() {
            self.release(&opened);
            let _ = self.connected.send(outcome);
            return;
        }
        if self.connected.send(Ok(())).is_err() {
            self.release(&opened);
            return;
        }
        let stop = self.stream();
        let _ = self.stopped.send(stop);
    }

    /// Undoes a partial connection (every step attempted).
    fn release(&self, opened: &Opened) {
        if opened.control {
            let _ = self.call(Call::EraseAllTrajectories, |l| l.erase_all_trajectories());
            let _ = self.call(Call::StopControlApi, |l| l.stop_control_api());
        }
        if opened.api {
            let _ = self.call(Call::CloseApi, |l| l.close_api());
        }
    }

    /// InitAPI (or InitEthernetAPI), the device, control, Cartesian mode,
    /// an empty FIFO, the first measured pose.
    fn connect(&self, opened: &mut Opened) -> Result<(), ArmError> {
        let unavailable = |detail: String| ArmError::Unavailable { detail };
        let init = self.call(Call::Init, |l| l.init(&self.ethernet));
        if init != NO_ERROR_KINOVA {
            return Err(unavailable(format!(
                "{}: {}",
                describe_code(&self.library.symbol(Call::Init.name(self.link)), init),
                self.no_arm_hint()
            )));
        }
        opened.api = true;
        if self.abandoned.load(Ordering::Acquire) {
            return Err(unavailable("gave up waiting".into()));
        }
        let (devices, result) = self.call(Call::GetDevices, |l| l.get_devices());
        if result != NO_ERROR_KINOVA {
            return Err(unavailable(format!(
                "{}: {}",
                describe_code(&self.library.symbol("GetDevices"), result),
                self.no_arm_hint()
            )));
        }
        let device = self.choose(&devices)?;
        self.checked(Call::SetActiveDevice, |l| l.set_active_device(device))
            .map_err(unavailable)?;
        // As kinova-ros does: "on a cold boot the arm may not respond to
        // commands from the API right away": start, stop, start.
        self.checked(Call::StartControlApi, |l| l.start_control_api())
            .map_err(unavailable)?;
        opened.control = true;
        self.checked(Call::StopControlApi, |l| l.stop_control_api())
            .map_err(unavailable)?;
        self.checked(Call::StartControlApi, |l| l.start_control_api())
            .map_err(unavailable)?;
        self.checked(Call::SetCartesianControl, |l| l.set_cartesian_control())
            .map_err(unavailable)?;
        // Nothing left from an earlier session runs.
        self.checked(Call::EraseAllTrajectories, |l| l.erase_all_trajectories())
            .map_err(unavailable)?;
        let state = self.measure(ArmCommand::default()).map_err(unavailable)?;
        self.publish_state(state);
        Ok(())
    }

    /// The device with the configured serial number, or the first.
    fn choose(&self, devices: &[KinovaDevice]) -> Result<KinovaDevice, ArmError> {
        let wanted = self.serial_number.trim();
        let found = devices
            .iter()
            .find(|d| wanted.is_empty() || d.serial() == wanted);
        match found {
            Some(device) => Ok(*device),
            None if devices.is_empty() => Err(ArmError::Unavailable {
                detail: format!(
                    "{} found no device: {}",
                    self.library.symbol("GetDevices"),
                    self.no_arm_hint()
                ),
            }),
            None => Err(ArmError::Unavailable {
                detail: format!(
                    "no JACO2 with serial number {wanted:?} among the {} found ({}): check \
                     `[arm.kinova_sdk] serial_number` (empty for the first arm)",
                    devices.len(),
                    devices
                        .iter()
                        .map(|d| format!("{} {}", d.model(), d.serial()))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            }),
        }
    }

    /// `GetCartesianPosition` as an [`ArmState`].
    fn measure(&self, executing: ArmCommand) -> Result<ArmState, String> {
        let (code, position) =
            self.call(Call::GetCartesianPosition, |l| l.get_cartesian_position());
        if code != NO_ERROR_KINOVA {
            return Err(describe_code(
                &self.library.symbol("GetCartesianPosition"),
                code,
            ));
        }
        Ok(state_of(&position, executing))
    }

    fn publish_state(&self, state: ArmState) {
        if let Ok(mut shared) = self.shared.lock() {
            shared.state = Some(state);
        }
    }

    fn publish_failure(&self, failure: String) {
        if let Ok(mut shared) = self.shared.lock() {
            shared.failure.get_or_insert(failure);
        }
    }

    /// Streams points until `Stop` (or the arm side is gone), then stops.
    fn stream(&self) -> Result<(), String> {
        let mut failed = false;
        let mut last_point: Result<(), String> = Ok(());
        let mut executing = ArmCommand::default();
        // Until Stop, or the backend went away without one (stop anyway).
        while let Ok(request) = self.requests.recv() {
            self.busy.taken.fetch_add(1, Ordering::AcqRel);
            let mut stop = false;
            let mut sent = false;
            let mut next = Some(request);
            // Every queued point in order, then one measurement.
            while let Some(request) = next.take() {
                match request {
                    SdkRequest::Stop => {
                        stop = true;
                        break;
                    }
                    // After a failure only zero points are tried (the
                    // stop's zero): no motion is sent on a failed link.
                    SdkRequest::Point(command) if failed && !command.is_zero() => {}
                    SdkRequest::Point(command) => {
                        let point = TrajectoryPoint::cartesian_velocity(
                            command.linear.map(|v| v as f32),
                            command.angular.map(|v| v as f32),
                            command.fingers as f32,
                        );
                        last_point = self.checked(Call::SendAdvanceTrajectory, |l| {
                            l.send_advance_trajectory(point)
                        });
                        executing = command;
                        sent = true;
                        if let Err(failure) = &last_point {
                            failed = true;
                            self.publish_failure(failure.clone());
                        }
                    }
                }
                next = self.requests.try_recv().ok();
                if next.is_some() {
                    self.busy.taken.fetch_add(1, Ordering::AcqRel);
                }
            }
            if sent && !failed {
                match self.measure(executing) {
                    Ok(state) => self.publish_state(state),
                    Err(failure) => {
                        failed = true;
                        self.publish_failure(failure);
                    }
                }
            }
            if stop {
                break;
            }
        }
        self.stop_sequence(last_point)
    }

    /// EraseAllTrajectories, StopControlAPI, CloseAPI: each attempted;
    /// `Err` lists what failed (the final zero point's failure first).
    fn stop_sequence(&self, last_point: Result<(), String>) -> Result<(), String> {
        let results = [
            last_point.map_err(|e| format!("the zero point: {e}")),
            self.checked(Call::EraseAllTrajectories, |l| l.erase_all_trajectories()),
            self.checked(Call::StopControlApi, |l| l.stop_control_api()),
            self.checked(Call::CloseApi, |l| l.close_api()),
        ];
        let failures: Vec<String> = results.into_iter().filter_map(Result::err).collect();
        if failures.is_empty() {
            Ok(())
        } else {
            Err(failures.join("; "))
        }
    }
}

/// Kinova's pose as an [`ArmState`]: X, Y, Z in m; ThetaX, ThetaY, ThetaZ
/// in rad as Euler XYZ angles, R = Rx(ThetaX)·Ry(ThetaY)·Rz(ThetaZ)
/// (kinova-ros's `EulerXYZ2Quaternion`, used for `out/tool_pose`); the
/// fingers from Finger1 (kinova-ros's reference finger).
pub fn state_of(position: &CartesianPosition, executing: ArmCommand) -> ArmState {
    let c = &position.Coordinates;
    let rotation = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), f64::from(c.ThetaX))
        * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), f64::from(c.ThetaY))
        * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), f64::from(c.ThetaZ));
    ArmState {
        pose: Isometry3::from_parts(
            Translation3::new(f64::from(c.X), f64::from(c.Y), f64::from(c.Z)),
            rotation,
        ),
        fingers: Some(f64::from(position.Fingers.Finger1)),
        executing,
    }
}

#[cfg(test)]
mod tests {
    use super::super::abi::{CartesianInfo, FingersPosition};
    use super::*;

    /// kinova-ros's `EulerXYZ2Quaternion`, transcribed.
    fn kinova_ros_quaternion(tx: f64, ty: f64, tz: f64) -> [f64; 4] {
        let (sx, cx) = (0.5 * tx).sin_cos();
        let (sy, cy) = (0.5 * ty).sin_cos();
        let (sz, cz) = (0.5 * tz).sin_cos();
        [
            sx * cy * cz + cx * sy * sz,
            -sx * cy * sz + cx * sy * cz,
            sx * sy * cz + cx * cy * sz,
            -sx * sy * sz + cx * cy * cz,
        ]
    }

    #[test]
    fn the_orientation_is_kinova_ros_euler_xyz() {
        for (tx, ty, tz) in [(0.3, -0.7, 1.9), (3.0, 0.2, -2.5), (-1.2, 1.4, 0.1)] {
            let position = CartesianPosition {
                Coordinates: CartesianInfo {
                    X: 0.1,
                    Y: -0.2,
                    Z: 0.3,
                    ThetaX: tx,
                    ThetaY: ty,
                    ThetaZ: tz,
                },
                Fingers: FingersPosition {
                    Finger1: 1200.0,
                    Finger2: 1.0,
                    Finger3: 2.0,
                },
            };
            let state = state_of(&position, ArmCommand::default());
            let q = state.pose.rotation.quaternion();
            let expected = kinova_ros_quaternion(f64::from(tx), f64::from(ty), f64::from(tz));
            let sign = if q.w * expected[3] < 0.0 { -1.0 } else { 1.0 };
            for (got, want) in [q.i, q.j, q.k, q.w].iter().zip(expected) {
                assert!((got * sign - want).abs() < 1e-12, "{q:?} vs {expected:?}");
            }
            assert_eq!(state.pose.translation.vector.y, f64::from(-0.2f32));
            assert_eq!(state.fingers, Some(1200.0));
        }
    }
}
