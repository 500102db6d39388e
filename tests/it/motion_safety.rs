//! Motion-safety scenarios (a go-to or a new direction asked while the
//! arm brakes, two axes at once, slanted approaches to the boundaries, the
//! orientation limits, the stop after a release), each through the whole
//! pipeline — scripted breaths, the detector, the matcher, the mode
//! machine, motion and the simulated JACO — and checked tick by tick by
//! the motion invariants (`motion::check_invariants`: limits as vectors,
//! the stop margin as a normal distance, stopping after every release and
//! fault).

use nalgebra::Vector3;
use sipnpuff::config::Config;
use sipnpuff::control::action::Action;
use sipnpuff::control::event::Event;
use sipnpuff::control::mode::{Direction, Mode, ModeState};
use sipnpuff::control::motion::MotionEvent;
use sipnpuff::sim::script::{Timing, sequence_steps};
use sipnpuff::sim::sensor_model::{SignalGenerator, SignalParams, Step};

use crate::common::{puff, rest, sip};
use crate::motion::{Record, check_invariants, clearance, motion_events, run};

const DT: f64 = 0.001;

use crate::common::TickByTick;
use Action::{LongPuff, LongSip, ShortPuff, ShortSip};
const TRANSLATE_X: [Action; 2] = [ShortPuff, ShortPuff];
const TRANSLATE_Y: [Action; 2] = [ShortPuff, ShortSip];
const TRANSLATE_Z: [Action; 2] = [ShortSip, ShortSip];
const ROTATE_Y: [Action; 2] = [LongPuff, ShortSip];
const ROTATE_Z: [Action; 2] = [LongPuff, LongPuff];
const SAVE_POINT: [Action; 2] = [LongSip, ShortPuff];
const GOTO_POINT: [Action; 2] = [LongSip, ShortSip];

/// Enters `actions` with comfortable timings, then waits 300 ms.
fn select(actions: &[Action]) -> Vec<Step> {
    let mut steps = sequence_steps(actions, Timing::DEFAULT);
    steps.push(rest(300));
    steps
}

/// Plays `script` on a clean signal through the pipeline and the arm.
fn play(config: &Config, script: &[Step]) -> Vec<Record> {
    let params = SignalParams::clean(config.core().detector(), 7);
    run(config, SignalGenerator::new(params, script).map(Some))
}

fn config(toml: &str) -> Config {
    Config::from_toml_str(toml).unwrap_or_else(|e| panic!("{e}"))
}

fn speed(r: &Record) -> f64 {
    Vector3::from(r.out.motion.linear).norm()
}

/// The first tick with a puff held in goto_point.
fn goto_pressed(trace: &[Record]) -> usize {
    trace
        .iter()
        .position(|r| {
            r.out.command.state == ModeState::Command(Mode::GotoPoint)
                && r.out.command.direction == Direction::Positive
        })
        .expect("goto_point held")
}

fn no_trajectory_error(trace: &[Record]) {
    assert!(
        !motion_events(trace).contains(&MotionEvent::TrajectoryError),
        "the trajectory generator failed"
    );
}

/// Smallest normal distance to a boundary over the trace, m.
fn min_clearance(config: &Config, trace: &[Record]) -> f64 {
    trace
        .iter()
        .map(|r| clearance(config, &r.out.motion.pose.translation.vector))
        .fold(f64::INFINITY, f64::min)
}

/// Largest vector acceleration of the linear velocity, m/s².
fn max_linear_acceleration(trace: &[Record]) -> f64 {
    trace
        .windows(2)
        .map(|w| {
            (Vector3::from(w[1].out.motion.linear) - Vector3::from(w[0].out.motion.linear)).norm()
                / DT
        })
        .fold(0.0, f64::max)
}

