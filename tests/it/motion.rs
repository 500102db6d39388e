//! Per-tick motion invariants on traces through the whole pipeline and the
//! simulated JACO: limits (velocity, acceleration, jerk from the 1 kHz
//! trace), no NaN, the workspace, stopping after release, in detection mode
//! and after a sensor fault.

use crate::common::TickByTick;
use nalgebra::Vector3;
use sipnpuff::arm::sim::SimulatedJaco;
use sipnpuff::config::Config;
use sipnpuff::control::action::{Action, Breath};
use sipnpuff::control::event::Event;
use sipnpuff::control::mode::{Direction, ModeState};
use sipnpuff::control::motion::MotionEvent;
use sipnpuff::control::motion::workspace::{self, Boundary};
use sipnpuff::control::pipeline::Pipeline;
use sipnpuff::control::sample::Sample;
use sipnpuff::control::tick::TickOutput;
use sipnpuff::sim::script::{Timing, demo_script, random_session, sequence_steps};
use sipnpuff::sim::sensor_model::{SignalGenerator, SignalParams, Step};

const DT: f64 = 0.001;

/// One tick of the pipeline and the arm it drives.
pub struct Record {
    pub out: TickOutput,
    pub arm_inside: bool,
    pub arm_position: Vector3<f64>,
}

/// `None` samples are ticks on which the sensor delivered nothing.
pub fn run(config: &Config, samples: impl Iterator<Item = Option<f64>>) -> Vec<Record> {
    let mut core: Pipeline = Pipeline::new(config.core());
    let mut arm = SimulatedJaco::new(config.core());
    samples
        .enumerate()
        .map(|(t, v)| {
            let out = match v {
                Some(v) => core.tick(t as u64, v),
                None => core.tick_with(t as u64, Sample::Missing),
            };
            arm.tick(out.motion.arm_command.as_ref());
            Record {
                out,
                arm_inside: arm.inside_workspace(),
                arm_position: arm.state().pose.translation.vector,
            }
        })
        .collect()
}

fn noisy(config: &Config, seed: u64) -> SignalParams {
    SignalParams::clean(config.core().detector(), seed)
        .with_noise(0.03)
        .with_hum(0.05)
        .with_drift(0.1)
        .with_spikes_every(250)
}

/// Longest time stopping can take, in ticks (the safety monitor's bound).
pub fn stop_ticks(config: &Config) -> usize {
    sipnpuff::tools::safety::stop_steps(config.core()) as usize
}

/// Rounding allowance on the stop margin, m (a nanometre).
pub const MARGIN_SLACK_M: f64 = 1e-9;

/// Normal distance from `p` to the nearest boundary of the workspace (reach
/// sphere, base sphere, table), m: negative outside.
pub fn clearance(config: &Config, p: &Vector3<f64>) -> f64 {
    let w = config.core().workspace();
    let r = p.norm();
    (w.reach_m - r)
        .min(r - w.min_radius_m)
        .min(p.z - w.table_z_m)
}

fn velocities(o: &TickOutput) -> [Vector3<f64>; 2] {
    [
        Vector3::from(o.motion.linear),
        Vector3::from(o.motion.angular),
    ]
}

fn still(o: &TickOutput) -> bool {
    o.motion.is_still()
}

