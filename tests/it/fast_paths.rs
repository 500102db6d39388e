//! Skipped work, proven equivalent: the core as it runs (the detector's
//! rest step, each Ruckig channel's update skipped while it rests and is
//! asked nothing, a rest tick repeating the last one) and the core on its
//! reference path, which skips nothing, each driving a simulated arm (with
//! and without its skipped milliseconds), side by side on the same streams
//! — the demo user, noisy random sessions through both libraries, harsh
//! signals with rail spikes, saturation and NaN dropouts, the scanning
//! interface, measured poses, missing samples and a lost device — with
//! every field of every tick's output and view equal, the floats bit for
//! bit.

use sipnpuff::arm::sim::SimulatedJaco;
use sipnpuff::config::Config;
use sipnpuff::control::event::Event;
use sipnpuff::control::motion::rest::pose_bits;
use sipnpuff::control::pipeline::Pipeline;
use sipnpuff::control::tick::{TickInput, TickOutput};
use sipnpuff::sim::script::{demo_script, random_session};
use sipnpuff::sim::sensor_model::{SignalGenerator, SignalParams, Step};

use crate::common::paper_config;
use crate::common::{TickByTick, arm_measured, arm_starts_at};
use sipnpuff::control::sample::Sample;

/// The floats of a tick's output, as bits (`==` would take −0 for 0).
fn float_bits(out: &TickOutput) -> [u64; 24] {
    let m = &out.motion;
    let q = m.pose.rotation.coords;
    let p = m.pose.translation.vector;
    let v = m.velocity();
    let command = m.arm_command.map_or([0.0; 7], |c| {
        [
            c.linear[0],
            c.linear[1],
            c.linear[2],
            c.angular[0],
            c.angular[1],
            c.angular[2],
            c.fingers,
        ]
    });
    let mut bits = [0; 24];
    for (b, x) in bits.iter_mut().zip(
        v.iter()
            .chain(p.iter())
            .chain(q.iter())
            .chain(&[m.fingers])
            .chain(&command),
    ) {
        *b = x.to_bits();
    }
    bits
}

/// The simulated arm's pose and fingers, as bits.
fn arm_bits(arm: &SimulatedJaco) -> [u64; 8] {
    pose_bits(&arm.state().pose, arm.fingers())
}

/// The core as it runs (one output reused, as replay runs it) and the core
/// on its reference path, each driving its simulated arm (the fast one
/// with its own skipped milliseconds).
struct Pair {
    fast: Pipeline,
    full: Pipeline,
    fast_arm: SimulatedJaco,
    full_arm: SimulatedJaco,
    out: TickOutput,
}

impl Pair {
    fn new(config: &Config) -> Pair {
        let fast = Pipeline::new(config.core());
        let mut full = Pipeline::new(config.core());
        full.use_reference_path();
        let mut full_arm = SimulatedJaco::new(config.core());
        full_arm.use_reference_path();
        Pair {
            out: TickOutput::default(),
            fast,
            full,
            fast_arm: SimulatedJaco::new(config.core()),
            full_arm,
        }
    }

    /// Steps both at tick `t` and checks that every field of the outputs,
    /// the views and the arms' poses are the same, floats bit for bit.
    fn step(&mut self, input: &TickInput) -> &TickOutput {
        let t = input.tick;
        let (fast, a) = (&mut self.fast, &mut self.out);
        fast.step(input, a);
        let b = self.full.tick_input(input);
        assert_eq!(*a, b, "tick {t}");
        assert_eq!(float_bits(a), float_bits(&b), "tick {t}");
        assert_eq!(fast.view(), self.full.view(), "tick {t}");
        self.fast_arm.tick(a.motion.arm_command.as_ref());
        self.full_arm.tick(b.motion.arm_command.as_ref());
        let (fast_arm, full_arm) = (arm_bits(&self.fast_arm), arm_bits(&self.full_arm));
        assert_eq!(fast_arm, full_arm, "arm at tick {t}");
        assert_eq!(
            self.fast_arm.inside_workspace(),
            self.full_arm.inside_workspace(),
            "arm inside its workspace at tick {t}"
        );
        &self.out
    }

