//! `sipnpuff doctor`: what a run with the same options would get, each
//! device, output and address checked as the run would meet it, every
//! denial with its fix, exit status 1 when something needed is missing.
//! (What the real-time set-up gets depends on the user: tests/live.)

use std::net::TcpListener;

use sipnpuff::arm::ArmSpec;
use sipnpuff::config::Config;
use sipnpuff::output::OutputSpec;
use sipnpuff::rt::setup::RtOptions;
use sipnpuff::sensor::SensorSpec;
use sipnpuff::session::doctor::{Check, Examined, all_needed_granted, examine};

use crate::common::{fixture, sipnpuff_output};

/// The checks for `sensor` and `outputs`, the page at `page`, without
/// the real-time set-up.
fn doctor(sensor: &str, outputs: &[&str], page: Option<std::net::SocketAddr>) -> Vec<Check> {
    let sensor = SensorSpec::parse(sensor).unwrap();
    let outputs: Vec<OutputSpec> = outputs
        .iter()
        .map(|o| OutputSpec::parse(o).unwrap())
        .collect();
    examine(
        &Config::default(),
        &Examined {
            sensor: &sensor,
            imu: None,
            arm: &ArmSpec::Sim,
            outputs: &outputs,
            rt: RtOptions::NONE,
            page,
        },
    )
}

fn check<'a>(checks: &'a [Check], what: &str) -> &'a Check {
    checks
        .iter()
        .find(|c| c.what.starts_with(what))
        .unwrap_or_else(|| panic!("no check {what}: {checks:#?}"))
}

#[test]
fn a_readable_recording_and_a_free_page_are_all_a_run_needs() {
    let recording = fixture("demo.csv");
    let checks = doctor(&format!("csv:{}", recording.display()), &[], None);
    let sensor = check(&checks, "sensor csv:");
    assert!(sensor.ok && sensor.needed, "{sensor:?}");
    assert!(sensor.detail.contains("demo.csv"), "{sensor:?}");
    assert!(check(&checks, "arm sim").ok);
    assert!(all_needed_granted(&checks), "{checks:#?}");
}

#[test]
fn a_missing_sensor_an_unreachable_broker_and_a_taken_page_are_each_said_with_their_fix() {
    let taken = TcpListener::bind("127.0.0.1:0").unwrap();
    let closed = {
        let l = TcpListener::bind("127.0.0.1:0").unwrap();
        l.local_addr().unwrap().port()
    };
    let checks = doctor(
        "csv:/nonexistent/breaths.csv",
        &[&format!("mqtt:127.0.0.1:{closed}")],
        Some(taken.local_addr().unwrap()),
    );
    let sensor = check(&checks, "sensor csv:/nonexistent");
    assert!(!sensor.ok && sensor.needed, "{sensor:?}");
    assert!(
        sensor.detail.contains("/nonexistent/breaths.csv"),
        "{sensor:?}"
    );
    let broker = check(&checks, "output mqtt 127.0.0.1:");
    assert!(!broker.ok && broker.needed, "{broker:?}");
    assert!(broker.detail.contains("refused"), "{broker:?}");
    assert!(
        broker
            .fix
            .as_deref()
            .unwrap_or("")
            .contains("start the broker"),
        "{broker:?}"
    );
    // The page's address taken is said, but a run can go without a page.
    let page = check(&checks, "display 127.0.0.1:");
    assert!(!page.ok && !page.needed, "{page:?}");
    assert!(
        page.fix.as_deref().unwrap_or("").contains("holds it"),
        "{page:?}"
    );
    assert!(!all_needed_granted(&checks));
}

#[test]
fn doctor_exits_1_naming_each_denial_and_0_when_all_is_granted() {
    let missing = sipnpuff_output(&[
        "doctor",
        "--sensor",
        "csv:/nonexistent/breaths.csv",
        "--no-display",
        "--priority",
        "0",
        "--no-mlock",
    ]);
    let text = String::from_utf8_lossy(&missing.stdout);
    assert_eq!(missing.status.code(), Some(1), "{text}");
    assert!(
        text.contains("DENIED  sensor csv:/nonexistent/breaths.csv"),
        "{text}"
    );
    assert!(
        text.contains("1 needed thing DENIED: fix it before deploying"),
        "{text}"
    );
    let fine = sipnpuff_output(&[
        "doctor",
        "--no-display",
        "--priority",
        "0",
        "--no-mlock",
        "--json",
    ]);
    let json: serde_json::Value = serde_json::from_slice(&fine.stdout).unwrap();
    assert_eq!(fine.status.code(), Some(0), "{json}");
    assert_eq!(json["ready"], true, "{json}");
    assert!(
        json["user"].as_str().unwrap_or("").contains("uid"),
        "{json}"
    );
    let sensor = &json["checks"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["what"] == "sensor synthetic");
    assert!(sensor.is_some_and(|c| c["ok"] == true), "{json}");
}

#[test]
fn the_service_environment_names_the_backends_as_the_flags_do() {
    let mut command = crate::common::sipnpuff();
    command
        .args(["doctor", "--no-display", "--priority", "0", "--no-mlock"])
        .env("SIPNPUFF_SENSOR", "csv:/nonexistent/from-env.csv")
        .env("SIPNPUFF_OUTPUTS", "mqtt:127.0.0.1:1");
    let output = crate::watchdog::output(&mut command);
    let text = String::from_utf8_lossy(&output.stdout);
    assert!(
        text.contains("DENIED  sensor csv:/nonexistent/from-env.csv"),
        "{text}"
    );
    assert!(text.contains("DENIED  output mqtt 127.0.0.1:1"), "{text}");
    assert!(text.contains("2 needed things DENIED"), "{text}");
}
