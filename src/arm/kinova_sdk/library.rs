//! Kinova's command layer, loaded at run time with `libloading` as
//! kinova-ros's `kinova_api.cpp` does with `dlopen`: the file found in
//! `[arm.kinova_sdk] library_dir`, its communication layer loaded first
//! with `RTLD_GLOBAL` when it is there (the command layer opens it by name
//! in `InitAPI`), the functions looked up by their exported names (the
//! Ethernet layer prefixes every name with `Ethernet_`), and one safe
//! method per call that returns the code. Not RT-safe: called only from
//! the SDK thread ([`super::worker`]).

use std::ffi::c_int;
use std::mem::ManuallyDrop;
use std::path::{Path, PathBuf};

use libloading::os::unix::{Library, RTLD_GLOBAL, RTLD_NOW};

use super::abi::{
    CartesianPosition, EthernetCommConfig, KinovaDevice, MAX_KINOVA_DEVICE, TrajectoryPoint,
};
use crate::arm::{ArmError, SdkLink};

/// The command layer's file names, Kinova's SDK installer's first, then
/// kinova-ros's (`kinova_driver/lib/<arch>/`).
pub fn command_layer_names(link: SdkLink) -> [&'static str; 2] {
    match link {
        SdkLink::Usb => [
            "Kinova.API.USBCommandLayerUbuntu.so",
            "USBCommandLayerUbuntu.so",
        ],
        SdkLink::Eth => [
            "Kinova.API.EthCommandLayerUbuntu.so",
            "EthCommandLayerUbuntu.so",
        ],
    }
}

/// The communication layer's file names (preloaded when present).
fn comm_layer_names(link: SdkLink) -> [&'static str; 2] {
    match link {
        SdkLink::Usb => ["Kinova.API.CommLayerUbuntu.so", "USBCommLayerUbuntu.so"],
        SdkLink::Eth => ["Kinova.API.EthCommLayerUbuntu.so", "EthCommLayerUbuntu.so"],
    }
}

type NoArgs = unsafe extern "C" fn() -> c_int;

/// The loaded command layer: the functions this backend calls.
pub struct KinovaLibrary {
    /// The file loaded.
    pub path: PathBuf,
    link: SdkLink,
    // Never unloaded: the real library runs its own threads (USB reads),
    // which a `dlclose` would pull the code from under; kinova-ros never
    // unloads it either.
    _command: ManuallyDrop<Library>,
    _comm: Option<ManuallyDrop<Library>>,
    init_api: Option<NoArgs>,
    init_ethernet_api: Option<unsafe extern "C" fn(*mut EthernetCommConfig) -> c_int>,
    get_devices: unsafe extern "C" fn(*mut KinovaDevice, *mut c_int) -> c_int,
    set_active_device: unsafe extern "C" fn(KinovaDevice) -> c_int,
    start_control_api: NoArgs,
    stop_control_api: NoArgs,
    set_cartesian_control: NoArgs,
    send_advance_trajectory: unsafe extern "C" fn(TrajectoryPoint) -> c_int,
    get_cartesian_position: unsafe extern "C" fn(*mut CartesianPosition) -> c_int,
    erase_all_trajectories: NoArgs,
    close_api: NoArgs,
}

/// Where the library comes from, for the errors.
fn where_from(dir: &Path) -> String {
    format!(
        "it comes with Kinova's JACO SDK installer (which puts it in /opt/kinova/API) or with \
         kinova-ros (kinova_driver/lib/x86_64-linux-gnu/, or i386-linux-gnu/); set \
         `[arm.kinova_sdk] library_dir` to the folder holding it (now {})",
        dir.display()
    )
}

/// A libloading error with dlerror's text.
fn loading_error(error: &libloading::Error) -> String {
    match std::error::Error::source(error) {
        Some(source) => format!("{error}: {source}"),
        None => error.to_string(),
    }
}

