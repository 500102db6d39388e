//! Motion, tick by tick: ramps and limits, rotations, the fingers' ends,
//! the workspace, save and go-to, proportional speed, a planner failure.

use super::*;
use crate::control::motion::workspace::Boundary;

fn command(mode: Mode, direction: Direction) -> ModeOutput {
    ModeOutput {
        state: ModeState::Command(mode),
        direction,
        strength_volts: 1.0,
        speed_fraction: None,
    }
}

/// Runs `ticks` ticks of one command, returning the outputs.
fn run(m: &mut Motion, tick: &mut Tick, c: ModeOutput, ticks: u64) -> Vec<MotionOutput> {
    (0..ticks)
        .map(|_| {
            *tick += 1;
            let mut out = MotionOutput::default();
            m.step(*tick, &c, &mut out);
            out
        })
        .collect()
}

fn events(outputs: &[MotionOutput]) -> Vec<MotionEvent> {
    outputs
        .iter()
        .flat_map(|o| o.events.into_iter().flatten())
        .collect()
}

/// Motion with the default limits, workspace and home pose.
fn motion() -> Motion {
    motion_with(|_, _| {})
}

/// Motion with the defaults changed by `edit`.
fn motion_with(edit: impl FnOnce(&mut MotionConfig, &mut HomeConfig)) -> Motion {
    let (mut limits, mut home) = (MotionConfig::default(), HomeConfig::default());
    edit(&mut limits, &mut home);
    Motion::new(&limits, &WorkspaceConfig::default(), &home)
}

const PUFF: Direction = Direction::Positive;
const SIP: Direction = Direction::Negative;
const STILL: Direction = Direction::Still;

#[test]
fn power_up_is_still() {
    let mut m = motion();
    let mut t = 0;
    let out = run(&mut m, &mut t, ModeOutput::default(), 100);
    assert!(
        out.iter()
            .all(|o| o.linear == [0.0; 3] && o.angular == [0.0; 3])
    );
    assert_eq!(out[99].pose, HomeConfig::default().pose());
}

#[test]
fn translation_ramps_holds_and_brakes_within_the_limits() {
    // A = 0.64 m/s², J = 12.8 m/s³: 0 → 0.2 m/s takes 0.05 + 0.2625 +
    // 0.05 = 0.3625 s, and braking from 0.2 m/s covers 0.2 · 0.3625 / 2
    // = 0.03625 m.
    let mut m = motion();
    let mut t = 0;
    let held = run(&mut m, &mut t, command(Mode::TranslateX, PUFF), 2000);
    assert!(held[361].linear[0] < 0.2);
    assert!(
        (held[362].linear[0] - 0.2).abs() < 1e-12,
        "{}",
        held[362].linear[0]
    );
    assert_eq!(held[1999].linear, [0.2, 0.0, 0.0]);
    let x_at_release = held[1999].pose.translation.x;
    let released = run(&mut m, &mut t, command(Mode::TranslateX, STILL), 600);
    assert!(released[361].linear[0] > 0.0);
    assert_eq!(released[362].linear, [0.0; 3]);
    let travelled = released[599].pose.translation.x - x_at_release;
    assert!((travelled - 0.03625).abs() < 1e-6, "{travelled}");
}

#[test]
fn rotation_is_about_the_tool_axis() {
    // Tool rotated 90° about base z: its x axis is the base y axis.
    let mut m = motion_with(|_, home| {
        home.home_rotation_vector_rad = [0.0, 0.0, std::f64::consts::FRAC_PI_2];
    });
    let mut t = 0;
    let out = run(&mut m, &mut t, command(Mode::RotateX, PUFF), 1000);
    let w = out[999].angular;
    assert!(
        w[0].abs() < 1e-12 && (w[1] - 1.07).abs() < 1e-12 && w[2].abs() < 1e-12,
        "{w:?}"
    );
    // The tool point does not move.
    assert_eq!(out[999].pose.translation, m.pose().translation);
    assert_eq!(
        out[999].pose.translation.vector,
        Vector3::new(0.21, -0.26, 0.48)
    );
}

