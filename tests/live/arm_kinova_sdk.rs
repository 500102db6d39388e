//! `--arm kinova-sdk:usb|eth` against a stand-in for Kinova's command layer
//! (`tests/peers/kinova_sdk/standin.c`, built here with the system's C
//! compiler into the two file names Kinova's SDK uses). The stand-in
//! records every call with its arguments and a CLOCK_MONOTONIC time, and
//! integrates the commanded velocity into the pose `GetCartesianPosition`
//! returns. It proves the calls and values sipnpuff makes, not the real
//! library's behaviour.
//!
//! Skipped with a notice when no C compiler is found, unless
//! `SIPNPUFF_REQUIRE_PEERS=1` (CI), where that is a failure.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use nalgebra::{UnitQuaternion, Vector3};
use serde_json::Value;
use sipnpuff::arm::kinova_sdk::abi::{
    CartesianPosition, EthernetCommConfig, KinovaDevice, TrajectoryPoint, UserPosition,
};

use crate::common::{Running, assert_rate, have_peer, monotonic_ns, setting_granted};
use crate::peers::{Gaps, quantile, recorded_commands};
use crate::scratch::Scratch;

/// The stand-in's starting orientation (Euler XYZ, rad): not the identity,
/// so the conversion to a rotation is exercised end to end.
const START: [f64; 6] = [0.21, -0.26, 0.48, 0.3, -0.2, 1.0];

/// The C compiler: `$CC`, else `cc`, else `gcc`.
fn compiler() -> Option<String> {
    let candidates = std::env::var("CC")
        .ok()
        .into_iter()
        .chain(["cc".to_string(), "gcc".to_string()]);
    for cc in candidates {
        let ok = Command::new(&cc)
            .arg("--version")
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        if ok {
            return Some(cc);
        }
    }
    None
}

/// Runs a real-time test (see [`crate::common::real_time`]) with the
/// stand-in built with these extra `-D` defines; a notice (or, under
/// `SIPNPUFF_REQUIRE_PEERS=1`, a failure) when there is no C compiler.
fn kinova_test(defines: &[&str], test: impl Fn(&Standin)) {
    crate::common::real_time(|| {
        let Some(cc) = compiler() else {
            have_peer(Some(
                "no C compiler (cc, gcc or $CC) to build the Kinova SDK stand-in: run tests/peers/kinova_sdk/install.sh"
                    .into(),
            ));
            return;
        };
        test(&Standin::build(&cc, defines));
    });
}

/// The stand-in built into a test's scratch folder (`lib/`), where its
/// runs keep their config and the stand-in's log of calls.
struct Standin {
    dir: Scratch,
}

impl Standin {
    /// Builds the stand-in under both file names (USB and Ethernet, the
    /// latter with `Ethernet_` names) with `cc` and extra `-D` defines.
    fn build(cc: &str, defines: &[&str]) -> Standin {
        let source = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/peers/kinova_sdk/standin.c");
        let standin = Standin {
            dir: Scratch::new(),
        };
        std::fs::create_dir(standin.lib()).unwrap();
        for (file, ethernet) in [
            ("Kinova.API.USBCommandLayerUbuntu.so", false),
            ("Kinova.API.EthCommandLayerUbuntu.so", true),
        ] {
            let mut command = Command::new(cc);
            command.args([
                "-shared",
                "-fPIC",
                "-O2",
                "-Wall",
                "-Werror",
                "-fvisibility=hidden",
            ]);
            if ethernet {
                command.arg("-DSTANDIN_ETHERNET");
            }
            for define in defines {
                command.arg(format!("-D{define}"));
            }
            let output = command
                .arg("-o")
                .arg(standin.lib().join(file))
                .arg(&source)
                .args(["-lm", "-lpthread"])
                .output()
                .unwrap();
            assert!(
                output.status.success(),
                "building the stand-in failed:\n{}",
                String::from_utf8_lossy(&output.stderr)
            );
        }
        standin
    }

    /// The folder of the built library.
    fn lib(&self) -> PathBuf {
        self.dir.join("lib")
    }

    /// The stand-in's log of calls.
    fn log(&self) -> PathBuf {
        self.dir.join("calls.log")
    }