impl KinovaLibrary {
    /// Loads the `link`'s command layer from `dir` and looks up every
    /// function this backend calls. Errors name the file, the folder and
    /// where the library comes from, or the missing symbol.
    pub fn load(dir: &Path, link: SdkLink) -> Result<KinovaLibrary, ArmError> {
        let names = command_layer_names(link);
        let Some(path) = names.iter().map(|n| dir.join(n)).find(|p| p.is_file()) else {
            return Err(ArmError::Unavailable {
                detail: format!(
                    "Kinova's {} command layer `{}` (or kinova-ros's `{}`) is not in {}: {}",
                    match link {
                        SdkLink::Usb => "USB",
                        SdkLink::Eth => "Ethernet",
                    },
                    names[0],
                    names[1],
                    dir.display(),
                    where_from(dir)
                ),
            });
        };
        let comm = match comm_layer_names(link)
            .iter()
            .map(|n| dir.join(n))
            .find(|p| p.is_file())
        {
            Some(comm_path) => Some(ManuallyDrop::new(open(&comm_path, dir)?)),
            None => None,
        };
        let command = open(&path, dir)?;
        let prefix = match link {
            SdkLink::Usb => "",
            SdkLink::Eth => "Ethernet_",
        };
        let lookup = Lookup {
            library: &command,
            path: &path,
            prefix,
        };
        // SAFETY: for every `lookup.get` below, each type is the function's
        // declaration in Kinova's headers (`Kinova.API.USBCommandLayerUbuntu.h`,
        // `Kinova.API.EthCommandLayerUbuntu.h`), C++ references as pointers
        // and structures `#[repr(C)]` (abi.rs, with layout tests).
        let library = unsafe {
            KinovaLibrary {
                init_api: match link {
                    SdkLink::Usb => Some(lookup.get(b"InitAPI")?),
                    SdkLink::Eth => None,
                },
                init_ethernet_api: match link {
                    SdkLink::Usb => None,
                    SdkLink::Eth => Some(lookup.get(b"InitEthernetAPI")?),
                },
                get_devices: lookup.get(b"GetDevices")?,
                set_active_device: lookup.get(b"SetActiveDevice")?,
                start_control_api: lookup.get(b"StartControlAPI")?,
                stop_control_api: lookup.get(b"StopControlAPI")?,
                set_cartesian_control: lookup.get(b"SetCartesianControl")?,
                send_advance_trajectory: lookup.get(b"SendAdvanceTrajectory")?,
                get_cartesian_position: lookup.get(b"GetCartesianPosition")?,
                erase_all_trajectories: lookup.get(b"EraseAllTrajectories")?,
                close_api: lookup.get(b"CloseAPI")?,
                path: path.clone(),
                link,
                _command: ManuallyDrop::new(command),
                _comm: comm,
            }
        };
        Ok(library)
    }

    /// The exported name of `call` in this layer (`Ethernet_` + the name
    /// for the Ethernet layer).
    pub fn symbol(&self, call: &str) -> String {
        match self.link {
            SdkLink::Usb => call.to_string(),
            SdkLink::Eth => format!("Ethernet_{call}"),
        }
    }

    /// `InitAPI()` (USB) or `InitEthernetAPI(config)` (Ethernet).
    pub fn init(&self, ethernet: &EthernetCommConfig) -> c_int {
        let mut config = *ethernet;
        match (self.init_api, self.init_ethernet_api) {
            // SAFETY: the library's own function, no arguments.
            (Some(init), _) => unsafe { init() },
            // SAFETY: a valid, exclusive pointer to a live EthernetCommConfig.
            (None, Some(init)) => unsafe { init(&mut config) },
            // Not reached: `load` sets one of the two.
            (None, None) => -1,
        }
    }

