//! The C ABI of Kinova's command layer: the structures, constants and
//! return codes `KinovaTypes.h`, `Kinova.API.USBCommandLayerUbuntu.h` and
//! `Kinova.API.USBCommLayerUbuntu.h` declare (kinova-ros's copies of
//! Kinova's SDK 5.03 headers, `kinova_driver/include/kinova/`), written
//! here from those declarations. Layouts are `#[repr(C)]`, checked by the
//! tests below against sizes and offsets computed by hand from the headers
//! (x86-64 and aarch64 Linux: `int`, `float` and C enums are 4 bytes,
//! `unsigned long` 8), and in the integration tests against what a C
//! compiler makes of the same declarations (the stand-in library logs its
//! `sizeof`s).
//!
//! C++ references in the headers (`int &result`, `CartesianPosition &`)
//! are pointers in the ABI; structures passed by value
//! (`SendAdvanceTrajectory(TrajectoryPoint)`, `SetActiveDevice(KinovaDevice)`)
//! are passed by value here too.

use std::ffi::{c_char, c_int, c_uint, c_ulong, c_ushort};

/// `NO_ERROR_KINOVA`: every call's success.
pub const NO_ERROR_KINOVA: c_int = 1;

/// `POSITION_TYPE::CARTESIAN_VELOCITY`: the point's Cartesian values are
/// velocities (m/s, rad/s).
pub const CARTESIAN_VELOCITY: c_int = 7;

/// `HAND_MODE::VELOCITY_MODE`: the fingers' values are velocities.
pub const VELOCITY_MODE: c_int = 2;

/// `MAX_KINOVA_DEVICE`: `GetDevices` fills up to this many.
pub const MAX_KINOVA_DEVICE: usize = 20;

/// `SERIAL_LENGTH`.
pub const SERIAL_LENGTH: usize = 20;

/// `struct CartesianInfo`: X, Y, Z (m or m/s) and ThetaX, ThetaY, ThetaZ
/// (rad or rad/s), by context.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[allow(non_snake_case, missing_docs)]
pub struct CartesianInfo {
    pub X: f32,
    pub Y: f32,
    pub Z: f32,
    pub ThetaX: f32,
    pub ThetaY: f32,
    pub ThetaZ: f32,
}

/// `struct AngularInfo`: seven actuators (unused here, zero).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[allow(missing_docs)]
pub struct AngularInfo {
    pub actuators: [f32; 7],
}

/// `struct FingersPosition`: Finger1..3 (position units 0..~6800, or
/// units/s by context).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[allow(non_snake_case, missing_docs)]
pub struct FingersPosition {
    pub Finger1: f32,
    pub Finger2: f32,
    pub Finger3: f32,
}

/// `struct CartesianPosition`: what `GetCartesianPosition` fills.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[allow(non_snake_case, missing_docs)]
pub struct CartesianPosition {
    pub Coordinates: CartesianInfo,
    pub Fingers: FingersPosition,
}

/// `struct UserPosition`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[allow(non_snake_case, missing_docs)]
pub struct UserPosition {
    /// `POSITION_TYPE` (a C enum: `int`).
    pub Type: c_int,
    pub Delay: f32,
    pub CartesianPosition: CartesianInfo,
    pub Actuators: AngularInfo,
    /// `HAND_MODE` (a C enum: `int`).
    pub HandMode: c_int,
    pub Fingers: FingersPosition,
}

/// `struct Limitation` (not active here: zero).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[allow(missing_docs)]
pub struct Limitation {
    pub speed: [f32; 3],
    pub force: [f32; 3],
    pub acceleration: [f32; 3],
}

/// `struct TrajectoryPoint`: what `SendAdvanceTrajectory` takes, by value.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[allow(non_snake_case, missing_docs)]
pub struct TrajectoryPoint {
    pub Position: UserPosition,
    pub LimitationsActive: c_int,
    pub SynchroType: c_int,
    pub Limitations: Limitation,
}

impl TrajectoryPoint {
    /// A `CARTESIAN_VELOCITY` point as kinova-ros builds one
    /// (`setCartesianVelocitiesWithFingerVelocity`: everything zeroed, then
    /// the type, the velocities in the Cartesian part, the fingers'
    /// velocities with `VELOCITY_MODE`; no limitations).
    pub fn cartesian_velocity(linear: [f32; 3], angular: [f32; 3], fingers: f32) -> Self {
        TrajectoryPoint {
            Position: UserPosition {
                Type: CARTESIAN_VELOCITY,
                CartesianPosition: CartesianInfo {
                    X: linear[0],
                    Y: linear[1],
                    Z: linear[2],
                    ThetaX: angular[0],
                    ThetaY: angular[1],
                    ThetaZ: angular[2],
                },
                HandMode: VELOCITY_MODE,
                Fingers: FingersPosition {
                    Finger1: fingers,
                    Finger2: fingers,
                    Finger3: fingers,
                },
                ..UserPosition::default()
            },
            ..TrajectoryPoint::default()
        }
    }
}

