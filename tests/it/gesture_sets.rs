//! Gesture sets made from simulated people's protocol recordings, checked
//! by leave-one-out, then scored on held-out sessions of the same people
//! (practice: each gesture 30 times; an hour of ordinary movement): each
//! gesture read right, and ordinary movement taken for none.

use std::path::PathBuf;

use crate::common::{assert_exit, refused, sipnpuff_output as sipnpuff};
use crate::scratch::Scratch;
use sipnpuff::control::gesture::GestureConfig;
use sipnpuff::control::imu::{Channel, Channels};
use sipnpuff::gestures::record::record;
use sipnpuff::sim::head_gesture::GestureName;
use sipnpuff::sim::imu_session::{ImuSession, practice_session, protocol_session, use_session};
use sipnpuff::sim::imu_user::ImuUser;
use sipnpuff::tools::gesture_accuracy::{Made, score};
use sipnpuff::tools::imu_csv::write_imu_csv;

fn names(gestures: &[GestureName]) -> Vec<String> {
    gestures.iter().map(|g| g.name().to_string()).collect()
}

fn made(session: &ImuSession) -> Vec<Made> {
    session
        .truth
        .iter()
        .map(|t| Made {
            name: t.name.name().to_string(),
            start: t.start,
            end: t.end,
        })
        .collect()
}

fn ordinary_ms(session: &ImuSession) -> u64 {
    session.ordinary.iter().map(|(a, b)| b - a).sum()
}

#[test]
fn figures_per_user() {
    let gestures = GestureName::DEFAULT;
    for user in ImuUser::all() {
        let protocol = protocol_session(&user, &gestures, 1);
        let recorded = match record(
            &protocol.samples,
            protocol.channels,
            &names(&gestures),
            GestureConfig::default(),
            None,
        ) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("{}: {e}", user.name);
                continue;
            }
        };
        let check = sipnpuff::gestures::check::check(&recorded.set, &[]);
        let clock = std::time::Instant::now();
        let held_out = practice_session(&user, &gestures, 30, 2);
        let generated = clock.elapsed().as_secs_f64();
        let s = score(
            &recorded.set,
            &held_out.samples,
            &made(&held_out),
            ordinary_ms(&held_out),
        )
        .unwrap();
        let ordinary = use_session(&user, &[], 60, 3);
        let o = score(
            &recorded.set,
            &ordinary.samples,
            &[],
            ordinary_ms(&ordinary),
        )
        .unwrap();
        eprintln!(
            "{}: loo {}/{}; held-out {}/{} ({}); false {} in {:.2} h + {} in {:.2} h; \
             practice made in {generated:.2} s",
            user.name,
            check.right,
            check.examples,
            s.gestures.iter().map(|g| g.right).sum::<usize>(),
            s.gestures.iter().map(|g| g.made).sum::<usize>(),
            s.gestures
                .iter()
                .map(|g| format!(
                    "{} {}/{} (c{} m{})",
                    g.name, g.right, g.made, g.confused, g.missed
                ))
                .collect::<Vec<_>>()
                .join(", "),
            s.false_activations.len(),
            s.ordinary_hours,
            o.false_activations.len(),
            o.ordinary_hours
        );
        let mut by: std::collections::BTreeMap<&str, usize> = Default::default();
        for (_, name) in o.false_activations.iter().chain(&s.false_activations) {
            *by.entry(name.as_str()).or_default() += 1;
        }
        eprintln!(
            "   false by gesture: {by:?}; at {:?}",
            o.false_activations.iter().take(5).collect::<Vec<_>>()
        );
    }
}

/// The gestures ordinary movement does not imitate, scored per user as
/// the targets ask: leave-one-out, a held-out hour of use, and false
/// activations per gesture on an hour of ordinary movement. Prints only.
/// `SIPNPUFF_GESTURES=a,b` scores other gestures.
#[test]
fn figures_for_the_targets() {
    let gestures: Vec<GestureName> = match std::env::var("SIPNPUFF_GESTURES") {
        Ok(list) => list
            .split(',')
            .map(|n| {
                *GestureName::ALL
                    .iter()
                    .find(|g| g.name() == n)
                    .unwrap_or_else(|| panic!("no gesture {n}"))
            })
            .collect(),
        Err(_) => vec![
            GestureName::Nod,
            GestureName::DoubleNod,
            GestureName::Shake,
            GestureName::TiltLeft,
            GestureName::TiltRight,
        ],
    };
    for user in ImuUser::all() {
        let protocol = protocol_session(&user, &gestures, 1);
        let recorded = match record(
            &protocol.samples,
            protocol.channels,
            &names(&gestures),
            GestureConfig::default(),
            None,
        ) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("{}: does not record: {e}", user.name);
                continue;
            }
        };
        let check = sipnpuff::gestures::check::check(&recorded.set, &[]);
        let held_out = use_session(&user, &gestures, 60, 2);
        let s = score(
            &recorded.set,
            &held_out.samples,
            &made(&held_out),
            ordinary_ms(&held_out),
        )
        .unwrap();
        let ordinary = use_session(&user, &[], 60, 3);
        let o = score(
            &recorded.set,
            &ordinary.samples,
            &[],
            ordinary_ms(&ordinary),
        )
        .unwrap();
        let c = &recorded.set.config;
        eprintln!("   rest {:?}", recorded.rest);
        eprintln!(
            "{}: on {:.2} off {:.2} rad/s; loo {}/{}; false {:.1}/h ordinary, {:.1}/h in use",
            user.name,
            c.motion_on_rad_s,
            c.motion_off_rad_s,
            check.right,
            check.examples,
            o.false_activations.len() as f64 / o.ordinary_hours,
            s.false_activations.len() as f64 / s.ordinary_hours,
        );
        for (g, gesture) in s.gestures.iter().zip(&check.gestures) {
            let false_ordinary = o
                .false_activations
                .iter()
                .filter(|(_, n)| *n == g.name)
                .count();
            eprintln!(
                "   {:<11} loo {}/{}  held-out {}/{} (confused {}, missed {})  false {:.1}/h",
                g.name,
                gesture.right,
                gesture.examples,
                g.right,
                g.made,
                g.confused,
                g.missed,
                false_ordinary as f64 / o.ordinary_hours
            );
        }
    }
}

