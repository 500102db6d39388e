//! `run --sensor serial:` against a real kernel tty: a pseudo-terminal
//! whose master end this test writes like a microcontroller (or a
//! FLipMouse) would. The kernel's tty layer is the same one a CDC-ACM or
//! USB-serial port goes through; the USB side itself is proven in the VM
//! harness (`tests/vm/`).

use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crate::common::{Running, fixture};
use crate::scratch::Scratch;

/// A pseudo-terminal pair; the slave is in raw mode, as a real serial port
/// is opened by sipnpuff.
pub struct Pty {
    master: OwnedFd,
    /// Kept open so the line settings stay until the test ends.
    _slave: OwnedFd,
    pub path: String,
}

impl Pty {
    pub fn open() -> Pty {
        // Close-on-exec from the start: a sipnpuff started by a test
        // running beside this one must not inherit the master, whose copy
        // would keep the port from hanging up when this one closes.
        // SAFETY: posix_openpt takes flags and returns a new fd or -1.
        let master = unsafe { libc::posix_openpt(libc::O_RDWR | libc::O_NOCTTY | libc::O_CLOEXEC) };
        assert!(master >= 0, "posix_openpt");
        // SAFETY: the fd is new and ours to own.
        let master = unsafe { OwnedFd::from_raw_fd(master) };
        let mut name = [0 as libc::c_char; 128];
        // SAFETY: a valid master fd; ptsname_r writes at most 128 bytes.
        let rc = unsafe {
            libc::grantpt(master.as_raw_fd());
            libc::unlockpt(master.as_raw_fd());
            libc::ptsname_r(master.as_raw_fd(), name.as_mut_ptr(), name.len())
        };
        assert_eq!(rc, 0, "ptsname_r");
        // SAFETY: ptsname_r wrote a NUL-terminated name.
        let path = unsafe { std::ffi::CStr::from_ptr(name.as_ptr()) }
            .to_string_lossy()
            .into_owned();
        // SAFETY: opens the slave by its NUL-terminated name.
        let slave = unsafe {
            libc::open(
                name.as_ptr(),
                libc::O_RDWR | libc::O_NOCTTY | libc::O_CLOEXEC,
            )
        };
        assert!(slave >= 0, "open {path}");
        // SAFETY: the fd is new and ours to own.
        let slave = unsafe { OwnedFd::from_raw_fd(slave) };
        // SAFETY: a zeroed termios is filled by tcgetattr before use.
        let mut t: libc::termios = unsafe { std::mem::zeroed() };
        // SAFETY: a valid fd and termios.
        unsafe {
            libc::tcgetattr(slave.as_raw_fd(), &mut t);
            libc::cfmakeraw(&mut t);
            libc::tcsetattr(slave.as_raw_fd(), libc::TCSANOW, &t);
        }
        Pty {
            master,
            _slave: slave,
            path,
        }
    }
}

/// Writes `bytes` to the master end (blocking while the slave's queue is
/// full, as a real device's USB endpoint would NAK).
fn write_all(fd: &OwnedFd, mut bytes: &[u8]) -> bool {
    while !bytes.is_empty() {
        // SAFETY: writes at most `bytes.len()` bytes from `bytes`.
        let n = unsafe { libc::write(fd.as_raw_fd(), bytes.as_ptr().cast(), bytes.len()) };
        if n <= 0 {
            return false;
        }
        bytes = &bytes[n as usize..];
    }
    true
}

/// Reads what sipnpuff wrote to the port, waiting up to `timeout`.
fn read_some(fd: &OwnedFd, timeout: Duration) -> Vec<u8> {
    let mut poll = libc::pollfd {
        fd: fd.as_raw_fd(),
        events: libc::POLLIN,
        revents: 0,
    };
    // SAFETY: one valid pollfd.
    let ready = unsafe { libc::poll(&mut poll, 1, timeout.as_millis() as i32) };
    if ready <= 0 {
        return Vec::new();
    }
    let mut buffer = [0u8; 256];
    // SAFETY: reads at most 256 bytes into `buffer`.
    let n = unsafe { libc::read(fd.as_raw_fd(), buffer.as_mut_ptr().cast(), buffer.len()) };
    buffer[..n.max(0) as usize].to_vec()
}

/// The scripted breaths: (volts, ms). A long puff then a short sip selects
/// `rotate_y` in the built-in library.
const PATTERN: [(f64, u64); 5] = [(2.5, 3000), (4.0, 800), (2.5, 400), (1.5, 150), (2.5, 2500)];