    /// The config: the library folder, the home pose the stand-in starts
    /// at, `arm` lines for `[arm]` and `extra` lines for
    /// `[arm.kinova_sdk]`.
    fn config(&self, library_dir: &Path, arm: &str, extra: &str) -> PathBuf {
        let rotation = euler_xyz(START[3], START[4], START[5]).scaled_axis();
        let path = self.dir.join("config.toml");
        std::fs::write(
            &path,
            format!(
                "[arm]\nhome_position_m = [{}, {}, {}]\nhome_rotation_vector_rad = [{}, {}, {}]\n{arm}\n\
                 [arm.feedback]\ntimeout_ms = {FEEDBACK_TIMEOUT_MS}\n\
                 [arm.kinova_sdk]\nlibrary_dir = {:?}\n{extra}\n",
                START[0],
                START[1],
                START[2],
                rotation.x,
                rotation.y,
                rotation.z,
                library_dir.display().to_string()
            ),
        )
        .unwrap();
        path
    }

    /// `sipnpuff run --arm ARM --json ARGS` with `config` and the
    /// stand-in's env.
    fn command(&self, arm: &str, config: &Path, env: &[(&str, &str)], args: &[&str]) -> Command {
        let mut command = crate::common::sipnpuff();
        command
            .args(["run", "--arm", arm, "--json", "--config"])
            .arg(config)
            .args(args)
            .env("KINOVA_STANDIN_LOG", self.log())
            .env("KINOVA_STANDIN_POSE", start_env())
            .envs(env.iter().copied())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        command
    }

    /// A run to its end with the library in `library_dir` and `extra`
    /// lines for `[arm.kinova_sdk]`.
    fn run_with(
        &self,
        library_dir: &Path,
        arm: &str,
        extra: &str,
        env: &[(&str, &str)],
        args: &[&str],
    ) -> Run {
        let config = self.config(library_dir, "", extra);
        let output = crate::watchdog::output(&mut self.command(arm, &config, env, args));
        crate::common::witness(&String::from_utf8_lossy(&output.stdout));
        Run {
            status: output.status,
            stdout: String::from_utf8_lossy(&output.stdout).into(),
            stderr: String::from_utf8_lossy(&output.stderr).into(),
            calls: read_log(&self.log()),
        }
    }

    /// [`Standin::run_with`] the stand-in's library.
    fn run(&self, arm: &str, extra: &str, env: &[(&str, &str)], args: &[&str]) -> Run {
        self.run_with(&self.lib(), arm, extra, env, args)
    }

    /// A USB run of 1 s that fails with the stand-in told `env`: all it
    /// printed, and the calls' names.
    fn failed_start(&self, env: (&str, &str)) -> (String, Vec<String>) {
        let run = self.run("kinova-sdk:usb", "", &[env], &["--seconds", "1"]);
        assert!(!run.status.success());
        let names = run.names().iter().map(|n| n.to_string()).collect();
        (run.all(), names)
    }
}

/// One recorded call.
#[derive(Debug, Clone)]
struct Call {
    ns: u64,
    name: String,
    fields: HashMap<String, String>,
}

impl Call {
    fn f32(&self, key: &str) -> f32 {
        self.fields[key].parse().unwrap()
    }
    fn int(&self, key: &str) -> i64 {
        self.fields[key].parse().unwrap()
    }
    fn is_zero_point(&self) -> bool {
        ["x", "y", "z", "tx", "ty", "tz", "f1", "f2", "f3"]
            .iter()
            .all(|k| self.f32(k) == 0.0)
    }
}

fn read_log(path: &Path) -> Vec<Call> {
    let Ok(text) = std::fs::read_to_string(path) else {
        return Vec::new();
    };
    text.lines()
        .map(|line| {
            let mut words = line.split(' ');
            let ns = words.next().unwrap().parse().unwrap();
            let name = words.next().unwrap().to_string();
            let fields = words
                .filter_map(|w| w.split_once('='))
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect();
            Call { ns, name, fields }
        })
        .collect()
}

/// A finished run.
struct Run {
    status: std::process::ExitStatus,
    stdout: String,
    stderr: String,
    calls: Vec<Call>,
}

impl Run {
    fn report(&self) -> Value {
        let line = self
            .stdout
            .lines()
            .rev()
            .find(|l| l.contains("\"arm_backend\""))
            .unwrap_or_else(|| panic!("no report:\n{}\n{}", self.stdout, self.stderr));
        serde_json::from_str(line).unwrap()
    }
    fn names(&self) -> Vec<&str> {
        self.calls.iter().map(|c| c.name.as_str()).collect()
    }
    fn sends(&self) -> Vec<&Call> {
        self.calls
            .iter()
            .filter(|c| c.name.ends_with("SendAdvanceTrajectory"))
            .collect()
    }
    fn all(&self) -> String {
        format!("{}\n{}", self.stdout, self.stderr)
    }
}