/// `struct KinovaDevice` (from the comm layer's header).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(non_snake_case, missing_docs)]
pub struct KinovaDevice {
    pub SerialNumber: [c_char; SERIAL_LENGTH],
    pub Model: [c_char; SERIAL_LENGTH],
    pub VersionMajor: c_int,
    pub VersionMinor: c_int,
    pub VersionRelease: c_int,
    pub DeviceType: c_int,
    pub DeviceID: c_int,
}

impl Default for KinovaDevice {
    fn default() -> Self {
        KinovaDevice {
            SerialNumber: [0; SERIAL_LENGTH],
            Model: [0; SERIAL_LENGTH],
            VersionMajor: 0,
            VersionMinor: 0,
            VersionRelease: 0,
            DeviceType: 0,
            DeviceID: 0,
        }
    }
}

impl KinovaDevice {
    /// The serial number, up to its NUL (lossy UTF-8).
    pub fn serial(&self) -> String {
        c_text(&self.SerialNumber)
    }

    /// The model, up to its NUL.
    pub fn model(&self) -> String {
        c_text(&self.Model)
    }
}

/// A fixed C character array as text: up to the first NUL (or all of it).
fn c_text(chars: &[c_char]) -> String {
    let bytes: Vec<u8> = chars
        .iter()
        .take_while(|&&c| c != 0)
        .map(|&c| c as u8)
        .collect();
    String::from_utf8_lossy(&bytes).into_owned()
}

/// `struct EthernetCommConfig`: addresses as `inet_addr` gives them
/// (network byte order in an `unsigned long`), ports in host order.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[allow(non_snake_case, missing_docs)]
pub struct EthernetCommConfig {
    pub localIpAddress: c_ulong,
    pub subnetMask: c_ulong,
    pub robotIpAddress: c_ulong,
    pub localCmdport: c_ushort,
    pub localBcastPort: c_ushort,
    pub robotPort: c_ushort,
    pub rxTimeOutInMs: c_ulong,
}

/// `inet_addr`'s value for an address: its four bytes in network order,
/// read as a native `u32`.
pub fn inet_addr(ip: std::net::Ipv4Addr) -> c_ulong {
    c_ulong::from(u32::from_ne_bytes(ip.octets()))
}

/// `struct TrajectoryFIFO` (not called; documents the buffer's size field).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[allow(non_snake_case, missing_docs)]
pub struct TrajectoryFifo {
    pub TrajectoryCount: c_uint,
    pub UsedPercentage: f32,
    pub MaxSize: c_uint,
}

/// A return code's name and meaning, from the headers' comments.
pub fn error_name(code: c_int) -> (&'static str, &'static str) {
    match code {
        1 => ("NO_ERROR_KINOVA", "no error"),
        666 => ("UNKNOWN_ERROR", "an error of unknown origin"),
        1001 => ("ERROR_LOAD_USB_LIBRARY", "unable to load the USB library"),
        1002 => ("ERROR_OPEN_METHOD", "the USB library has no Open method"),
        1003 => ("ERROR_WRITE_METHOD", "the USB library has no Write method"),
        1004 => ("ERROR_READ_METHOD", "the USB library has no Read method"),
        1005 => (
            "ERROR_READ_INT_METHOD",
            "the USB library has no Read Int method",
        ),
        1006 => (
            "ERROR_FREE_LIBRARY",
            "the USB library has no Free Library method",
        ),
        1007 => (
            "ERROR_JACO_CONNECTION",
            "a problem with the USB connection between the arm and this computer",
        ),
        1008 => ("ERROR_CLAIM_INTERFACE", "unable to claim the USB interface"),
        1009 => ("ERROR_UNKNOWN_DEVICE", "unknown type of device"),
        1010 => (
            "ERROR_NOT_INITIALIZED",
            "the functionality has not been initialized",
        ),
        1011 => (
            "ERROR_LIBUSB_NO_DEVICE",
            "the USB library cannot find the arm",
        ),
        1012 => ("ERROR_LIBUSB_BUSY", "the USB library is busy"),
        1013 => (
            "ERROR_LIBUSB_NOT_SUPPORTED",
            "not supported by the installed USB library",
        ),
        1014 => (
            "ERROR_SENDPACKET_UNKNOWN",
            "unknown error while sending a packet",
        ),
        1015 => ("ERROR_NO_DEVICE_FOUND", "cannot find the requested device"),
        1016 => (
            "ERROR_OPERATION_INCOMPLETED",
            "the operation was not entirely completed",
        ),
        1017..=1020 => ("ERROR_RS485_*", "an RS-485 error"),
        1021 => (
            "ERROR_FUNCTION_NOT_ACCESSIBLE",
            "the function is not available in this context",
        ),
        1022 => ("ERROR_COMM_TIMEOUT", "the arm did not answer in time"),
        2001 => ("ERROR_INIT_API", "error while initializing the API"),
        2002 => (
            "ERROR_LOAD_COMM_DLL",
            "could not load the communication layer (the CommLayer library beside the command layer)",
        ),
        2003..=2005 => ("JACO_NACK/COMM_FAILED", "the arm refused or did not answer"),
        2006..=2015 => (
            "ERROR_*_METHOD",
            "the communication layer lacks a function the command layer needs",
        ),
        2100 => ("ERROR_INVALID_PARAM", "a parameter is not valid"),
        2101 => ("ERROR_API_NOT_INITIALIZED", "the API is not initialized"),
        2102 => (
            "ERROR_INIT_DATA_STRUCTURES_METHOD",
            "the communication layer lacks InitDataStructure",
        ),
        9999 => ("ERROR_NACK_RECEIVED", "the arm answered NACK"),
        _ => ("?", "a code the SDK's headers do not list"),
    }
}