/// The scenario of defect a: save a point, drive away and back and forth,
/// release, and select goto_point while the arm is still braking (with a
/// low acceleration limit braking lasts seconds).
#[test]
fn goto_pressed_while_braking_stays_inside_and_within_the_limits() {
    let config = config(
        "[motion]\nlinear_acceleration_mps2 = 0.05\n[arm]\nhome_position_m = [0.35, -0.26, 0.48]\n",
    );
    let mut script = vec![rest(500)];
    script.extend(select(&SAVE_POINT));
    script.extend([puff(150), rest(2100)]);
    script.extend(select(&TRANSLATE_Y));
    script.extend([puff(3000), rest(2100)]);
    script.extend(select(&TRANSLATE_X));
    script.extend([sip(4500), rest(2100)]);
    script.extend(sequence_steps(
        &GOTO_POINT,
        Timing {
            gap_ms: 100,
            ..Timing::DEFAULT
        },
    ));
    // Within max_hold_ms, so several times, 300 ms apart: each release
    // brakes, and the goto resumes from rest.
    for _ in 0..4 {
        script.extend([puff(5900), rest(300)]);
    }
    script.push(rest(5000));
    let trace = play(&config, &script);
    let pressed = goto_pressed(&trace);
    assert!(
        speed(&trace[pressed]) > 0.01,
        "the scenario presses goto_point while braking: {} m/s at tick {pressed}",
        speed(&trace[pressed])
    );
    no_trajectory_error(&trace);
    check_invariants(&config, &trace);
    // The go-to starts only once the arm has braked to rest.
    let started = trace
        .iter()
        .position(|r| {
            r.out
                .events
                .iter()
                .any(|e| matches!(e, Event::Motion(MotionEvent::GotoStarted { .. })))
        })
        .expect("the go-to starts");
    assert!(started > pressed && speed(&trace[started - 1]) == 0.0);
}

/// A short inactivity timeout and goto_point on [1, 1]: a
/// fast selection lands while the arm brakes from full speed.
#[test]
fn a_fast_goto_selection_while_braking_stays_inside() {
    let config = config(
        "[motion]\nlinear_acceleration_mps2 = 0.2\n[command]\ninactivity_timeout_ms = 300\n\
         [[sequence]]\nactions = [-1, -1]\nmode = \"translate_x\"\n\
         [[sequence]]\nactions = [2, -1]\nmode = \"save_point\"\n\
         [[sequence]]\nactions = [1, 1]\nmode = \"goto_point\"\n",
    );
    let fast = Timing {
        short_ms: 60,
        long_ms: 800,
        gap_ms: 60,
    };
    // Each breath within the 300 ms the mode waits for it.
    let quick = Timing {
        gap_ms: 100,
        ..Timing::DEFAULT
    };
    let mut script = vec![rest(500)];
    script.extend(sequence_steps(&SAVE_POINT, quick));
    script.extend([puff(150), rest(400)]);
    script.extend(sequence_steps(&TRANSLATE_X, quick));
    script.extend([sip(3000), rest(320)]);
    script.extend(sequence_steps(&[ShortSip, ShortSip], fast));
    script.extend([puff(8000), rest(3000)]);
    let trace = play(&config, &script);
    let pressed = goto_pressed(&trace);
    assert!(
        speed(&trace[pressed]) > 0.01,
        "pressed while braking: {} m/s at tick {pressed}",
        speed(&trace[pressed])
    );
    no_trajectory_error(&trace);
    check_invariants(&config, &trace);
}

/// Drive down to the table, then translate_x at full
/// speed, one NaN sample, rest for `fault_recovery_ms`, select translate_z
/// with two 45 ms sips and hold a sip while x still brakes.
fn new_direction_while_braking(fault_recovery_ms: u32, then: [Action; 2]) -> (Config, Vec<Record>) {
    let config = config(&format!(
        "[detector]\nfault_recovery_ms = {fault_recovery_ms}\n"
    ));
    let quick = Timing {
        short_ms: 45,
        long_ms: 800,
        gap_ms: 50,
    };
    let mut script = vec![rest(500)];
    script.extend(select(&TRANSLATE_Z));
    script.extend([sip(3000), rest(2100)]);
    script.extend(select(&TRANSLATE_X));
    script.extend([
        puff(1500),
        Step::Dropout { ms: 1 },
        rest(fault_recovery_ms + 10),
    ]);
    script.extend(sequence_steps(&then, quick));
    script.extend([sip(3000), rest(3000)]);
    (config.clone(), play(&config, &script))
}