#[test]
fn fingers_stop_at_their_ends() {
    let mut m = motion();
    let mut t = 0;
    let out = run(&mut m, &mut t, command(Mode::Fingers, SIP), 4000);
    assert_eq!(
        events(&out),
        [MotionEvent::WorkspaceLimit {
            boundary: Boundary::FingersClosed
        }]
    );
    let closed = out[3999].fingers;
    assert!(
        closed <= 6800.0 - FINGER_MARGIN && closed > 6800.0 - FINGER_MARGIN - 5.0,
        "{closed}"
    );
    assert_eq!(out[3999].fingers_velocity, 0.0);
    // Puff opens from there.
    let out = run(&mut m, &mut t, command(Mode::Fingers, PUFF), 500);
    assert!(out[499].fingers < closed - 500.0);
}

#[test]
fn a_resting_channel_skips_its_update_while_the_other_moves() {
    let mut m = motion();
    let mut t = 0;
    run(&mut m, &mut t, command(Mode::Fingers, STILL), 10);
    let arm_before = m.arm.skipped().get();
    run(&mut m, &mut t, command(Mode::Fingers, SIP), 300);
    assert_eq!(m.arm.skipped().get() - arm_before, 300, "the arm rests");
    run(&mut m, &mut t, command(Mode::Fingers, STILL), 500);
    let fingers_before = m.fingers.skipped().get();
    let out = run(&mut m, &mut t, command(Mode::TranslateX, PUFF), 300);
    assert!(out[299].linear[0] > 0.0);
    assert_eq!(m.fingers.skipped().get() - fingers_before, 300);
}

#[test]
fn the_table_stops_the_tool_at_the_margin() {
    let mut m = motion(); // z = 0.48, margin 5 mm
    let mut t = 0;
    let out = run(&mut m, &mut t, command(Mode::TranslateZ, SIP), 4000);
    assert_eq!(
        events(&out),
        [MotionEvent::WorkspaceLimit {
            boundary: Boundary::Table
        }]
    );
    let z = out[3999].pose.translation.z;
    assert!((0.005..0.006).contains(&z), "stopped at z = {z}");
    assert_eq!(out[3999].linear, [0.0; 3]);
    // Holding on moves nothing more; the other way is free.
    let out = run(&mut m, &mut t, command(Mode::TranslateZ, SIP), 500);
    assert_eq!(out[499].pose.translation.z, z);
    assert!(events(&out).is_empty(), "one event per hold");
    let out = run(&mut m, &mut t, command(Mode::TranslateZ, PUFF), 500);
    assert!(out[499].pose.translation.z > z + 0.01);
}

#[test]
fn the_base_sphere_stops_the_tool() {
    let mut m = motion_with(|_, home| home.home_position_m = [0.35, 0.0, 0.1]);
    let mut t = 0;
    let out = run(&mut m, &mut t, command(Mode::TranslateX, SIP), 3000);
    assert_eq!(
        events(&out),
        [MotionEvent::WorkspaceLimit {
            boundary: Boundary::Base
        }]
    );
    let p = out[2999].pose.translation.vector;
    let to_sphere = p.norm() - 0.2;
    assert!(
        to_sphere > 0.0 && (0.005..0.006).contains(&(p.x - 0.03f64.sqrt())),
        "{p:?}"
    );
}