/// Streams `steps` as one line every `period_ms` (on absolute deadlines),
/// formatted by `line`; then closes the port (the device goes away).
pub fn stream(
    pty: Pty,
    steps: &'static [(f64, u64)],
    period_ms: u64,
    line: fn(f64) -> String,
) -> JoinHandle<()> {
    std::thread::spawn(move || {
        let period = Duration::from_millis(period_ms);
        let mut next = Instant::now();
        let levels = steps
            .iter()
            .flat_map(|&(v, ms)| std::iter::repeat_n(v, (ms / period_ms) as usize));
        for v in levels {
            if !write_all(&pty.master, line(v).as_bytes()) {
                return;
            }
            next += period;
            if let Some(wait) = next.checked_duration_since(Instant::now()) {
                std::thread::sleep(wait);
            }
        }
        // Dropping the pty closes the master: the port hangs up.
    })
}

fn config() -> String {
    fixture("shared-machine.toml").display().to_string()
}

/// Bursts (their action codes) and matched modes in the events.
fn bursts_and_modes(lines: &[String]) -> (Vec<i64>, Vec<String>) {
    let mut bursts = Vec::new();
    let mut modes = Vec::new();
    for line in lines {
        let Ok(v) = serde_json::from_str::<serde_json::Value>(line) else {
            continue;
        };
        match v["event"].as_str() {
            Some("burst") => bursts.push(v["action"].as_i64().unwrap_or(0)),
            Some("match") => modes.push(v["mode"].as_str().unwrap_or("").to_string()),
            _ => {}
        }
    }
    (bursts, modes)
}

