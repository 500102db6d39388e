//! Zero heap allocation after construction, proven with a counting global
//! allocator over a long noisy session that exercises every path of the
//! core (bursts, matches, resets, waits, mode changes, faults, recoveries,
//! a stuck breath and its re-zero), of the motion layer (every mode, save
//! and go to point, workspace and finger limits, braking after faults, the
//! 100 Hz stream) and of the simulated arm.

use crate::common::TickByTick;
use sipnpuff::arm::sim::SimulatedJaco;
use sipnpuff::config::Config;
use sipnpuff::control::event::Event;
use sipnpuff::control::motion::MotionEvent;
use sipnpuff::control::pipeline::Pipeline;
use sipnpuff::control::sample::Sample;
use sipnpuff::control::selection::Interface;
use sipnpuff::rt::alloc_counter::thread_allocations;
use sipnpuff::sim::script::every_path_session;
use sipnpuff::sim::sensor_model::SignalGenerator;
use sipnpuff::sim::user::{RUN_STEPS, scripted_session};

#[test]
fn counter_sees_allocations() {
    let before = thread_allocations();
    let boxed = std::hint::black_box(Box::new([0u8; 64]));
    drop(boxed);
    assert_eq!(thread_allocations() - before, 1);
}

#[test]
fn core_step_never_allocates() {
    let config = Config::default();
    let (params, script) = every_path_session(&config);
    let samples: Vec<f64> = SignalGenerator::new(params, &script).collect();
    assert!(samples.len() >= 100_000, "{} samples", samples.len());
    let mut core: Pipeline = Pipeline::new(config.core());
    let mut arm = SimulatedJaco::new(config.core());

    let mut counts = [0usize; 12];
    let before = thread_allocations();
    for (t, &v) in samples.iter().enumerate() {
        let out = if t % 5000 == 4999 {
            core.tick_with(t as u64, Sample::Missing) // a lost sample now and then
        } else {
            core.tick(t as u64, v)
        };
        arm.tick(out.motion.arm_command.as_ref());
        for event in out.events.iter() {
            let kind = match event {
                Event::Burst(_) => 0,
                Event::Match { .. } => 1,
                Event::Reset { .. } => 2,
                Event::Detection { .. } => 3,
                Event::Fault { .. } => 4,
                Event::Recovered => 5,
                Event::Motion(MotionEvent::Saved { .. }) => 6,
                Event::Motion(MotionEvent::GotoStarted { .. }) => 7,
                Event::Motion(MotionEvent::GotoReached) => 8,
                Event::Motion(MotionEvent::WorkspaceLimit { boundary: _ }) => 9,
                Event::Rezeroed { .. } => 10,
                Event::Highlight { .. }
                | Event::Motion(_)
                | Event::ArmFault { .. }
                | Event::Gesture { .. }
                | Event::GestureRejected { .. } => 11,
            };
            counts[kind] += 1;
        }
    }
    let allocations = thread_allocations() - before;
    assert_eq!(allocations, 0, "{} ticks", samples.len());
    assert!(
        counts[..11].iter().all(|&n| n > 0),
        "every kind of event happened: {counts:?}"
    );
}

/// The scanning interface (BSP): the run user's session and the noisy
/// every-path session (whose puffs enter whatever is highlighted).
#[test]
fn bsp_core_step_never_allocates() {
    let config = Config::default().with_interface(Interface::Bsp).unwrap();
    let (run_params, run_script) = scripted_session(&config, &RUN_STEPS, 1);
    let (params, script) = every_path_session(&config);
    let mut samples: Vec<f64> = SignalGenerator::new(run_params, &run_script).collect();
    samples.extend(SignalGenerator::new(params, &script));
    let mut core: Pipeline = Pipeline::new(config.core());
    let (mut highlights, mut matches) = (0, 0);
    let before = thread_allocations();
    for (t, &v) in samples.iter().enumerate() {
        for event in core.tick(t as u64, v).events.iter() {
            match event {
                Event::Highlight { .. } => highlights += 1,
                Event::Match { .. } => matches += 1,
                _ => {}
            }
        }
    }
    assert_eq!(thread_allocations() - before, 0, "{} ticks", samples.len());
    assert!(
        highlights > 100 && matches > 10,
        "{highlights} highlights, {matches} matches"
    );
}

#[test]
fn generator_never_allocates() {
    let config = Config::default();
    let (params, script) = every_path_session(&config);
    let before = thread_allocations();
    let mut sum = 0.0;
    for v in SignalGenerator::new(params, &script) {
        if v.is_finite() {
            sum += v;
        }
    }
    assert_eq!(thread_allocations() - before, 0);
    assert!(sum > 0.0);
}

/// The gesture front end with 10 gestures × 5 templates over 80 s of
/// gestures, looking around, twitches and too-long holds: no allocation
/// in `Recognizer::step`, and both verdicts happen.
#[test]
fn gesture_step_never_allocates() {
    use sipnpuff::control::gesture::{GestureConfig, GestureEvent, Recognizer, RejectReason};
    use sipnpuff::sim::head::{Head, HeadScript, Move, Noise, example_templates, ten_gestures};

    let config = GestureConfig::default();
    let gestures = ten_gestures();
    let templates = example_templates(&config, &gestures, 5, 0.6, 500);
    assert_eq!(templates.len(), 50);
    let mut recognizer = Recognizer::new(config, templates).unwrap();
    let mut script = HeadScript::new().rest(1000);
    for round in 0..4 {
        for m in gestures {
            let speed = 0.8 + 0.1 * round as f64;
            script = script
                .then(m.varied(m.speed * speed, m.amplitude))
                .rest(600);
        }
        script = script
            .then(Move::new(Head::LookAround))
            .rest(500)
            .then(Move::new(Head::Twitch))
            .rest(500)
            .then(Move::new(Head::LookDown).held(3000))
            .rest(800);
    }
    assert!(script.length_ms() >= 60_000, "{} ms", script.length_ms());
    let samples = script.samples(10, Noise::TYPICAL, 77);

    let (mut recognised, mut rejected, mut too_long) = (0, 0, 0);
    let mut next = samples.iter().peekable();
    let before = thread_allocations();
    for tick in 0..=script.length_ms() {
        let sample = next.next_if(|s| s.0 == tick).map(|s| &s.1);
        match recognizer.step(tick, sample) {
            Some(GestureEvent::Recognised { .. }) => recognised += 1,
            Some(GestureEvent::Rejected { why, .. }) => {
                rejected += 1;
                too_long += usize::from(why == RejectReason::TooLong);
            }
            None => {}
        }
    }
    assert_eq!(thread_allocations() - before, 0);
    assert!(
        recognised >= 20 && rejected >= 4 && too_long >= 1,
        "{recognised} recognised, {rejected} rejected ({too_long} too long)"
    );
}