/// These tests are about the SDK's calls, not the pose's silence: a loaded
/// test machine once starved the SDK thread past the default 250 ms (an
/// arm fault, rightly); 1 s keeps them about what they test.
const FEEDBACK_TIMEOUT_MS: u32 = 1000;

/// R = Rx(tx)·Ry(ty)·Rz(tz), as kinova-ros reads Kinova's angles.
fn euler_xyz(tx: f64, ty: f64, tz: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::x_axis(), tx)
        * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), ty)
        * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), tz)
}

fn start_env() -> String {
    START.map(|v| v.to_string()).join(",")
}

/// The connection's calls, in order (kinova-ros's start, stop, start).
const CONNECT: [&str; 9] = [
    "InitAPI",
    "GetDevices",
    "SetActiveDevice",
    "StartControlAPI",
    "StopControlAPI",
    "StartControlAPI",
    "SetCartesianControl",
    "EraseAllTrajectories",
    "GetCartesianPosition",
];

/// The stop's calls, after the zero point and its measurement.
const STOP: [&str; 3] = ["EraseAllTrajectories", "StopControlAPI", "CloseAPI"];

#[test]
fn usb_streams_the_cores_commands_at_100_hz_and_reads_the_measured_pose() {
    kinova_test(&[], |standin| {
        let record = standin.dir.join("rec");
        let run = standin.run(
            "kinova-sdk:usb",
            "",
            &[],
            &["--seconds", "8", "--record", record.to_str().unwrap()],
        );
        assert!(run.status.success(), "{}", run.all());
        let report = run.report();
        assert_eq!(report["errors"], serde_json::json!([]), "{}", run.all());
        assert_eq!(report["stream_ended_with_zero"], true);
        assert_eq!(report["drops"]["arm_commands"], 0);
        assert_eq!(report["drops"]["recorded_commands"], 0);
        // The SDK's worker carries every point: it runs at the arm
        // thread's priority whenever the arm thread does.
        assert_eq!(
            setting_granted(&report, "kinova-sdk thread: SCHED_FIFO priority 60"),
            setting_granted(&report, "arm thread: SCHED_FIFO priority 60")
        );

        // The layouts the C compiler made of the headers' declarations.
        let init = &run.calls[0];
        for (key, size) in [
            ("sizeof_trajectory_point", size_of::<TrajectoryPoint>()),
            ("sizeof_user_position", size_of::<UserPosition>()),
            ("sizeof_cartesian_position", size_of::<CartesianPosition>()),
            ("sizeof_kinova_device", size_of::<KinovaDevice>()),
            (
                "sizeof_ethernet_comm_config",
                size_of::<EthernetCommConfig>(),
            ),
            (
                "offset_limitations",
                std::mem::offset_of!(TrajectoryPoint, Limitations),
            ),
            (
                "offset_hand_mode",
                std::mem::offset_of!(UserPosition, HandMode),
            ),
        ] {
            assert_eq!(init.int(key) as usize, size, "{key}");
        }

        // The sequence: connect; a point and a measurement per command; the
        // zero point; the stop.
        let names = run.names();
        assert_eq!(names[..CONNECT.len()], CONNECT, "{names:?}");
        assert_eq!(names[names.len() - 3..], STOP, "{names:?}");
        let streamed = &names[CONNECT.len()..names.len() - 3];
        assert!(
            streamed
                .iter()
                .all(|n| *n == "SendAdvanceTrajectory" || *n == "GetCartesianPosition"),
            "{streamed:?}"
        );
        assert_eq!(streamed.last(), Some(&"GetCartesianPosition"));
        assert!(
            run.calls
                .iter()
                .all(|c| c.fields.get("returns").or(c.fields.get("result")).unwrap() == "1"),
            "every call succeeded"
        );

        // Every command the core made, as f32, in order; then one zero point.
        let commands = recorded_commands(&record);
        let sends = run.sends();
        assert_eq!(report["arm_commands"], commands.len() as u64);
        assert_eq!(sends.len(), commands.len() + 1, "the commands and one zero");
        let mut moving = 0;
        for (send, command) in sends.iter().zip(&commands) {
            let want = [
                command.linear[0] as f32,
                command.linear[1] as f32,
                command.linear[2] as f32,
                command.angular[0] as f32,
                command.angular[1] as f32,
                command.angular[2] as f32,
                command.fingers as f32,
                command.fingers as f32,
                command.fingers as f32,
            ];
            let got = ["x", "y", "z", "tx", "ty", "tz", "f1", "f2", "f3"].map(|k| send.f32(k));
            assert_eq!(got, want, "point {} vs {command:?}", send.int("n"));
            moving += usize::from(!command.is_zero());
        }
        assert!(
            moving > 50,
            "the scripted user moved the arm ({moving} points)"
        );
        for send in &sends {
            assert_eq!(send.int("type"), 7, "CARTESIAN_VELOCITY");
            assert_eq!(send.int("hand_mode"), 2, "VELOCITY_MODE");
            assert_eq!(send.f32("delay"), 0.0);
            assert_eq!(send.fields["actuators"], "0,0,0,0,0,0,0");
            assert_eq!(send.int("limitations_active"), 0);
            assert_eq!(send.int("synchro"), 0);
            assert_eq!(send.fields["limitations"], "0,0,0,0,0,0,0,0,0");
            assert_eq!((send.int("control"), send.int("cartesian")), (1, 1));
        }
        assert!(sends.last().unwrap().is_zero_point());

        // 100 Hz at the library, over the stream (the core's ticks).
        let stream = &sends[..sends.len() - 1];
        let times: Vec<i64> = stream.iter().map(|s| s.ns as i64).collect();
        let gaps = Gaps::of(&times);
        let rate = gaps.rate_hz();
        eprintln!(
            "kinova-sdk:usb at the stand-in: {} points, {rate:.3} Hz; interval p50 {:.3} ms, \
         p99 {:.3} ms, min {:.3} ms, max {:.3} ms",
            stream.len(),
            gaps.quantile(0.5),
            gaps.quantile(0.99),
            gaps.quantile(0.0),
            gaps.quantile(1.0)
        );
        assert_rate(rate, &report);
        // Each point's time at the library against its core tick (1 ms each):
        // the spread of that offset is the jitter the path to the library adds.
        let mut offsets: Vec<f64> = stream
            .iter()
            .zip(&commands)
            .map(|(s, c)| s.ns as f64 / 1e6 - c.tick as f64)
            .collect();
        offsets.sort_by(f64::total_cmp);
        let base = offsets[0];
        eprintln!(
            "kinova-sdk:usb point time minus its core tick, above the smallest: p50 {:.3} ms, p99 \
         {:.3} ms, max {:.3} ms",
            quantile(&offsets, 0.5) - base,
            quantile(&offsets, 0.99) - base,
            offsets[offsets.len() - 1] - base
        );

        // The measured pose: the last GetCartesianPosition, Euler XYZ.
        let last = run
            .calls
            .iter()
            .rev()
            .find(|c| c.name == "GetCartesianPosition")
            .unwrap();
        let arm = &report["arm"];
        for (i, k) in ["x", "y", "z"].iter().enumerate() {
            assert_eq!(
                arm["position_m"][i].as_f64().unwrap(),
                f64::from(last.f32(k))
            );
        }
        assert!(
            f64::from(last.f32("x")) > START[0] + 0.05,
            "it moved: {last:?}"
        );
        let want = euler_xyz(
            f64::from(last.f32("tx")),
            f64::from(last.f32("ty")),
            f64::from(last.f32("tz")),
        )
        .scaled_axis();
        for i in 0..3 {
            let got = arm["rotation_vector_rad"][i].as_f64().unwrap();
            assert!((got - want[i]).abs() < 1e-9, "{got} vs {want:?}");
        }
        assert_eq!(arm["fingers"].as_f64(), Some(f64::from(last.f32("f1"))));
    });
}

