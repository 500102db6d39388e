//! The real-time runtime's logic on simulated time: the core's timers
//! stay true across skipped ticks, and a late wake-up faults and throws
//! the sensor's backlog away.

use sipnpuff::clock::SimClock;
use sipnpuff::config::Config;
use sipnpuff::control::event::Event;
use sipnpuff::control::modes::DetectionReason;
use sipnpuff::control::pipeline::Pipeline;
use sipnpuff::rt::scheduler::Scheduler;

use crate::common::TickByTick;
use sipnpuff::sim::script::run_script;
use sipnpuff::sim::sensor_model::{SignalGenerator, SignalParams};

const P: u64 = 1_000_000;

/// The scripted user through the core, paced by a scheduler on simulated
/// time; `stall` = (tick after which the machine stalls, ns). Returns the
/// events with their ticks, and the ticks skipped.
fn simulated_run(stall: Option<(u64, u64)>) -> (Vec<(u64, Event)>, u64) {
    let config = Config::default();
    let (script, _) = run_script(&config);
    let mut samples =
        SignalGenerator::new(SignalParams::clean(config.core().detector(), 3), &script);
    let mut core: Pipeline = Pipeline::new(config.core());
    let mut clock = SimClock::default();
    let mut scheduler = Scheduler::new(0, P, None);
    let mut events = Vec::new();
    loop {
        if let Some((at, ns)) = stall
            && scheduler.stats().ticks_run == at
        {
            clock.lateness.push_back(ns);
        }
        let wake = scheduler.wait(&mut clock);
        // Samples of skipped ticks are gone; the core is told the tick.
        for _ in 0..wake.skipped {
            samples.next();
        }
        let Some(volts) = samples.next() else { break };
        let out = core.tick(wake.tick, volts);
        events.extend(out.events.iter().map(|e| (out.tick, *e)));
        clock.advance(5_000);
    }
    (events, scheduler.stats().skipped_ticks)
}

#[test]
fn skipped_ticks_keep_the_cores_timers_true() {
    let (reference, skipped) = simulated_run(None);
    assert_eq!(skipped, 0);
    // The point is saved (the puff in save_point); 600 ms later, while
    // command mode waits for another breath, the machine stalls for 40 ms
    // (shorter than `stale_ms`): the inactivity timeout still ends command
    // mode at the same tick.
    let saved = reference
        .iter()
        .find(|(_, e)| matches!(e, Event::Motion(_)))
        .unwrap()
        .0;
    let (stalled, skipped) = simulated_run(Some((saved + 600, 40 * P + 300_000)));
    assert_eq!(skipped, 40);
    let detection = |events: &[(u64, Event)]| {
        events
            .iter()
            .find(|(_, e)| matches!(e, Event::Detection { .. }))
            .unwrap()
            .0
    };
    assert_eq!(detection(&stalled), detection(&reference));
    assert_eq!(stalled[..4], reference[..4]);
    assert!(
        !stalled
            .iter()
            .any(|(_, e)| matches!(e, Event::Fault { .. }))
    );

    // A 700 ms stall is longer than `stale_ms`: a fault on the first tick
    // after it, which ends command mode there and then.
    let (stalled, skipped) = simulated_run(Some((saved + 600, 700 * P + 300_000)));
    assert_eq!(skipped, 700);
    let resumed = saved + 600 + 700;
    assert!(
        stalled.contains(&(
            resumed,
            Event::Detection {
                reason: DetectionReason::Fault
            }
        )),
        "{stalled:?}"
    );
    let fault = stalled
        .iter()
        .find(|(_, e)| matches!(e, Event::Fault { .. }))
        .unwrap();
    assert_eq!(fault.0, resumed);
    assert!(
        format!("{fault:?}").contains("Stalled { ms: 701 }"),
        "{fault:?}"
    );
}

/// The control tick after a late wake-up: the machine stalled 2 s while
/// the user was puffing, and the sensor's ring filled meanwhile. The gap
/// is a fault at once, everything queued is thrown away (counted in the
/// drops), never replayed as a breath, and fresh samples at rest recover.
#[test]
fn a_late_wake_up_faults_and_discards_the_sensors_backlog() {
    use sipnpuff::control::event::TimedEvent;
    use sipnpuff::rt::arm_thread::{ArmHandoff, Handed};
    use sipnpuff::rt::control_loop::{ControlTick, OutputRings, TickWork};
    use sipnpuff::rt::scheduler::Wake;
    use sipnpuff::sensor::ring::{SAMPLE_RING, ring};

    let config = Config::default();
    let (arm_tx, _arm_rx) = rtrb::RingBuffer::<Handed>::new(4096);
    let (events_tx, mut events_rx) = rtrb::RingBuffer::<TimedEvent>::new(4096);
    let (mut feed, samples) = ring(SAMPLE_RING);
    let mut work = ControlTick::new(
        Pipeline::new(config.core()),
        samples,
        OutputRings {
            arm: ArmHandoff::new(arm_tx),
            events: events_tx,
            recorded: None,
            outputs: Vec::new(),
        },
        false,
    );
    let wake = |tick, skipped| Wake {
        tick,
        skipped,
        woke_ns: tick * P,
        latency_ns: skipped * P,
    };
    let mut tick = 0;
    let mut step = |feed: &mut sipnpuff::sensor::ring::SampleFeed, volts: f64, ms: u64| {
        for _ in 0..ms {
            feed.push(volts);
            work.tick(&wake(tick, 0), None);
            tick += 1;
        }
    };
    step(&mut feed, 2.5, 1000);
    step(&mut feed, 4.0, 1500); // a puff, still held when the machine stalls
    // The stall: the producer filled the ring with the puff meanwhile.
    let mut queued = 0;
    while feed.push(4.0) {
        queued += 1;
    }
    let resumed = tick + 2000;
    let outcome = work.tick(&wake(resumed, 2000), None);
    assert_eq!(outcome.drops.samples, queued, "the backlog, counted");
    let mut events = Vec::new();
    while let Ok(e) = events_rx.pop() {
        events.push(e);
    }
    let fault = events
        .iter()
        .find(|e| matches!(e.event, Event::Fault { .. }))
        .unwrap_or_else(|| panic!("no fault: {events:?}"));
    assert_eq!(fault.tick, resumed);
    let line = serde_json::to_string(fault).unwrap();
    assert!(line.contains("stalled for 2001 ms"), "{line}");
    // Fresh samples at rest: recovered after 250 of them, and no burst
    // ever (the backlog was not replayed).
    for tick in resumed + 1..resumed + 401 {
        feed.push(2.5);
        work.tick(&wake(tick, 0), None);
    }
    while let Ok(e) = events_rx.pop() {
        events.push(e);
    }
    assert!(
        events.iter().any(|e| e.event == Event::Recovered),
        "{events:?}"
    );
    assert!(
        !events.iter().any(|e| matches!(e.event, Event::Burst(_))),
        "{events:?}"
    );
}