#[test]
fn save_and_go_to_point() {
    let mut m = motion();
    let mut t = 0;
    // Nothing saved: nothing moves, and an event says why.
    let out = run(&mut m, &mut t, command(Mode::GotoPoint, PUFF), 200);
    assert_eq!(events(&out), [MotionEvent::NoSavedPoint]);
    assert!(out.iter().all(|o| o.linear == [0.0; 3]));
    run(&mut m, &mut t, command(Mode::GotoPoint, STILL), 10);
    let out = run(&mut m, &mut t, command(Mode::SavePoint, PUFF), 10);
    assert!(matches!(events(&out)[..], [MotionEvent::Saved { .. }]));
    let saved = m.saved().unwrap();
    run(&mut m, &mut t, command(Mode::SavePoint, STILL), 10);
    for (mode, ticks) in [
        (Mode::TranslateX, 1200),
        (Mode::TranslateY, 800),
        (Mode::RotateZ, 700),
        (Mode::RotateX, 500),
    ] {
        run(&mut m, &mut t, command(mode, PUFF), ticks);
        run(&mut m, &mut t, command(mode, STILL), 1000);
    }
    // Hold a puff: a straight line back, all axes arriving together.
    let out = run(&mut m, &mut t, command(Mode::GotoPoint, PUFF), 6000);
    let ev = events(&out);
    assert!(matches!(ev[0], MotionEvent::GotoStarted { .. }), "{ev:?}");
    assert_eq!(ev[1], MotionEvent::GotoReached);
    let end = out[5999].pose;
    assert!((end.translation.vector - saved.translation.vector).norm() < 1e-6);
    assert!(end.rotation.angle_to(&saved.rotation) < 1e-6);
    let start = out[0].pose.translation.vector;
    for o in &out {
        // On the line from start to goal.
        let p = o.pose.translation.vector - start;
        let line = saved.translation.vector - start;
        assert!(p.cross(&line).norm() / line.norm() < 1e-6);
        assert!(Vector3::from(o.linear).norm() <= 0.2 * (1.0 + 1e-9));
    }
    // At the point: a new puff says so and moves nothing.
    run(&mut m, &mut t, command(Mode::GotoPoint, STILL), 10);
    let out = run(&mut m, &mut t, command(Mode::GotoPoint, PUFF), 100);
    assert_eq!(events(&out), [MotionEvent::AlreadyAtSavedPoint]);
}

/// Saves the home pose, then moves 1.5 s forward and comes to rest.
fn save_then_move_away(m: &mut Motion, t: &mut Tick) {
    run(m, t, command(Mode::SavePoint, PUFF), 5);
    run(m, t, command(Mode::SavePoint, STILL), 5);
    run(m, t, command(Mode::TranslateX, PUFF), 1500);
    run(m, t, command(Mode::TranslateX, STILL), 1000);
}

#[test]
fn a_goto_resumes_from_rest_after_a_halt() {
    let mut m = motion();
    let mut t = 0;
    save_then_move_away(&mut m, &mut t);
    run(&mut m, &mut t, command(Mode::GotoPoint, PUFF), 500);
    m.halt(); // a stall: the arm stopped on its own
    let out = run(&mut m, &mut t, command(Mode::GotoPoint, PUFF), 4000);
    let one_tick_from_rest = m.limits().linear_jerk_mps3 * CYCLE_S * CYCLE_S;
    assert!(
        Vector3::from(out[0].linear).norm() <= one_tick_from_rest,
        "from rest"
    );
    let ev = events(&out);
    assert!(matches!(ev[0], MotionEvent::GotoStarted { .. }), "{ev:?}");
    assert_eq!(ev[1], MotionEvent::GotoReached);
    let goal = m.saved().unwrap().translation.vector;
    assert!((m.pose().translation.vector - goal).norm() < 1e-6);
}

#[test]
fn releasing_a_goto_brakes_along_the_line() {
    let mut m = motion();
    let mut t = 0;
    save_then_move_away(&mut m, &mut t);
    run(&mut m, &mut t, command(Mode::TranslateZ, SIP), 1000);
    run(&mut m, &mut t, command(Mode::TranslateZ, STILL), 1000);
    let start = m.pose().translation.vector;
    let goal = m.saved().unwrap().translation.vector;
    run(&mut m, &mut t, command(Mode::GotoPoint, PUFF), 800);
    let out = run(&mut m, &mut t, command(Mode::GotoPoint, STILL), 1000);
    assert_eq!(out[999].linear, [0.0; 3]);
    let p = out[999].pose.translation.vector;
    assert!(
        (p - start).cross(&(goal - start)).norm() < 1e-9,
        "stopped on the line"
    );
    assert!((p - goal).norm() > 0.01, "short of the goal");
}

