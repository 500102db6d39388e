//! An inertial sample: a head-worn IMU's three accelerations and three
//! angular rates, the input of the gesture front end. The channels a
//! sensor lacks are absent from its [`Channels`] and read as zero.

use std::fmt;

/// How many channels an [`ImuSample`] holds.
pub const CHANNELS: usize = 6;

/// One of an IMU's six channels, in the order of the CSV header
/// `tick,ax,ay,az,gx,gy,gz`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Channel {
    /// Acceleration along x, m/s², gravity included.
    Ax,
    /// Acceleration along y, m/s², gravity included.
    Ay,
    /// Acceleration along z, m/s², gravity included.
    Az,
    /// Angular rate about x, rad/s.
    Gx,
    /// Angular rate about y, rad/s.
    Gy,
    /// Angular rate about z, rad/s.
    Gz,
}

impl Channel {
    /// The six channels, in sample order.
    pub const ALL: [Channel; CHANNELS] = [
        Channel::Ax,
        Channel::Ay,
        Channel::Az,
        Channel::Gx,
        Channel::Gy,
        Channel::Gz,
    ];

    /// Where it sits in [`ImuSample::values`].
    pub const fn index(self) -> usize {
        match self {
            Channel::Ax => 0,
            Channel::Ay => 1,
            Channel::Az => 2,
            Channel::Gx => 3,
            Channel::Gy => 4,
            Channel::Gz => 5,
        }
    }

    /// Its name in a CSV header and a gesture set: `ax` … `gz`.
    pub const fn name(self) -> &'static str {
        match self {
            Channel::Ax => "ax",
            Channel::Ay => "ay",
            Channel::Az => "az",
            Channel::Gx => "gx",
            Channel::Gy => "gy",
            Channel::Gz => "gz",
        }
    }

    /// The channel named `name`, if any.
    pub fn from_name(name: &str) -> Option<Channel> {
        Channel::ALL.into_iter().find(|c| c.name() == name)
    }

    /// Whether it is an acceleration (m/s²) rather than a rate (rad/s).
    pub const fn is_acceleration(self) -> bool {
        matches!(self, Channel::Ax | Channel::Ay | Channel::Az)
    }
}

impl fmt::Display for Channel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A set of channels: the ones a sensor or a recording gives. `Copy`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Channels(u8);

impl Channels {
    /// No channel.
    pub const NONE: Channels = Channels(0);
    /// All six.
    pub const ALL: Channels = Channels(0b11_1111);

    /// The set holding `channels`.
    pub fn of(channels: &[Channel]) -> Channels {
        channels.iter().fold(Channels::NONE, |set, &c| set.with(c))
    }

    /// This set and `channel`.
    pub const fn with(self, channel: Channel) -> Channels {
        Channels(self.0 | 1 << channel.index())
    }

    /// Whether `channel` is in the set.
    pub const fn contains(self, channel: Channel) -> bool {
        self.0 & 1 << channel.index() != 0
    }

    /// Whether every channel of `other` is in this set.
    pub const fn covers(self, other: Channels) -> bool {
        self.0 & other.0 == other.0
    }

    /// Whether the set is empty.
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// The channels in the set, in sample order.
    pub fn iter(self) -> impl Iterator<Item = Channel> {
        Channel::ALL.into_iter().filter(move |&c| self.contains(c))
    }
}

/// The set written as its names, comma-separated (`ax,ay,az`).
impl fmt::Display for Channels {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, channel) in self.iter().enumerate() {
            if i > 0 {
                f.write_str(",")?;
            }
            f.write_str(channel.name())?;
        }
        Ok(())
    }
}

/// One IMU sample: accelerations in m/s² (gravity included) and angular
/// rates in rad/s, indexed by [`Channel::index`]. `Copy`, RT-safe.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ImuSample {
    /// `ax, ay, az, gx, gy, gz`.
    pub values: [f64; CHANNELS],
}

impl ImuSample {
    /// The value of `channel`.
    pub fn get(&self, channel: Channel) -> f64 {
        self.values.get(channel.index()).copied().unwrap_or(0.0)
    }

    /// The acceleration vector, m/s².
    pub fn acceleration(&self) -> [f64; 3] {
        let [ax, ay, az, ..] = self.values;
        [ax, ay, az]
    }

    /// The angular rate vector, rad/s.
    pub fn rate(&self) -> [f64; 3] {
        let [.., gx, gy, gz] = self.values;
        [gx, gy, gz]
    }

    /// Whether every value is finite (a NaN or ±∞ is a sensor fault).
    pub fn is_finite(&self) -> bool {
        self.values.iter().all(|v| v.is_finite())
    }
}

/// One tick's input from the IMU, as [`Sample`](crate::control::sample::Sample)
/// is the breath sensor's. `Copy`, RT-safe.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum ImuInput {
    /// A sample arrived on this tick.
    Sample(ImuSample),
    /// No sample on this tick (an IMU samples at its own rate; after
    /// `stale_ms` without one it is in fault).
    #[default]
    Missing,
    /// The IMU's device is gone: in fault at once.
    Lost,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channels_are_named_as_the_csv_header_names_them() {
        let names: Vec<&str> = Channel::ALL.iter().map(|c| c.name()).collect();
        assert_eq!(names, ["ax", "ay", "az", "gx", "gy", "gz"]);
        let gyro = Channels::of(&[Channel::Gz, Channel::Gx, Channel::Gy]);
        assert_eq!(gyro.to_string(), "gx,gy,gz");
        assert!(Channels::ALL.covers(gyro));
        assert!(!gyro.covers(Channels::ALL));
        assert!(!gyro.contains(Channel::Ax));
    }
}