#[test]
fn a_1khz_serial_stream_gives_the_scripted_bursts_then_a_disconnect_is_a_fault() {
    crate::common::real_time(|| {
        let pty = Pty::open();
        let path = format!("serial:{}", pty.path);
        let feeder = stream(pty, &PATTERN, 1, |v| format!("{v:.3}\n"));
        let run = Running::spawn(&["run", "--sensor", &path, "--config", &config(), "--json"]);
        let (status, lines, stderr) = run.finish();
        feeder.join().unwrap();
        assert_eq!(
            bursts_and_modes(&lines),
            (vec![-2, 1], vec!["rotate_y".to_string()]),
            "{lines:?}\n{stderr}"
        );
        // The neutral was measured before anything could move, and said.
        assert!(
            stderr.contains("neutral 2.5000 V measured at rest (noise 0.0000 V rms"),
            "{stderr}"
        );
        // The port hung up: a fault at once, the run ended safely, exit 1.
        assert!(
            lines
                .iter()
                .any(|l| l
                    .contains(r#""event":"fault","reason":"sensor disconnected — arm stopped""#)),
            "{lines:?}"
        );
        assert_eq!(status.code(), Some(1), "{stderr}");
        let report: serde_json::Value = serde_json::from_str(lines.last().unwrap()).unwrap();
        assert_eq!(report["stop_reason"], "sensor ended", "{report}");
        assert_eq!(report["stream_ended_with_zero"], true);
        assert_eq!(report["control_thread_allocations"], 0);
        let errors = report["errors"].to_string();
        assert!(errors.contains("disconnected"), "{errors}");
        assert!(
            report["sensor"]
                .as_str()
                .unwrap()
                .contains("neutral 2.5000 V")
        );
    });
}

#[test]
fn the_neutral_waits_while_the_user_breathes_and_says_so() {
    crate::common::real_time(|| {
        // A puff during the first measurement, then rest: the neutral is
        // measured after it, and the puff is never a burst. The puff lasts
        // 2 s: longer than the pty's backlog (read at once when the port
        // opens) plus the port's period check plus a loaded machine's delays
        // before the measurement starts.
        const BREATHING: [(f64, u64); 4] = [(2.5, 300), (3.6, 2000), (2.5, 2500), (2.5, 500)];
        let pty = Pty::open();
        let path = format!("serial:{}", pty.path);
        let feeder = stream(pty, &BREATHING, 1, |v| format!("{v:.3}\r\n"));
        let run = Running::spawn(&["run", "--sensor", &path, "--config", &config()]);
        let (_, lines, stderr) = run.finish();
        feeder.join().unwrap();
        // Seen as a level that moved or as a rest level far from the
        // neutral, depending on where the window fell.
        assert!(
            stderr.contains("— please rest (no sip or puff); measuring again"),
            "{stderr}"
        );
        assert!(
            stderr.contains("neutral 2.5000 V measured at rest"),
            "{stderr}"
        );
        assert_eq!(bursts_and_modes(&lines), (vec![], vec![]), "{lines:?}");
    });
}

#[test]
fn the_flipmouse_dialect_is_started_and_its_rate_is_said() {
    crate::common::real_time(|| {
        // FLipMouse: nothing until `AT SR`, then a VALUES line every 50 ms.
        // A 50 ms source can still time a long puff and a 300 ms sip.
        const FLIP: [(f64, u64); 5] =
            [(2.5, 4000), (4.0, 900), (2.5, 600), (1.5, 300), (2.5, 2000)];
        let pty = Pty::open();
        let path = format!("serial:{}", pty.path);
        let dir = Scratch::new();
        let cfg = dir.join("flip.toml");
        std::fs::write(
            &cfg,
            "[detector]\nstale_ms = 1000\n[sensor.serial]\nformat = \"flipmouse\"\n",
        )
        .unwrap();
        let run = Running::spawn(&["run", "--sensor", &path, "--config", cfg.to_str().unwrap()]);
        let mut asked = Vec::new();
        let deadline = Instant::now() + Duration::from_secs(20);
        while !String::from_utf8_lossy(&asked).contains("AT SR\r") && Instant::now() < deadline {
            asked.extend(read_some(&pty.master, Duration::from_millis(100)));
        }
        assert!(
            String::from_utf8_lossy(&asked).contains("AT SR\r"),
            "{asked:?}"
        );
        let feeder = stream(pty, &FLIP, 50, |v| {
            format!("VALUES:{},0,0,0,0,0,0,0,1\r\n", (v / 5.0 * 1023.0).round())
        });
        let (_, lines, stderr) = run.finish();
        feeder.join().unwrap();
        assert!(stderr.contains("every 50 ms (20 per second)"), "{stderr}");
        assert!(stderr.contains("a 40 ms burst cannot be timed"), "{stderr}");
        assert_eq!(
            bursts_and_modes(&lines),
            (vec![-2, 1], vec!["rotate_y".to_string()]),
            "{lines:?}\n{stderr}"
        );
    });
}

#[test]
fn a_port_that_sends_nothing_is_an_error_at_start_saying_what_to_check() {
    let pty = Pty::open();
    let path = format!("serial:{},baud=9600", pty.path);
    let started = Instant::now();
    let run = Running::spawn(&["run", "--sensor", &path]);
    let (status, lines, stderr) = run.finish();
    drop(pty);
    assert_eq!(status.code(), Some(1), "{stderr}");
    assert!(lines.is_empty(), "nothing ran: {lines:?}");
    assert!(
        stderr.contains("sent nothing readable as `volts` in 2000 ms at 9600 baud"),
        "{stderr}"
    );
    assert!(stderr.contains("check the baud rate"), "{stderr}");
    assert!(started.elapsed() >= Duration::from_secs(2));
}

/// A head-worn IMU on a microcontroller printing `ax,ay,az,gx,gy,gz` at
/// 100 Hz (`[sensor.serial] format = "imu"`): a simulated person's nod
/// and wobble through the kernel's tty, read with the fixture's gesture
/// set. The nod selects translate_x, the wobble fires its home event;
/// then the port hangs up: an IMU fault at once, and the run ends at rest.
#[test]
fn a_serial_imu_streams_a_persons_gestures_then_a_disconnect_is_a_fault() {
    use sipnpuff::sim::head_gesture::GestureName;
    use sipnpuff::sim::imu_session::practice_session;
    use sipnpuff::sim::imu_user::ImuUser;

    let user = ImuUser::builtin("typical").unwrap();
    let session = practice_session(&user, &[GestureName::Nod, GestureName::Wobble], 1, 3);
    let lines: Vec<String> = session
        .samples
        .iter()
        .map(|(_, s)| {
            let v = s.values;
            format!("{},{},{},{},{},{}\r\n", v[0], v[1], v[2], v[3], v[4], v[5])
        })
        .collect();
    let dir = Scratch::new();
    let imu_config = dir.join("imu.toml");
    std::fs::write(&imu_config, "[sensor.serial]\nformat = \"imu\"\n").unwrap();
    crate::common::real_time(|| {
        let pty = Pty::open();
        let path = format!("serial:{}", pty.path);
        let lines = lines.clone();
        let feeder = std::thread::spawn(move || {
            let period = Duration::from_millis(10);
            let mut next = Instant::now();
            for line in &lines {
                if !write_all(&pty.master, line.as_bytes()) {
                    return;
                }
                next += period;
                if let Some(wait) = next.checked_duration_since(Instant::now()) {
                    std::thread::sleep(wait);
                }
            }
        });
        let run = Running::spawn(&[
            "run",
            "--sensor",
            &path,
            "--config",
            "fixtures/gesture-user/config.toml",
            "--config",
            imu_config.to_str().unwrap(),
            "--json",
        ]);
        let (status, lines, stderr) = run.finish();
        feeder.join().unwrap();
        let said = lines.join("\n");
        for event in [
            r#""event":"gesture","name":"nod""#,
            r#""event":"match","sequence":["nod"],"mode":"translate_x""#,
            r#""event":"match","sequence":["wobble"],"home_event":"lights_toggle""#,
            r#""event":"fault","reason":"IMU disconnected — arm stopped""#,
        ] {
            assert!(said.contains(event), "{event}\n{said}\n{stderr}");
        }
        assert_eq!(status.code(), Some(1), "{stderr}");
        let report: serde_json::Value = serde_json::from_str(lines.last().unwrap()).unwrap();
        assert_eq!(report["stop_reason"], "sensor ended", "{report}");
        assert_eq!(report["stream_ended_with_zero"], true);
        assert_eq!(report["control_thread_allocations"], 0);
        assert!(
            report["sensor"].as_str().unwrap().contains("format imu"),
            "{report}"
        );
    });
}

#[test]
fn an_iio_imu_is_read_through_its_sysfs_channels() {
    // A directory laid out as sysfs lays out an IIO IMU's: a head at
    // rest, gravity on z (±2 g: 0.000598 m/s² a count).
    let dir = Scratch::new();
    let device = dir.join("iio:device0");
    std::fs::create_dir_all(&device).unwrap();
    for (file, value) in [
        ("name", "mpu6050"),
        ("in_accel_x_raw", "12"),
        ("in_accel_y_raw", "-30"),
        ("in_accel_z_raw", "16400"),
        ("in_accel_scale", "0.000598"),
        ("in_anglvel_x_raw", "2"),
        ("in_anglvel_y_raw", "-1"),
        ("in_anglvel_z_raw", "0"),
        ("in_anglvel_scale", "0.000133090"),
    ] {
        std::fs::write(device.join(file), format!("{value}\n")).unwrap();
    }
    let sensor = format!("iio:{}", device.display());
    // A loaded test machine may starve the reader for a while: allowed
    // here, as shared-machine.toml allows the breath sensor.
    let loaded = dir.join("loaded.toml");
    std::fs::write(&loaded, "[gestures]\nstale_ms = 1000\n").unwrap();
    crate::common::real_time(|| {
        // Half a second: the values never change, and a second of that
        // would rightly be the frozen fault.
        let out = crate::common::sipnpuff()
            .args([
                "run",
                "--sensor",
                &sensor,
                "--config",
                "fixtures/gesture-user/config.toml",
                "--config",
                loaded.to_str().unwrap(),
                "--seconds",
                "0.5",
                "--no-display",
            ])
            .output()
            .unwrap();
        let (stdout, stderr) = (
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr),
        );
        assert_eq!(out.status.code(), Some(0), "{stderr}\n{stdout}");
        let said = format!("sensor: {sensor} (IMU ax,ay,az,gx,gy,gz; read 1000 times a second)");
        assert!(stdout.contains(&said), "{said}\n{stdout}");
        assert!(!stdout.contains("\"event\":\"fault\""), "{stdout}");
    });
}

/// `gestures record --sensor serial:PTY`: a live session guided in the
/// terminal, with a simulated person at the other end of the kernel's
/// tty who hears each prompt (read from the command's stderr) and nods
/// when asked, then moves as they ordinarily do for the minute asked.
/// The recording is kept, and the set made from it says the session's
/// five nods are each read as a nod.
#[test]
fn a_live_gesture_recording_is_guided_through_a_serial_imu() {
    use std::io::BufRead;
    use std::sync::mpsc;

    use sipnpuff::control::imu::ImuInput;
    use sipnpuff::gestures::guided::ORDINARY_ASKED_MS;
    use sipnpuff::gestures::guided::Say;
    use sipnpuff::sim::guided_imu_user::GuidedImuUser;
    use sipnpuff::sim::head_gesture::GestureName;
    use sipnpuff::sim::imu_user::ImuUser;

    let dir = Scratch::new();
    let config = dir.join("imu.toml");
    std::fs::write(&config, "[sensor.serial]\nformat = \"imu\"\n").unwrap();
    let (set, recording) = (dir.join("sam.toml"), dir.join("sam.csv"));
    crate::common::real_time(|| {
        let _ = std::fs::remove_file(&set);
        let _ = std::fs::remove_file(&recording);
        let pty = Pty::open();
        let port = format!("serial:{}", pty.path);
        let user = ImuUser::builtin("typical").unwrap();
        let mut person = GuidedImuUser::new(user, &[GestureName::Nod], 5);
        let (tell, hear) = mpsc::channel::<Say>();
        // The person: a sample every 10 ms from before the port is opened
        // (it must answer at once) until the command has ended.
        let feeder = std::thread::spawn(move || {
            let start = Instant::now();
            let mut tick = 0u64;
            loop {
                match hear.try_recv() {
                    Ok(say) => person.hear(tick, &say),
                    Err(mpsc::TryRecvError::Disconnected) => return,
                    Err(mpsc::TryRecvError::Empty) => {}
                }
                let now = start.elapsed().as_millis() as u64;
                while tick <= now {
                    if let ImuInput::Sample(s) = person.input(tick) {
                        let v = s.values;
                        let line =
                            format!("{},{},{},{},{},{}\r\n", v[0], v[1], v[2], v[3], v[4], v[5]);
                        if !write_all(&pty.master, line.as_bytes()) {
                            return;
                        }
                    }
                    tick += 1;
                }
                std::thread::sleep(Duration::from_millis(2));
            }
        });
        let mut command = crate::common::sipnpuff();
        command
            .args(["gestures", "record", "--gestures", "nod", "--sensor", &port])
            .arg("--config")
            .arg(&config)
            .arg("--out")
            .arg(&set)
            .stdin(std::process::Stdio::null())
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped());
        let mut child = crate::watchdog::spawn(&mut command);
        // The prompts the person hears, as a person reads them.
        let mut said = Vec::new();
        for line in std::io::BufReader::new(child.stderr.take().unwrap()).lines() {
            let line = line.unwrap();
            if line.starts_with("sipnpuff: nod — now (") {
                let example = line["sipnpuff: nod — now (".len()..]
                    .split(' ')
                    .next()
                    .and_then(|k| k.parse().ok())
                    .unwrap();
                let _ = tell.send(Say::Make {
                    gesture: 0,
                    example,
                    again: line.contains("no movement seen"),
                });
            } else if line.starts_with("sipnpuff: now move as you ordinarily do") {
                let _ = tell.send(Say::Ordinary {
                    ms: ORDINARY_ASKED_MS,
                });
            }
            said.push(line);
        }
        let status = crate::watchdog::wait(&mut child);
        let mut report = String::new();
        std::io::Read::read_to_string(&mut child.stdout.take().unwrap(), &mut report).unwrap();
        drop(tell);
        feeder.join().unwrap();
        let said = said.join("\n");
        assert_eq!(status.code(), Some(0), "{said}\n{report}");
        for step in [
            "sipnpuff: hold your head still, as you rest, for 3.5 s",
            "sipnpuff: nod — now (1 of 5)",
            "sipnpuff: nod — now (5 of 5)",
            "sipnpuff: now move as you ordinarily do for 61.0 s",
            "sipnpuff: done: the recording is over",
            "wrote the gesture set to",
        ] {
            assert!(said.contains(step), "{step}\n{said}");
        }
        assert_eq!(said.matches("  seen (").count(), 5, "{said}");
        assert!(
            report.contains("leave-one-out: 5/5 examples recognised as themselves"),
            "{report}"
        );
        // The set names the session's recording, which is kept.
        let text = std::fs::read_to_string(&set).unwrap();
        assert!(
            text.contains(&format!(
                "recording = {:?}",
                recording.display().to_string()
            )),
            "{text}"
        );
        let header = std::fs::read_to_string(&recording).unwrap();
        assert!(header.starts_with("tick,ax,ay,az,gx,gy,gz\n"));
    });
}