    /// `GetDevices(devices, result)`: the devices found and the result code.
    pub fn get_devices(&self) -> (Vec<KinovaDevice>, c_int) {
        let mut devices = [KinovaDevice::default(); MAX_KINOVA_DEVICE];
        let mut result: c_int = 0;
        // SAFETY: an array of MAX_KINOVA_DEVICE devices, as declared, and
        // a valid pointer for the result.
        let count = unsafe { (self.get_devices)(devices.as_mut_ptr(), &mut result) };
        let count = usize::try_from(count).unwrap_or(0).min(MAX_KINOVA_DEVICE);
        (devices[..count].to_vec(), result)
    }

    /// `SetActiveDevice(device)`.
    pub fn set_active_device(&self, device: KinovaDevice) -> c_int {
        // SAFETY: the structure by value, as declared.
        unsafe { (self.set_active_device)(device) }
    }

    /// `StartControlAPI()`.
    pub fn start_control_api(&self) -> c_int {
        // SAFETY: no arguments.
        unsafe { (self.start_control_api)() }
    }

    /// `StopControlAPI()`.
    pub fn stop_control_api(&self) -> c_int {
        // SAFETY: no arguments.
        unsafe { (self.stop_control_api)() }
    }

    /// `SetCartesianControl()`.
    pub fn set_cartesian_control(&self) -> c_int {
        // SAFETY: no arguments.
        unsafe { (self.set_cartesian_control)() }
    }

    /// `SendAdvanceTrajectory(point)`.
    pub fn send_advance_trajectory(&self, point: TrajectoryPoint) -> c_int {
        // SAFETY: the structure by value, as declared.
        unsafe { (self.send_advance_trajectory)(point) }
    }

    /// `GetCartesianPosition(position)`: the code and what it filled.
    pub fn get_cartesian_position(&self) -> (c_int, CartesianPosition) {
        let mut position = CartesianPosition::default();
        // SAFETY: a valid, exclusive pointer to a live CartesianPosition.
        let code = unsafe { (self.get_cartesian_position)(&mut position) };
        (code, position)
    }

    /// `EraseAllTrajectories()`.
    pub fn erase_all_trajectories(&self) -> c_int {
        // SAFETY: no arguments.
        unsafe { (self.erase_all_trajectories)() }
    }

    /// `CloseAPI()`.
    pub fn close_api(&self) -> c_int {
        // SAFETY: no arguments.
        unsafe { (self.close_api)() }
    }
}

/// Opens one file with `RTLD_NOW | RTLD_GLOBAL`, as kinova-ros does.
fn open(path: &Path, dir: &Path) -> Result<Library, ArmError> {
    // SAFETY: loading runs the library's initialisers: Kinova's own code,
    // which kinova-ros loads the same way.
    unsafe { Library::open(Some(path), RTLD_NOW | RTLD_GLOBAL) }.map_err(|error| {
        ArmError::Unavailable {
            detail: format!(
                "could not load {}: {} (a library for another architecture, or one it \
                 needs is missing; {})",
                path.display(),
                loading_error(&error),
                where_from(dir)
            ),
        }
    })
}

/// Looks functions up in one library.
struct Lookup<'a> {
    library: &'a Library,
    path: &'a Path,
    prefix: &'static str,
}

impl Lookup<'_> {
    /// The function `prefix + name`, as a `T`.
    ///
    /// # Safety
    /// `T` must be the function's true type.
    unsafe fn get<T: Copy>(&self, name: &[u8]) -> Result<T, ArmError> {
        let mut symbol = self.prefix.as_bytes().to_vec();
        symbol.extend_from_slice(name);
        // SAFETY: the caller guarantees T; the symbol is copied out as a
        // function pointer, valid while the library stays loaded (it is
        // never unloaded).
        match unsafe { self.library.get::<T>(symbol.as_slice()) } {
            Ok(function) => Ok(*function),
            Err(error) => Err(ArmError::Unavailable {
                detail: format!(
                    "{} has no symbol `{}` ({}): not Kinova's command layer, or a version \
                     without that function (kinova-ros's headers declare it: SDK 5.03)",
                    self.path.display(),
                    String::from_utf8_lossy(&symbol),
                    loading_error(&error)
                ),
            }),
        }
    }
}