#[test]
fn a_new_direction_while_braking_keeps_the_table_margin() {
    for recovery in [250, 150, 100, 50] {
        let (config, trace) = new_direction_while_braking(recovery, TRANSLATE_Z);
        let z_min = trace
            .iter()
            .map(|r| r.out.motion.pose.translation.z)
            .fold(f64::INFINITY, f64::min);
        let margin = config.core().workspace().stop_margin_m;
        assert!(
            z_min >= margin - 1e-9,
            "fault_recovery_ms {recovery}: the tool went down to {:.2} mm (margin {} mm)",
            z_min * 1e3,
            margin * 1e3
        );
        check_invariants(&config, &trace);
    }
}

#[test]
fn two_axes_at_once_stay_within_the_vector_limits() {
    // x brakes while the new mode (translate_y, a sip: −y) accelerates.
    let (config, trace) = new_direction_while_braking(50, TRANSLATE_Y);
    let a = max_linear_acceleration(&trace);
    let limit = config.core().motion().linear_acceleration_mps2;
    assert!(
        a <= limit * (1.0 + 1e-9),
        "vector acceleration {a:.3} m/s² against {limit}"
    );
    check_invariants(&config, &trace);
}

/// The stop margin is a normal distance, whatever the direction
/// of travel: a slanted approach to the reach sphere, a grazing approach
/// to the base sphere, skimming over it.
#[test]
fn the_margin_holds_as_a_normal_distance() {
    for (home, mode, breath) in [
        ([0.5, 0.4, 0.45], TRANSLATE_X, puff(6000)),
        ([0.5, 0.19, 0.06], TRANSLATE_X, sip(6000)),
        ([0.5, 0.0, 0.2001 + 0.005], TRANSLATE_X, sip(6000)),
        ([0.5, 0.0, 0.2049], TRANSLATE_X, sip(6000)),
        ([0.3, -0.3, 0.6], TRANSLATE_Z, puff(6000)),
    ] {
        let config = config(&format!("[arm]\nhome_position_m = {home:?}\n"));
        let mut script = vec![rest(500)];
        script.extend(select(&mode));
        script.extend([breath, rest(2000)]);
        let trace = play(&config, &script);
        let c = min_clearance(&config, &trace);
        let margin = config.core().workspace().stop_margin_m;
        assert!(
            c >= margin - 1e-9,
            "from {home:?}: {:.3} mm from a boundary (margin {} mm)",
            c * 1e3,
            margin * 1e3
        );
        check_invariants(&config, &trace);
    }
}