/// `CALL returned CODE (NAME: meaning)`.
pub fn describe_code(call: &str, code: c_int) -> String {
    let (name, meaning) = error_name(code);
    format!("{call} returned {code} ({name}: {meaning})")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::{offset_of, size_of};

    /// Sizes and offsets computed by hand from the headers' declarations.
    #[test]
    fn layouts_match_the_headers() {
        assert_eq!(size_of::<CartesianInfo>(), 6 * 4);
        assert_eq!(size_of::<AngularInfo>(), 7 * 4);
        assert_eq!(size_of::<FingersPosition>(), 3 * 4);
        assert_eq!(size_of::<CartesianPosition>(), 36);
        assert_eq!(offset_of!(CartesianPosition, Fingers), 24);
        // Type 4, Delay 4, CartesianInfo 24, AngularInfo 28, HandMode 4,
        // FingersPosition 12.
        assert_eq!(size_of::<UserPosition>(), 76);
        assert_eq!(offset_of!(UserPosition, Delay), 4);
        assert_eq!(offset_of!(UserPosition, CartesianPosition), 8);
        assert_eq!(offset_of!(UserPosition, Actuators), 32);
        assert_eq!(offset_of!(UserPosition, HandMode), 60);
        assert_eq!(offset_of!(UserPosition, Fingers), 64);
        assert_eq!(size_of::<Limitation>(), 9 * 4);
        assert_eq!(size_of::<TrajectoryPoint>(), 120);
        assert_eq!(offset_of!(TrajectoryPoint, LimitationsActive), 76);
        assert_eq!(offset_of!(TrajectoryPoint, SynchroType), 80);
        assert_eq!(offset_of!(TrajectoryPoint, Limitations), 84);
        assert_eq!(size_of::<KinovaDevice>(), 60);
        assert_eq!(offset_of!(KinovaDevice, VersionMajor), 40);
        // Three unsigned longs, three unsigned shorts (30 → padded to 32),
        // an unsigned long.
        assert_eq!(size_of::<EthernetCommConfig>(), 40);
        assert_eq!(offset_of!(EthernetCommConfig, localCmdport), 24);
        assert_eq!(offset_of!(EthernetCommConfig, robotPort), 28);
        assert_eq!(offset_of!(EthernetCommConfig, rxTimeOutInMs), 32);
    }

    #[test]
    fn a_velocity_point_is_zero_but_for_the_velocities() {
        let p = TrajectoryPoint::cartesian_velocity([0.1, -0.2, 0.3], [0.4, 0.5, -0.6], 700.0);
        assert_eq!(p.Position.Type, CARTESIAN_VELOCITY);
        assert_eq!(p.Position.HandMode, VELOCITY_MODE);
        assert_eq!(p.Position.CartesianPosition.Y, -0.2);
        assert_eq!(p.Position.CartesianPosition.ThetaZ, -0.6);
        assert_eq!(p.Position.Fingers.Finger3, 700.0);
        assert_eq!(p.Position.Delay, 0.0);
        assert_eq!(p.Position.Actuators, AngularInfo::default());
        assert_eq!(p.LimitationsActive, 0);
        assert_eq!(p.Limitations, Limitation::default());
    }

    #[test]
    fn addresses_are_in_network_order_as_inet_addr_gives_them() {
        let ip: std::net::Ipv4Addr = "192.168.100.11".parse().unwrap();
        let bytes = (inet_addr(ip) as u32).to_ne_bytes();
        assert_eq!(bytes, [192, 168, 100, 11]);
    }

    #[test]
    fn codes_are_named() {
        assert_eq!(
            describe_code("InitAPI", 1015),
            "InitAPI returned 1015 (ERROR_NO_DEVICE_FOUND: cannot find the requested device)"
        );
        assert_eq!(error_name(4242).0, "?");
    }
}