#[test]
fn eth_uses_the_ethernet_layer_with_the_configured_addresses() {
    kinova_test(&[], |standin| {
        let run = standin.run(
            "kinova-sdk:eth",
            "local_ip = \"10.1.2.3\"\nsubnet_mask = \"255.255.0.0\"\nrobot_ip = \"10.1.9.8\"\n\
         robot_port = 55001\nlocal_cmd_port = 25001\nlocal_broadcast_port = 25026",
            &[],
            &["--seconds", "1"],
        );
        assert!(run.status.success(), "{}", run.all());
        assert_eq!(run.report()["stream_ended_with_zero"], true);
        let names = run.names();
        assert!(
            names.iter().all(|n| n.starts_with("Ethernet_")),
            "{names:?}"
        );
        let bare: Vec<&str> = names.iter().map(|n| &n["Ethernet_".len()..]).collect();
        let mut connect = CONNECT.to_vec();
        connect[0] = "InitEthernetAPI";
        assert_eq!(bare[..connect.len()], connect, "{bare:?}");
        assert_eq!(bare[bare.len() - 3..], STOP);
        let init = &run.calls[0];
        for (key, value) in [
            ("local_ip", "10.1.2.3"),
            ("subnet_mask", "255.255.0.0"),
            ("robot_ip", "10.1.9.8"),
            ("robot_port", "55001"),
            ("local_cmd_port", "25001"),
            ("local_broadcast_port", "25026"),
            ("rx_timeout_ms", "1000"),
        ] {
            assert_eq!(init.fields[key], value, "{key}");
        }
        assert!(run.sends().last().unwrap().is_zero_point());
    });
}