/// The invariants every trace must satisfy.
pub fn check_invariants(config: &Config, trace: &[Record]) {
    let m = config.core().motion();
    let tol = 1.0 + 1e-9;
    // Rounding of second differences of ~0.2 m/s values over 1 ms².
    let jerk_slack = 1e-9;
    let limits = [
        (
            m.linear_speed_mps,
            m.linear_acceleration_mps2,
            m.linear_jerk_mps3,
        ),
        (
            m.angular_speed_radps,
            m.angular_acceleration_radps2,
            m.angular_jerk_radps3,
        ),
    ];
    let finger_limits = (m.finger_speed, m.finger_acceleration, m.finger_jerk);
    for (k, r) in trace.iter().enumerate() {
        let o = &r.out;
        let p = o.motion.pose.translation.vector;
        let all = o
            .motion
            .linear
            .iter()
            .chain(&o.motion.angular)
            .chain([&o.motion.fingers_velocity, &o.motion.fingers]);
        assert!(
            all.chain(p.iter()).all(|v| v.is_finite()),
            "NaN at tick {k}"
        );
        assert!(
            r.arm_inside,
            "arm outside the workspace at tick {k}: {:?}",
            r.arm_position
        );
        assert!(
            workspace::contains(&p, config.core().workspace()),
            "pose outside at tick {k}"
        );
        let ws = config.core().workspace();
        for (what, at) in [("pose", p), ("arm", r.arm_position)] {
            let c = clearance(config, &at);
            assert!(
                c >= ws.stop_margin_m - MARGIN_SLACK_M,
                "{what} {:.3} mm from a boundary at tick {k} (margin {} mm): {at:?}",
                c * 1e3,
                ws.stop_margin_m * 1e3
            );
        }
        assert!((0.0..=config.core().workspace().finger_closed).contains(&o.motion.fingers));
        for (g, v) in velocities(o).iter().enumerate() {
            assert!(
                v.norm() <= limits[g].0 * tol,
                "speed {} at tick {k}",
                v.norm()
            );
        }
        assert!(o.motion.fingers_velocity.abs() <= finger_limits.0 * tol);
        if k >= 1 {
            let prev = &trace[k - 1].out;
            for (g, limit) in limits.iter().enumerate() {
                let a = (velocities(o)[g] - velocities(prev)[g]) / DT;
                assert!(
                    a.norm() <= limit.1 * tol,
                    "group {g} acceleration {} at tick {k}",
                    a.norm()
                );
            }
            let fa = (o.motion.fingers_velocity - prev.motion.fingers_velocity) / DT;
            assert!(
                fa.abs() <= finger_limits.1 * tol,
                "finger acceleration {fa} at tick {k}"
            );
        }
        if k >= 2 {
            let (a, b) = (&trace[k - 1].out, &trace[k - 2].out);
            for (g, limit) in limits.iter().enumerate() {
                let j = (velocities(o)[g] - 2.0 * velocities(a)[g] + velocities(b)[g]) / (DT * DT);
                assert!(
                    j.norm() <= limit.2 * tol + jerk_slack,
                    "group {g} jerk {} at tick {k}",
                    j.norm()
                );
            }
            let fj = (o.motion.fingers_velocity - 2.0 * a.motion.fingers_velocity
                + b.motion.fingers_velocity)
                / (DT * DT);
            assert!(
                fj.abs() <= finger_limits.2 * tol + 1e-3,
                "finger jerk {fj} at tick {k}"
            );
        }
    }

    // Still within the stopping time after a release (command mode, no new
    // breath meanwhile), after entering detection mode, and after a fault.
    let n = stop_ticks(config);
    for k in 1..trace.len() {
        let (prev, now) = (&trace[k - 1].out, &trace[k].out);
        let released =
            prev.command.direction != Direction::Still && now.command.direction == Direction::Still;
        let to_detection =
            prev.command.state != ModeState::Detection && now.command.state == ModeState::Detection;
        let fault = !prev.faulted && now.faulted;
        if !(released || to_detection || fault) || k + n >= trace.len() {
            continue;
        }
        if trace[k..k + n]
            .iter()
            .any(|r| r.out.command.direction != Direction::Still)
        {
            continue; // a new breath moves it again
        }
        assert!(
            still(&trace[k + n].out),
            "still moving {n} ticks after tick {k}"
        );
        if to_detection || fault {
            // …and it stays still until a new mode is selected.
            for r in trace[k + n..]
                .iter()
                .take_while(|r| r.out.command.state == ModeState::Detection)
            {
                assert!(
                    still(&r.out),
                    "moving in detection mode at tick {}",
                    r.out.tick
                );
            }
        }
    }
}

pub fn motion_events(trace: &[Record]) -> Vec<MotionEvent> {
    trace
        .iter()
        .flat_map(|r| r.out.events.iter().copied())
        .filter_map(|e| match e {
            Event::Motion(m) => Some(m),
            _ => None,
        })
        .collect()
}