#[test]
fn a_goto_through_the_base_sphere_stops_at_it() {
    // Save at (0.3, 0, 0.05), go round the base to (−0.3, 0, 0.05)
    // (0.2 m/s held T seconds moves 0.2·T m), then go back: the straight
    // line passes 0.05 m from the base, inside its 0.2 m sphere, which it
    // meets at x = −√(0.2² − 0.05²).
    let mut m = motion_with(|_, home| home.home_position_m = [0.3, 0.0, 0.05]);
    let mut t = 0;
    run(&mut m, &mut t, command(Mode::SavePoint, PUFF), 5);
    run(&mut m, &mut t, command(Mode::SavePoint, STILL), 5);
    for (mode, direction, ticks) in [
        (Mode::TranslateY, PUFF, 2000),
        (Mode::TranslateX, SIP, 3000),
        (Mode::TranslateY, SIP, 2000),
    ] {
        let out = run(&mut m, &mut t, command(mode, direction), ticks);
        assert!(events(&out).is_empty(), "{:?}", events(&out));
        run(&mut m, &mut t, command(mode, STILL), 1000);
    }
    let p = m.pose().translation.vector;
    assert!((p - Vector3::new(-0.3, 0.0, 0.05)).norm() < 1e-6, "{p:?}");
    let out = run(&mut m, &mut t, command(Mode::GotoPoint, PUFF), 3000);
    let ev = events(&out);
    assert!(matches!(ev[0], MotionEvent::GotoStarted { .. }), "{ev:?}");
    assert_eq!(
        ev[1..],
        [MotionEvent::WorkspaceLimit {
            boundary: Boundary::Base
        }]
    );
    let p = m.pose().translation.vector;
    let sphere_x = -(0.2f64 * 0.2 - 0.05 * 0.05).sqrt();
    let gap = sphere_x - p.x;
    assert!(
        (0.005..0.006).contains(&gap),
        "{p:?}, {gap} m from the sphere"
    );
    assert_eq!(out[2999].linear, [0.0; 3]);
}

#[test]
fn proportional_speed_follows_the_pressure() {
    let mut m = motion_with(|limits, _| {
        limits.proportional_speed = true;
        limits.proportional_full_scale_volts = 1.0;
        limits.proportional_min_fraction = 0.25;
    });
    let mut t = 0;
    let mut half = command(Mode::TranslateX, PUFF);
    half.strength_volts = 0.5; // 0.25 + 0.75 · 0.5 = 62.5 % of 0.2 m/s
    let out = run(&mut m, &mut t, half, 2000);
    assert!(
        (out[1999].linear[0] - 0.125).abs() < 1e-12,
        "{}",
        out[1999].linear[0]
    );
}

/// When the planner fails, the arm still brakes within the jerk and
/// acceleration limits until still.
#[test]
fn a_planner_failure_brakes_within_the_limits_until_still() {
    let mut m = motion();
    let mut t = 0;
    run(&mut m, &mut t, command(Mode::TranslateX, SIP), 1000);
    let l = *m.limits();
    m.arm.break_planner(); // the planner fails from now on
    let out = run(&mut m, &mut t, command(Mode::TranslateX, STILL), 1000);
    assert!(events(&out).contains(&MotionEvent::TrajectoryError));
    let v: Vec<f64> = out.iter().map(|o| o.linear[0]).collect();
    for k in 2..v.len() {
        let a = (v[k] - v[k - 1]) / CYCLE_S;
        let j = (v[k] - 2.0 * v[k - 1] + v[k - 2]) / (CYCLE_S * CYCLE_S);
        assert!(
            a.abs() <= l.linear_acceleration_mps2 * (1.0 + 1e-9),
            "a {a} at {k}"
        );
        assert!(
            j.abs() <= l.linear_jerk_mps3 * (1.0 + 1e-9) + 1e-9,
            "jerk {j} at {k}"
        );
    }
    let stop_ms = (l.linear_speed_mps / l.linear_acceleration_mps2
        + l.linear_acceleration_mps2 / l.linear_jerk_mps3)
        * 1000.0;
    let still = out.iter().position(|o| o.is_still()).expect("stops");
    assert!(still as f64 <= stop_ms + 2.0, "still after {still} ms");
}