/// `session`'s samples as a CSV of `channels` in a new scratch folder.
fn csv(session: &ImuSession, channels: Channels, name: &str) -> (Scratch, PathBuf) {
    let dir = Scratch::new();
    let path = dir.join(name);
    let mut text = Vec::new();
    write_imu_csv(&mut text, channels, &session.samples).unwrap();
    std::fs::write(&path, text).unwrap();
    (dir, path)
}

fn run(args: &[&str]) -> (String, String) {
    let out = sipnpuff(args);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_exit(out.status, &stderr, 0, &args.join(" "));
    (String::from_utf8_lossy(&out.stdout).into_owned(), stderr)
}

#[test]
fn a_set_is_recorded_and_checked_from_the_command_line() {
    let user = ImuUser::builtin("typical").unwrap();
    let protocol = protocol_session(&user, &GestureName::DEFAULT, 1);
    let (dir, from) = csv(&protocol, Channels::ALL, "protocol.csv");
    let set = dir.join("set.toml");
    let list = names(&GestureName::DEFAULT).join(",");
    let (stdout, stderr) = run(&[
        "gestures",
        "record",
        "--from",
        from.to_str().unwrap(),
        "--gestures",
        &list,
        "--out",
        set.to_str().unwrap(),
    ]);
    assert!(stderr.contains("wrote the gesture set to"), "{stderr}");
    let first = stdout.lines().next().unwrap_or_default();
    assert!(first.starts_with("leave-one-out: "), "{stdout}");
    assert!(
        first.contains("/30 examples recognised as themselves ("),
        "{stdout}"
    );
    let written = std::fs::read_to_string(&set).unwrap();
    assert!(
        written.starts_with("# sipnpuff gesture set: 6 gestures × 5 examples from "),
        "{written}"
    );

    // Without recordings: the ordinary stretch of its own recording.
    let (again, _) = run(&["gestures", "check", set.to_str().unwrap()]);
    assert_eq!(again, stdout);

    let ordinary = use_session(&user, &[], 10, 3);
    let (_d, ordinary_csv) = csv(&ordinary, Channels::ALL, "ordinary.csv");
    let (json, _) = run(&[
        "gestures",
        "check",
        set.to_str().unwrap(),
        ordinary_csv.to_str().unwrap(),
        "--json",
    ]);
    let json: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(json["examples"], 30);
    assert_eq!(json["gestures"].as_array().unwrap().len(), 6);
    let hours = json["ordinary_hours"].as_f64().unwrap();
    assert!((hours - 10.0 / 60.0).abs() < 0.01, "{hours}");
}

#[test]
fn a_recording_off_the_protocol_is_refused_and_nothing_written() {
    let user = ImuUser::builtin("typical").unwrap();
    let gestures = [GestureName::Nod, GestureName::Shake];
    let protocol = protocol_session(&user, &gestures, 1);
    let (dir, from) = csv(&protocol, Channels::ALL, "protocol.csv");
    let set = dir.join("set.toml");
    let out = set.to_str().unwrap();
    let from = from.to_str().unwrap();
    let stderr = refused(&[
        "gestures",
        "record",
        "--from",
        from,
        "--gestures",
        "nod,shake,tilt_left",
        "--out",
        out,
    ]);
    assert!(stderr.contains("gesture 'tilt_left': example "), "{stderr}");
    assert!(
        stderr.contains(
            "the examples of 'nod', 'shake' were found before it: is 'tilt_left' in the recording?"
        ),
        "{stderr}"
    );
    let stderr = refused(&[
        "gestures",
        "record",
        "--from",
        from,
        "--gestures",
        "nod,Shake",
        "--out",
        out,
    ]);
    assert!(
        stderr.contains("--gestures: `Shake` is not a name"),
        "{stderr}"
    );
    assert!(!set.exists());

    let accel = Channels::of(&[Channel::Ax, Channel::Ay, Channel::Az]);
    let (_d, accel_only) = csv(&protocol, accel, "accel.csv");
    let stderr = refused(&[
        "gestures",
        "record",
        "--from",
        accel_only.to_str().unwrap(),
        "--gestures",
        "nod,shake",
        "--out",
        out,
    ]);
    assert!(
        stderr.contains("needs the angular rates too (missing: gx, gy, gz)"),
        "{stderr}"
    );
    assert!(!set.exists());

    run(&[
        "gestures",
        "record",
        "--from",
        from,
        "--gestures",
        "nod,shake",
        "--out",
        out,
    ]);
    let stderr = refused(&["gestures", "check", out, accel_only.to_str().unwrap()]);
    assert!(
        stderr.contains("a set from another sensor's channels"),
        "{stderr}"
    );
}