#[test]
fn the_demo_user_under_noise() {
    let config = Config::default();
    let (script, _) = demo_script(&config);
    let samples = SignalGenerator::new(noisy(&config, 1), &script).map(Some);
    let trace = run(&config, samples);
    check_invariants(&config, &trace);

    let events = motion_events(&trace);
    let saved = events.iter().find_map(|e| match e {
        MotionEvent::Saved { position } => Some(Vector3::from(*position)),
        _ => None,
    });
    assert!(
        events.contains(&MotionEvent::WorkspaceLimit {
            boundary: Boundary::FingersClosed
        }),
        "{events:?}"
    );
    assert!(
        events.contains(&MotionEvent::WorkspaceLimit {
            boundary: Boundary::Reach
        }),
        "{events:?}"
    );
    assert!(events.contains(&MotionEvent::GotoReached), "{events:?}");

    // Where the goto ended, the arm (10 ms behind the core) ended too: at
    // the saved point.
    let reached = trace
        .iter()
        .position(|r| {
            r.out
                .events
                .iter()
                .any(|e| *e == Event::Motion(MotionEvent::GotoReached))
        })
        .unwrap();
    let settled = &trace[reached + 20];
    assert!((settled.arm_position - saved.unwrap()).norm() < 1e-6);
    assert!((settled.out.motion.pose.translation.vector - settled.arm_position).norm() < 1e-9);
}

/// Rest 0.5 s, enter `actions` (150 ms bursts, 300 ms gaps), rest 0.9 s.
fn select(actions: &[Action]) -> Vec<Step> {
    let mut script = vec![Step::Rest { ms: 500 }];
    script.extend(sequence_steps(actions, Timing::DEFAULT));
    script.push(Step::Rest { ms: 900 });
    script
}

#[test]
fn a_sensor_fault_mid_motion_brakes_smoothly() {
    let config = Config::default();
    // translate_x (two short puffs), then a 2 s puff cut by a 30 ms
    // dropout after 1 s; the user keeps puffing after the dropout.
    let mut script = select(&[Action::ShortPuff, Action::ShortPuff]);
    script.push(Step::Breath {
        breath: Breath::Puff,
        ms: 1000,
    });
    script.push(Step::Dropout { ms: 30 });
    script.push(Step::Breath {
        breath: Breath::Puff,
        ms: 1000,
    });
    script.push(Step::Rest { ms: 3000 });
    let samples =
        SignalGenerator::new(SignalParams::clean(config.core().detector(), 4), &script).map(Some);
    let trace = run(&config, samples);
    check_invariants(&config, &trace);
    let fault = trace.iter().position(|r| r.out.faulted).expect("a fault");
    assert!(
        trace[fault - 1].out.motion.linear[0] > 0.19,
        "full speed before the fault"
    );
    assert!(still(&trace[fault + stop_ticks(&config)].out));
    assert!(
        trace[fault..]
            .iter()
            .all(|r| r.out.command.state == ModeState::Detection)
    );
}

#[test]
fn a_stale_sensor_brakes_smoothly() {
    let config = Config::default();
    // translate_z (two short sips), then a 3 s sip: down.
    let mut script = select(&[Action::ShortSip, Action::ShortSip]);
    script.push(Step::Breath {
        breath: Breath::Sip,
        ms: 3000,
    });
    let samples: Vec<f64> =
        SignalGenerator::new(SignalParams::clean(config.core().detector(), 2), &script).collect();
    // The sensor stops delivering 1 s into the long sip (translate_z down).
    let cut = 500 + 2 * 450 + 900 + 1000;
    let input = samples[..cut]
        .iter()
        .map(|&v| Some(v))
        .chain(std::iter::repeat_n(None, 2000));
    let trace = run(&config, input);
    check_invariants(&config, &trace);
    assert!(trace[cut - 1].out.motion.linear[2] < -0.19);
    let stale = config.core().detector().stale_ms as usize;
    let fault = trace.iter().position(|r| r.out.faulted).unwrap();
    assert_eq!(
        fault,
        cut + stale - 1,
        "fault {stale} ms after the last sample"
    );
    assert!(still(&trace[fault + stop_ticks(&config)].out));
}

#[test]
fn random_users_respect_every_limit() {
    for seed in 0..4 {
        let config = Config::default();
        let (script, _) = random_session(&config, 180, seed);
        let samples = SignalGenerator::new(noisy(&config, seed), &script).map(Some);
        check_invariants(&config, &run(&config, samples));
    }
    // Slower, gentler limits and proportional speed.
    let config = Config::from_toml_str(
        "[motion]\nlinear_speed_mps = 0.08\nlinear_acceleration_mps2 = 0.2\nlinear_jerk_mps3 = 4.0\nangular_speed_radps = 0.3\nangular_acceleration_radps2 = 1.0\nangular_jerk_radps3 = 20.0\nproportional_speed = true\n",
    )
    .unwrap();
    let (script, _) = random_session(&config, 180, 9);
    let samples = SignalGenerator::new(noisy(&config, 9), &script).map(Some);
    check_invariants(&config, &run(&config, samples));
}