#[test]
fn a_failing_send_is_a_lost_link_and_the_arm_is_still_stopped() {
    kinova_test(&[], |standin| {
        let run = standin.run(
            "kinova-sdk:usb",
            "",
            &[
                // Mid-motion, whenever that is on a loaded machine: the
                // 51st point that moves fails, and every call after it.
                ("KINOVA_STANDIN_FAIL_MOVING_AFTER", "50"),
                ("KINOVA_STANDIN_FAIL_CODE", "1022"),
            ],
            // The failure ends the run (about 8 s in); the limit only has
            // to outlast a loaded machine's skipped ticks.
            &["--seconds", "30"],
        );
        assert!(!run.status.success(), "{}", run.all());
        let report = run.report();
        let errors = report["errors"].to_string();
        assert!(
            errors.contains("arm disconnected")
                && errors.contains("SendAdvanceTrajectory returned 1022 (ERROR_COMM_TIMEOUT"),
            "{errors}"
        );
        // The failure at the 51st moving point; nothing moving after it;
        // the zero point tried; the stop made.
        let sends = run.sends();
        let failed = sends.iter().position(|s| s.int("returns") != 1).unwrap();
        let moving = sends[..=failed].iter().filter(|s| !s.is_zero_point());
        assert_eq!(moving.count(), 51);
        assert!(!sends[failed].is_zero_point(), "it failed mid-motion");
        assert!(sends[failed + 1..].iter().all(|s| s.is_zero_point()));
        assert_eq!(sends.len(), failed + 2, "one zero point after the failure");
        let names = run.names();
        assert_eq!(names[names.len() - 3..], STOP, "{names:?}");
        assert_eq!(
            report["stream_ended_with_zero"], false,
            "the zero point failed too: not reported as sent"
        );
    });
}

#[test]
fn a_hanging_call_is_a_lost_link_within_the_call_timeout() {
    kinova_test(&[], |standin| {
        let run = standin.run(
            "kinova-sdk:usb",
            "call_timeout_ms = 50",
            &[("KINOVA_STANDIN_HANG_SEND_AFTER", "100")],
            &["--seconds", "4"],
        );
        assert!(!run.status.success(), "{}", run.all());
        let errors = run.report()["errors"].to_string();
        assert!(
            errors.contains("SendAdvanceTrajectory has not returned for")
                && errors.contains("call_timeout_ms"),
            "{errors}"
        );
        assert_eq!(run.sends().len(), 101, "nothing after the hanging call");
    });
}

#[test]
fn init_failure_says_what_to_check_and_touches_nothing_else() {
    kinova_test(&[], |standin| {
        let (all, names) = standin.failed_start(("KINOVA_STANDIN_INIT_CODE", "1015"));
        assert!(
            all.contains("InitAPI returned 1015 (ERROR_NO_DEVICE_FOUND")
                && all.contains("no JACO2 found on USB")
                && all.contains("10-kinova-arm.rules"),
            "{all}"
        );
        assert_eq!(names, ["InitAPI"]);
    });
}

#[test]
fn no_arm_found_is_a_clear_error_and_the_api_is_closed() {
    kinova_test(&[], |standin| {
        let (all, names) = standin.failed_start(("KINOVA_STANDIN_DEVICES", "0"));
        assert!(
            all.contains("GetDevices found no device") && all.contains("is it powered"),
            "{all}"
        );
        assert_eq!(names, ["InitAPI", "GetDevices", "CloseAPI"]);
    });
}

