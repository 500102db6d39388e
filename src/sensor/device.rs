//! The life of a device's reader thread, shared by the evdev, serial and
//! IIO backends: read into the hold until stopped or the device fails;
//! then the device is lost (the core faults at once) and, with
//! `[sensor] reconnect`, looked for again every 250 ms until it is back
//! or the run stops; without it the thread ends with the error (the run
//! ends safely and reports it).

use std::io;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use crate::sensor::SensorError;
use crate::sensor::held::{Holder, Link};
use crate::wakes::WakeLog;

/// How often a lost device is looked for again.
pub const RECONNECT_EVERY: Duration = Duration::from_millis(250);

/// What one backend's reader does.
pub trait DeviceReader {
    /// The device, as `--sensor` named it (for the error).
    fn what(&self) -> String;

    /// Whether a lost device is looked for again.
    fn reconnects(&self) -> bool;

    /// Reads into `holder` until `stop` is set (`Ok`) or the device fails
    /// (`Err`), logging how late it woke for data when it knows when the
    /// data was due.
    fn read_until_lost(
        &mut self,
        holder: &Holder,
        stop: &AtomicBool,
        log: &mut WakeLog,
    ) -> io::Result<()>;

    /// One attempt to open the device again; on success the reader holds
    /// the new device and `holder` its current value.
    fn try_reopen(&mut self, holder: &Holder) -> bool;

    /// Called once when the run stops with the device still there.
    fn finish(&mut self) {}
}

/// The reader thread's body.
pub fn run(
    reader: &mut impl DeviceReader,
    holder: &Holder,
    stop: &AtomicBool,
    log: &mut WakeLog,
) -> Result<(), SensorError> {
    loop {
        match reader.read_until_lost(holder, stop, log) {
            Ok(()) => {
                reader.finish();
                return Ok(());
            }
            Err(error) => {
                holder.link(Link::Lost);
                if !reader.reconnects() {
                    return Err(SensorError::Disconnected {
                        what: reader.what(),
                        detail: format!(
                            "{error} (the device went away; set `[sensor] reconnect = true` to resume when it returns)"
                        ),
                    });
                }
                loop {
                    if stop.load(Ordering::Relaxed) {
                        return Ok(());
                    }
                    std::thread::sleep(RECONNECT_EVERY);
                    if reader.try_reopen(holder) {
                        break;
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::sample::Sample;
    use crate::sensor::Samples;
    use crate::sensor::held::hold;

    /// Fails after each read; comes back on the second attempt.
    struct Flaky {
        reads: u32,
        attempts: u32,
        reconnect: bool,
    }

    impl DeviceReader for Flaky {
        fn what(&self) -> String {
            "flaky".into()
        }
        fn reconnects(&self) -> bool {
            self.reconnect
        }
        fn read_until_lost(
            &mut self,
            holder: &Holder,
            stop: &AtomicBool,
            _log: &mut WakeLog,
        ) -> io::Result<()> {
            self.reads += 1;
            holder.set(f64::from(self.reads));
            if self.reads >= 2 {
                stop.store(true, Ordering::Relaxed);
                return Ok(());
            }
            Err(io::Error::from_raw_os_error(libc::ENODEV))
        }
        fn try_reopen(&mut self, _holder: &Holder) -> bool {
            self.attempts += 1;
            self.attempts >= 2
        }
    }

    #[test]
    fn a_lost_device_ends_the_reader_or_is_found_again() {
        let (holder, mut samples) = hold();
        let stop = AtomicBool::new(false);
        let mut once = Flaky {
            reads: 0,
            attempts: 0,
            reconnect: false,
        };
        let mut log = WakeLog::start();
        let e = run(&mut once, &holder, &stop, &mut log)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("flaky disconnected: "), "{e}");
        assert!(e.contains("reconnect = true"), "{e}");
        assert_eq!(samples.try_read(0).sample, Sample::Lost);
        let mut again = Flaky {
            reads: 0,
            attempts: 0,
            reconnect: true,
        };
        assert!(run(&mut again, &holder, &stop, &mut log).is_ok());
        assert_eq!((again.reads, again.attempts), (2, 2));
        assert_eq!(samples.try_read(0).sample, Sample::Volts(2.0), "live again");
    }
}