    /// What the fast core and arm skipped (the reference ones nothing).
    fn skipped(&self, ticks: u64) -> Skipped {
        let count = |core: &Pipeline, arm: &SimulatedJaco| {
            let [arm_updates, finger_updates, repeats] = core.motion().skipped();
            Skipped {
                ticks,
                arm_updates,
                finger_updates,
                repeats,
                arm_ms: arm.skipped_ms(),
                rest_samples: core.detector().rest_steps(),
            }
        };
        let reference = count(&self.full, &self.full_arm);
        assert_eq!(
            reference,
            Skipped {
                ticks,
                ..Skipped::default()
            }
        );
        count(&self.fast, &self.fast_arm)
    }
}

/// What the fast core skipped over a stream.
#[derive(Debug, Default, Clone, Copy, PartialEq)]
struct Skipped {
    ticks: u64,
    /// The arm channel's updates skipped.
    arm_updates: u64,
    /// The fingers' updates skipped.
    finger_updates: u64,
    /// Rest ticks that repeated the last one.
    repeats: u64,
    /// The simulated arm's milliseconds skipped standing still.
    arm_ms: u64,
    /// Samples the detector took at rest (its rest step).
    rest_samples: u64,
}

impl std::ops::AddAssign for Skipped {
    fn add_assign(&mut self, o: Skipped) {
        self.ticks += o.ticks;
        self.arm_updates += o.arm_updates;
        self.finger_updates += o.finger_updates;
        self.repeats += o.repeats;
        self.arm_ms += o.arm_ms;
        self.rest_samples += o.rest_samples;
    }
}

/// Runs `samples` through both cores side by side ([`Pair`]).
fn side_by_side(config: &Config, samples: impl Iterator<Item = f64>) -> Skipped {
    let mut pair = Pair::new(config);
    let mut ticks = 0;
    for (t, volts) in samples.enumerate() {
        pair.step(&TickInput::volts(t as u64, volts));
        ticks += 1;
    }
    pair.skipped(ticks)
}

/// As [`side_by_side`], with missing samples and a lost device among the
/// samples, both cores measuring their arm's pose (every 10 ticks, 0.1 mm
/// off so that it corrects the estimate, at rest too), and the arm's link
/// lost at `link_lost_at`.
fn side_by_side_measured(config: &Config, inputs: &[Sample], link_lost_at: u64) -> Skipped {
    let mut pair = Pair::new(config);
    let mut news = arm_starts_at(pair.fast_arm.state().pose);
    let mut faulted = false;
    for (t, &sample) in inputs.iter().enumerate() {
        let t = t as u64;
        news.link_lost = t == link_lost_at;
        let out = pair.step(&TickInput {
            arm: std::mem::take(&mut news),
            ..TickInput::new(t, sample)
        });
        faulted |= out
            .events
            .iter()
            .any(|e| matches!(e, Event::ArmFault { .. }));
        if t.is_multiple_of(10) {
            let mut measured = pair.full_arm.state().pose;
            measured.translation.vector.x += if t.is_multiple_of(20) { 1e-4 } else { -1e-4 };
            news = arm_measured(measured);
        }
    }
    assert!(
        faulted,
        "the link lost at tick {link_lost_at} is an arm fault"
    );
    pair.skipped(inputs.len() as u64)
}

fn stream(params: SignalParams, script: &[Step]) -> Vec<f64> {
    SignalGenerator::new(params, script).collect()
}

#[test]
fn the_demo_user_moves_the_same_with_updates_skipped_at_rest() {
    let config = Config::default();
    let (script, _) = demo_script(&config);
    let clean = SignalParams::clean(config.core().detector(), 1);
    let skipped = side_by_side(&config, stream(clean, &script).into_iter());
    eprintln!("demo: {skipped:?}");
    // The test tests something: most of the demo is at rest (the demo
    // user moves through every mode).
    assert!(skipped.arm_updates * 3 > skipped.ticks, "{skipped:?}");
}