/// Tilt of the tool's z axis from its home direction, and its twist about
/// that axis (swing–twist decomposition), rad.
fn tilt_and_twist(config: &Config, r: &Record) -> (f64, f64) {
    let home = config.core().home().pose().rotation;
    let relative = home.inverse() * r.out.motion.pose.rotation;
    let z = relative * Vector3::z();
    let tilt = z.z.clamp(-1.0, 1.0).acos();
    let q = relative.quaternion();
    let twist = 2.0 * q.k.atan2(q.w);
    let twist =
        (twist + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
    (tilt, twist)
}

/// Rotations stop inside the orientation limits, braking, with
/// an event.
#[test]
fn rotations_stop_at_the_orientation_limits() {
    let config = Config::default();
    let ws = config.core().workspace();
    for (mode, breath) in [
        (ROTATE_Y, puff(4000)),
        (ROTATE_Y, sip(4000)),
        (ROTATE_Z, puff(4000)),
        (ROTATE_Z, sip(4000)),
    ] {
        let mut script = vec![rest(500)];
        script.extend(select(&mode));
        script.extend([breath, rest(2000)]);
        let trace = play(&config, &script);
        check_invariants(&config, &trace);
        let (mut tilt, mut twist) = (0.0f64, 0.0f64);
        for r in &trace {
            let (t, w) = tilt_and_twist(&config, r);
            tilt = tilt.max(t);
            twist = twist.max(w.abs());
        }
        assert!(
            tilt <= ws.max_tilt_rad + 1e-9 && twist <= ws.max_twist_rad + 1e-9,
            "{mode:?}: tilt {tilt:.4}, twist {twist:.4} rad"
        );
        let limited = trace.iter().any(|r| {
            r.out
                .events
                .iter()
                .any(|e| matches!(e, Event::Motion(MotionEvent::WorkspaceLimit { .. })))
        });
        assert!(limited, "{mode:?}: an event says the limit was reached");
        // It got close: the limit stops it, not something else.
        let reached = tilt.max(twist);
        assert!(reached > 0.95 * ws.max_tilt_rad.min(ws.max_twist_rad));
    }
}

/// After a release the speed rises by at most 10 % of the full
/// speed, and a release at full speed is still within v/A + 60 ms.
#[test]
fn the_arm_stops_promptly_after_a_release() {
    let config = Config::default();
    let m = *config.core().motion();
    for hold in [60, 120, 198, 300, 700, 2000] {
        let mut script = vec![rest(500)];
        script.extend(select(&TRANSLATE_X));
        script.extend([puff(hold), rest(1500)]);
        let trace = play(&config, &script);
        check_invariants(&config, &trace);
        let moving = trace
            .iter()
            .position(|r| r.out.command.direction == Direction::Positive)
            .expect("puff held");
        let released = moving
            + trace[moving..]
                .iter()
                .position(|r| r.out.command.direction == Direction::Still)
                .expect("released");
        let at_release = speed(&trace[released - 1]);
        let peak = trace[released..].iter().map(speed).fold(0.0, f64::max);
        assert!(
            peak <= at_release + 0.1 * m.linear_speed_mps + 1e-12,
            "hold {hold} ms: {at_release:.4} m/s at the release, peak {peak:.4} m/s after"
        );
        let still = released
            + trace[released..]
                .iter()
                .position(|r| r.out.motion.is_still())
                .expect("stops");
        // From the release: the acceleration ramps down (A/J), then the
        // stop from the peak speed (v/A + A/J); from full speed that is
        // within v/A + 60 ms.
        let (a, j) = (m.linear_acceleration_mps2, m.linear_jerk_mps3);
        let bound_s = if hold >= 700 {
            m.linear_speed_mps / a + 0.060
        } else {
            peak / a + 2.0 * a / j
        };
        let limit_ms = (bound_s * 1000.0).ceil() as usize + 1;
        assert!(
            still - released <= limit_ms,
            "hold {hold} ms: still {} ms after the release (at most {limit_ms})",
            still - released
        );
    }
}

/// Section 2 (beyond the paper): with `motion_onset_ms`, short breaths in
/// command mode select instead of moving. The slip of the review: in
/// translate_x, 0.5 s after a move, the user enters [1, 1] (translate_z)
/// and holds a sip meaning *down*.
#[test]
fn with_motion_onset_a_selection_in_command_mode_switches_without_moving() {
    let slip = |onset: u32| {
        let config = config(&format!("[command]\nmotion_onset_ms = {onset}\n"));
        let mut script = vec![rest(500)];
        script.extend(select(&TRANSLATE_X));
        script.extend([puff(1000), rest(500)]);
        script.extend(sequence_steps(&TRANSLATE_Z, Timing::DEFAULT));
        script.extend([sip(1500), rest(2500)]);
        let trace = play(&config, &script);
        check_invariants(&config, &trace);
        (config, trace)
    };
    let x_after_move = |trace: &[Record]| {
        // Where x stood 450 ms after the first release (braked to rest).
        let released = trace
            .iter()
            .position(|r| r.out.command.direction == Direction::Positive)
            .map(|start| {
                start
                    + trace[start..]
                        .iter()
                        .position(|r| r.out.command.direction == Direction::Still)
                        .unwrap()
            })
            .unwrap();
        trace[released + 450].out.motion.pose.translation.x
    };
    // The paper's behaviour: the sips of the selection move x backwards,
    // then the held sip goes on moving x backwards; z never moves.
    let (_, off) = slip(0);
    let last = off.last().unwrap().out.motion.pose.translation;
    assert!(
        x_after_move(&off) - last.x > 0.1,
        "without onset the slip drives x back"
    );
    assert!((last.z - 0.48).abs() < 1e-9);
    // With a 300 ms onset: the two 150 ms sips select translate_z at once,
    // nothing moves meanwhile, and the held sip moves down.
    let (_, on) = slip(300);
    let matched = on
        .iter()
        .filter_map(|r| {
            r.out.events.iter().find_map(|e| match e {
                Event::Match { target, .. } => target.mode().map(|mode| (r.out.tick, mode)),
                _ => None,
            })
        })
        .collect::<Vec<_>>();
    assert_eq!(matched.len(), 2, "{matched:?}");
    assert_eq!(matched[1].1, Mode::TranslateZ);
    assert!(
        on.iter().all(|r| !r
            .out
            .events
            .iter()
            .any(|e| matches!(e, Event::Detection { .. }))
            || r.out.tick > matched[1].0),
        "no return to detection mode before the switch"
    );
    let last = on.last().unwrap().out.motion.pose.translation;
    assert!(
        (x_after_move(&on) - last.x).abs() < 1e-9,
        "x does not move after the first move"
    );
    assert!(last.z < 0.48 - 0.1, "the held sip moves down: z {}", last.z);
}

/// A breath that moved the arm voids a selection begun before it.
#[test]
fn with_motion_onset_a_moving_breath_voids_a_selection_begun() {
    let config = config("[command]\nmotion_onset_ms = 300\n");
    let mut script = vec![rest(500)];
    script.extend(select(&TRANSLATE_X));
    script.extend([puff(150), rest(300), puff(800), rest(3000)]);
    let trace = play(&config, &script);
    check_invariants(&config, &trace);
    let events: Vec<Event> = trace
        .iter()
        .flat_map(|r| r.out.events.iter().copied())
        .collect();
    assert!(
        events.iter().any(|e| matches!(
            e,
            Event::Reset {
                reason: sipnpuff::control::selection::matcher::ResetReason::Moved,
                ..
            }
        )),
        "{events:?}"
    );
    // The 150 ms puff moved nothing; the 800 ms puff moved ~0.5 s' worth.
    let x = trace.last().unwrap().out.motion.pose.translation.x;
    assert!(x > 0.21 + 0.05 && x < 0.21 + 0.2, "x {x}");
}

/// A stall of the process longer than two arm cycles: the arm, fed no
/// command, has stopped on its own, so the commands resume from rest —
/// never from the speed before the gap (a jump for the real arm). A gap
/// under `stale_ms` is no fault: the held puff accelerates again.
#[test]
fn after_a_stall_the_commands_resume_from_rest() {
    use sipnpuff::control::pipeline::Pipeline;
    use sipnpuff::tools::safety::SafetyMonitor;
    let config = Config::default();
    let mut script = vec![rest(500)];
    script.extend(select(&TRANSLATE_X));
    script.extend([puff(3000), rest(1000)]);
    let params = SignalParams::clean(config.core().detector(), 3);
    let samples: Vec<f64> = SignalGenerator::new(params, &script).collect();
    let mut core: Pipeline = Pipeline::new(config.core());
    let mut monitor = SafetyMonitor::new(config.core());
    let cut = 500 + 1050 + 300 + 1500; // 1.5 s into the puff
    let mut tick = 0;
    let mut speeds = Vec::new();
    for (i, v) in samples.into_iter().enumerate() {
        tick += if i == cut { 31 } else { 1 }; // a 30 ms stall
        let out = core.tick(tick, v);
        monitor.check(&out).unwrap_or_else(|v| panic!("{v}"));
        speeds.push((tick, Vector3::from(out.motion.linear).norm()));
    }
    let before = speeds[cut - 1].1;
    let after = speeds[cut].1;
    assert!(before > 0.19, "full speed before the stall: {before}");
    let j = config.core().motion().linear_jerk_mps3;
    assert!(after <= j * DT * DT, "from rest after it: {after}");
    assert!(
        speeds[cut + 400].1 > 0.19,
        "the held puff accelerates again"
    );
}