#[test]
fn an_init_that_never_returns_gives_up_after_the_connect_timeout() {
    kinova_test(&[], |standin| {
        let config = standin.config(&standin.lib(), "connect_timeout_ms = 300", "");
        let output = crate::watchdog::output(&mut standin.command(
            "kinova-sdk:usb",
            &config,
            &[("KINOVA_STANDIN_INIT_DELAY_MS", "20000")],
            &["--seconds", "1"],
        ));
        let all = format!(
            "{}{}",
            String::from_utf8_lossy(&output.stdout),
            String::from_utf8_lossy(&output.stderr)
        );
        assert!(!output.status.success());
        assert!(
            all.contains("InitAPI did not return within 300 ms")
                && all.contains("connect_timeout_ms")
                && all.contains("is it powered and plugged in"),
            "{all}"
        );
    });
}

#[test]
fn a_missing_library_or_symbol_is_named() {
    kinova_test(&["STANDIN_OMIT_SEND"], |standin| {
        let empty = standin.dir.join("empty");
        std::fs::create_dir(&empty).unwrap();
        let run1 = standin.run_with(&empty, "kinova-sdk:usb", "", &[], &["--seconds", "1"]);
        assert!(!run1.status.success());
        let all = run1.all();
        assert!(
            all.contains("Kinova.API.USBCommandLayerUbuntu.so")
                && all.contains(&empty.display().to_string())
                && all.contains("JACO SDK installer")
                && all.contains("kinova_driver/lib/")
                && all.contains("[arm.kinova_sdk] library_dir"),
            "{all}"
        );
        let run2 = standin.run("kinova-sdk:eth", "", &[], &["--seconds", "1"]);
        assert!(!run2.status.success());
        let all = run2.all();
        assert!(
            all.contains("has no symbol `Ethernet_SendAdvanceTrajectory`"),
            "{all}"
        );
        assert!(run2.calls.is_empty(), "nothing was called");
    });
}

#[test]
fn sigint_mid_motion_sends_a_zero_point_then_closes() {
    kinova_test(&[], |standin| {
        let config = standin.config(&standin.lib(), "", "");
        let mut run =
            Running::start(standin.command("kinova-sdk:usb", &config, &[], &["--seconds", "30"]));
        // 0.9 s into the scripted user's 1.5 s puff: moving.
        run.wait_until_moving();
        let sigint_ns = monotonic_ns() as u64;
        run.signal(libc::SIGINT);
        let (status, lines, stderr) = run.finish();
        assert_eq!(status.code(), Some(130), "{lines:?}\n{stderr}");
        let calls = read_log(&standin.log());
        let sends: Vec<&Call> = calls
            .iter()
            .filter(|c| c.name == "SendAdvanceTrajectory")
            .collect();
        let moving_at_signal = sends
            .iter()
            .rev()
            .find(|s| s.ns <= sigint_ns)
            .is_some_and(|s| !s.is_zero_point());
        assert!(moving_at_signal, "the arm was moving at the signal");
        let last = sends.last().unwrap();
        assert!(last.is_zero_point() && last.ns > sigint_ns);
        let names: Vec<&str> = calls.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names[names.len() - 3..], STOP);
        let close = calls.last().unwrap();
        // Points after the signal: the core's brake (non-zero, decelerating),
        // then zeros; the stream's own zero point is the last.
        let first_zero = sends
            .iter()
            .find(|s| s.ns > sigint_ns && s.is_zero_point())
            .unwrap();
        // The brake's start: the first point after the signal slower than
        // the one before it.
        let speed = |s: &Call| {
            ["x", "y", "z"]
                .map(|k| f64::from(s.f32(k)).powi(2))
                .iter()
                .sum::<f64>()
                .sqrt()
        };
        let braking = sends
            .windows(2)
            .find(|w| w[1].ns > sigint_ns && speed(w[1]) < speed(w[0]))
            .map(|w| w[1])
            .unwrap();
        eprintln!(
            "kinova-sdk stop latency at the stand-in: SIGINT → first slower point {:.1} ms, → first \
         zero point {:.1} ms, → the stream's final zero point {:.1} ms, → CloseAPI {:.1} ms \
         ({} points after the signal)",
            (braking.ns - sigint_ns) as f64 / 1e6,
            (first_zero.ns - sigint_ns) as f64 / 1e6,
            (last.ns - sigint_ns) as f64 / 1e6,
            (close.ns - sigint_ns) as f64 / 1e6,
            sends.iter().filter(|s| s.ns > sigint_ns).count()
        );
    });
}