#[test]
fn noisy_random_sessions_through_both_libraries_are_the_same() {
    let _cpu = crate::common::cpu_heavy();
    let mut total = Skipped::default();
    for (config, seed) in [
        (Config::default(), 1),
        (Config::default(), 2),
        (paper_config(), 3),
    ] {
        let (script, _) = random_session(&config, 240, seed);
        let params = SignalParams::clean(config.core().detector(), seed)
            .with_noise(0.03)
            .with_hum(0.05)
            .with_drift(0.2)
            .with_spikes_every(250);
        total += side_by_side(&config, stream(params, &script).into_iter());
    }
    eprintln!("random sessions: {total:?}");
    assert!(total.ticks >= 720_000);
    // The test tests something: most rest ticks after motion repeat the
    // last tick (after motion along or about a negative axis too, whose
    // zeros are −0), and the arm stands still without stepping.
    assert!(total.repeats * 10 > total.arm_updates * 7, "{total:?}");
    assert!(total.arm_ms * 10 > total.ticks * 7, "{total:?}");
    // The fingers' update skipped while the arm moved.
    assert!(
        total.finger_updates > total.arm_updates + 10_000,
        "{total:?}"
    );
    // Most samples are at rest, between the thresholds: the detector
    // takes its rest step.
    assert!(total.rest_samples * 2 > total.ticks, "{total:?}");
}

#[test]
fn harsh_saturating_and_dropping_out_signals_are_the_same() {
    let _cpu = crate::common::cpu_heavy();
    let config = Config::default();
    let (mut script, _) = random_session(&config, 120, 9);
    // NaN dropouts between the breaths.
    script.insert(script.len() / 3, Step::Dropout { ms: 300 });
    script.insert(2 * script.len() / 3, Step::Dropout { ms: 40 });
    let mut params = SignalParams::clean(config.core().detector(), 9)
        .with_noise(0.1)
        .with_hum(0.2)
        .with_spikes_every(100)
        .with_drift(0.5);
    params.breath_volts = 3.2; // saturating at the rails
    let skipped = side_by_side(&config, stream(params, &script).into_iter());
    assert!(skipped.ticks >= 120_000);
}

#[test]
fn the_scanning_interface_is_the_same() {
    let config = Config::from_toml_str("[interface]\nkind = \"bsp\"\n").unwrap();
    let (script, _) = random_session(&config, 120, 4);
    let params = SignalParams::clean(config.core().detector(), 4).with_noise(0.02);
    let skipped = side_by_side(&config, stream(params, &script).into_iter());
    assert!(skipped.ticks >= 120_000 && skipped.arm_updates > 0);
}

#[test]
fn measured_poses_missing_samples_and_a_lost_device_are_the_same() {
    let config = Config::default();
    let (script, _) = random_session(&config, 120, 11);
    let params = SignalParams::clean(config.core().detector(), 11).with_noise(0.02);
    let mut inputs: Vec<Sample> = stream(params, &script)
        .into_iter()
        .enumerate()
        .map(|(t, volts)| match t % 5_003 {
            // Short gaps (under `stale_ms`) and long ones (a fault).
            1_000..1_030 | 3_000..3_400 => Sample::Missing,
            4_000..4_010 => Sample::Lost,
            _ => Sample::Volts(volts),
        })
        .collect();
    let ticks = inputs.len() as u64;
    inputs.extend([Sample::Volts(2.5); 3_000]);
    let skipped = side_by_side_measured(&config, &inputs, ticks);
    eprintln!("measured: {skipped:?}");
    // The test tests something: the rest paths ran, before and after the
    // arm's fault.
    assert!(skipped.arm_updates * 3 > ticks, "{skipped:?}");
}
