//! The telemetry thread: the thread that started the run empties the
//! control thread's rings every few milliseconds, feeds the histograms,
//! and hands each event, tick and arm command on to whoever watches the
//! run (the event sink, the session recorder, the display). Not RT-safe;
//! nothing here can hold up the control thread, whose full rings drop
//! and count.

use std::io;

use crate::control::event::TimedEvent;
use crate::control::motion::stream::ArmCommand;
use crate::rt::recorder::{Lost, SessionRecorder};
use crate::rt::service_watchdog::Liveness;
use crate::rt::stop::StopRequest;
use crate::rt::telemetry::{Drops, Latencies, TelemetryObserver, TickRecord};

/// Where a run's events go, on the telemetry thread (not RT-safe). An
/// error from either method means the output has failed: the run stops
/// safely ([`StopReason::OutputFailed`](super::stop::StopReason)), the
/// sink is called no more, and the error is in the report.
pub trait EventSink {
    /// Writes one event.
    fn event(&mut self, event: &TimedEvent) -> io::Result<()>;

    /// Called every few milliseconds while the run goes on, between
    /// events: an error if the output is already known dead (a closed
    /// pipe) before anything is written to it.
    fn check(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// A closure is a sink that never fails (tests, benches).
impl<F: FnMut(&TimedEvent)> EventSink for F {
    fn event(&mut self, event: &TimedEvent) -> io::Result<()> {
        self(event);
        Ok(())
    }
}

/// Who watches a run from the telemetry thread; each is optional.
#[derive(Default)]
pub struct Watchers<'a> {
    /// Gets every event, first (the events printed).
    pub events: Option<&'a mut dyn EventSink>,
    /// Gets every tick's core input, arm command and event (`run
    /// --record`).
    pub recorder: Option<&'a mut dyn SessionRecorder>,
    /// Gets every record and event, after the others (the display).
    pub observer: Option<&'a mut dyn TelemetryObserver>,
}

/// The telemetry thread's ends of the control thread's rings.
pub struct TelemetryRings {
    /// One record per tick.
    pub records: rtrb::Consumer<TickRecord>,
    /// The events.
    pub events: rtrb::Consumer<TimedEvent>,
    /// A copy of each arm command, when recording.
    pub recorded_commands: Option<rtrb::Consumer<ArmCommand>>,
}

/// The telemetry side of one run: the histograms of full and reference
/// ticks, the count of events, and the first failure of the event sink,
/// after which the run stops safely and nothing more is written to it.
pub struct Telemetry<'a> {
    rings: TelemetryRings,
    watchers: Watchers<'a>,
    /// Set when the event sink fails.
    stop: StopRequest,
    full: Latencies,
    reference: Latencies,
    events: u64,
    output_error: Option<io::Error>,
    /// The ring drops the recorder has been told of.
    told: Drops,
    /// Whether the loop keeps running (the service's watchdog).
    liveness: Liveness,
}

/// The telemetry thread's part of the run report.
#[derive(Debug, Clone)]
pub struct TelemetryReport {
    /// The full ticks.
    pub full: Latencies,
    /// The reference ticks (`bench latency` only).
    pub reference: Latencies,
    /// Events received.
    pub events: u64,
    /// Why the event sink failed, if it did.
    pub output_error: Option<String>,
}

impl<'a> Telemetry<'a> {
    /// The telemetry of a run: empties `rings` for `watchers`; a failed
    /// event sink requests a safe stop through `stop`.
    pub fn new(rings: TelemetryRings, watchers: Watchers<'a>, stop: StopRequest) -> Self {
        Telemetry {
            rings,
            watchers,
            stop,
            full: Latencies::default(),
            reference: Latencies::default(),
            events: 0,
            output_error: None,
            told: Drops::default(),
            liveness: Liveness::default(),
        }
    }

    /// The loop's progress as the drained records show it.
    pub fn liveness(&mut self) -> &mut Liveness {
        &mut self.liveness
    }

    /// Empties the rings as they are now: the events, then the recorder's
    /// arm commands, then the tick records; then tells the observer.
    pub fn drain(&mut self) {
        if let Some(sink) = self.watchers.events.as_deref_mut()
            && self.output_error.is_none()
            && let Err(e) = sink.check()
        {
            self.output_failed(e);
        }
        while let Ok(event) = self.rings.events.pop() {
            self.event(&event);
        }
        if let (Some(recorder), Some(commands)) = (
            self.watchers.recorder.as_deref_mut(),
            self.rings.recorded_commands.as_mut(),
        ) {
            while let Ok(command) = commands.pop() {
                recorder.command(&command);
            }
        }
        while let Ok(record) = self.rings.records.pop() {
            self.record(&record);
        }
        if let Some(observer) = self.watchers.observer.as_deref_mut() {
            observer.drained();
        }
    }

    /// After the last drain, with the loop's final `drops`: the recorder
    /// learns of the records dropped after the last one that arrived.
    pub fn finish(mut self, drops: &Drops) -> TelemetryReport {
        if let Some(recorder) = self.watchers.recorder.as_deref_mut() {
            let lost = Lost::between(&self.told, drops);
            if !lost.is_empty() {
                recorder.lost(lost);
            }
        }
        TelemetryReport {
            full: self.full,
            reference: self.reference,
            events: self.events,
            output_error: self.output_error.map(|e| e.to_string()),
        }
    }

    fn event(&mut self, event: &TimedEvent) {
        self.events += 1;
        if let Some(sink) = self.watchers.events.as_deref_mut()
            && self.output_error.is_none()
            && let Err(e) = sink.event(event)
        {
            self.output_failed(e);
        }
        if let Some(recorder) = self.watchers.recorder.as_deref_mut() {
            recorder.event(event);
        }
        if let Some(observer) = self.watchers.observer.as_deref_mut() {
            observer.event(event);
        }
    }

    fn record(&mut self, record: &TickRecord) {
        self.liveness.tick(record.woke_ns);
        if record.reference {
            self.reference.record(record);
        } else {
            self.full.record(record);
        }
        if let Some(recorder) = self.watchers.recorder.as_deref_mut() {
            let lost = Lost::between(&self.told, &record.drops);
            self.told = record.drops;
            if !lost.is_empty() {
                recorder.lost(lost);
            }
            if !record.reference {
                recorder.input(&record.input);
            }
        }
        if let Some(observer) = self.watchers.observer.as_deref_mut() {
            observer.record(record);
        }
    }

    /// The first failure of the event sink: the run stops safely.
    fn output_failed(&mut self, error: io::Error) {
        self.output_error = Some(error);
        self.stop.output_failed();
    }
}

#[cfg(test)]
mod tests {
    use rtrb::RingBuffer;

    use super::*;
    use crate::control::event::Event;
    use crate::control::modes::DetectionReason;
    use crate::control::tick::TickInput;
    use crate::rt::stop::StopReason;

    /// The control thread's ends of a telemetry's rings.
    struct ControlEnds {
        records: rtrb::Producer<TickRecord>,
        events: rtrb::Producer<TimedEvent>,
        commands: rtrb::Producer<ArmCommand>,
    }

    fn rings() -> (ControlEnds, TelemetryRings) {
        let (records, records_rx) = RingBuffer::new(16);
        let (events, events_rx) = RingBuffer::new(16);
        let (commands, commands_rx) = RingBuffer::new(16);
        let rings = TelemetryRings {
            records: records_rx,
            events: events_rx,
            recorded_commands: Some(commands_rx),
        };
        (
            ControlEnds {
                records,
                events,
                commands,
            },
            rings,
        )
    }

    fn event(tick: u64) -> TimedEvent {
        TimedEvent {
            tick,
            event: Event::Detection {
                reason: DetectionReason::Inactivity,
            },
        }
    }

    fn record(tick: u64, reference: bool, dropped_records: u64) -> TickRecord {
        TickRecord {
            tick,
            wake_latency_ns: 20_000,
            compute_ns: 500,
            reference,
            drops: Drops {
                records: dropped_records,
                ..Drops::default()
            },
            input: TickInput {
                tick,
                ..TickInput::default()
            },
            ..TickRecord::default()
        }
    }

    /// A sink that fails from its `fails_at`-th event on.
    struct FailingSink {
        written: u64,
        fails_at: u64,
    }

    impl EventSink for FailingSink {
        fn event(&mut self, _: &TimedEvent) -> io::Result<()> {
            self.written += 1;
            if self.written >= self.fails_at {
                Err(io::Error::from(io::ErrorKind::BrokenPipe))
            } else {
                Ok(())
            }
        }
    }

    /// What a recorder was handed, in order.
    #[derive(Default)]
    struct Log(Vec<String>);

    impl SessionRecorder for Log {
        fn start(&mut self, _: &str, _: &str) {}
        fn input(&mut self, input: &TickInput) {
            self.0.push(format!("input {}", input.tick));
        }
        fn command(&mut self, command: &ArmCommand) {
            self.0.push(format!("command {}", command.seq));
        }
        fn event(&mut self, event: &TimedEvent) {
            self.0.push(format!("event {}", event.tick));
        }
        fn lost(&mut self, lost: Lost) {
            self.0.push(format!("lost {} ticks", lost.ticks));
        }
    }

    #[test]
    fn a_failed_sink_stops_the_run_and_is_written_no_more() {
        let (mut control, rings) = rings();
        let mut sink = FailingSink {
            written: 0,
            fails_at: 2,
        };
        let stop = StopRequest::new();
        let watchers = Watchers {
            events: Some(&mut sink),
            ..Watchers::default()
        };
        let mut telemetry = Telemetry::new(rings, watchers, stop.clone());
        for tick in 0..4 {
            control.events.push(event(tick)).unwrap();
        }
        telemetry.drain();
        assert_eq!(stop.reason(), Some(StopReason::OutputFailed));
        control.events.push(event(4)).unwrap();
        telemetry.drain();
        let report = telemetry.finish(&Drops::default());
        assert_eq!(report.events, 5);
        assert_eq!(report.output_error.as_deref(), Some("broken pipe"));
        assert_eq!(sink.written, 2);
    }

    #[test]
    fn the_recorder_gets_the_core_inputs_and_learns_of_losses_before_the_next_item() {
        let (mut control, rings) = rings();
        let mut log = Log::default();
        let watchers = Watchers {
            recorder: Some(&mut log),
            ..Watchers::default()
        };
        let mut telemetry = Telemetry::new(rings, watchers, StopRequest::new());
        control.events.push(event(0)).unwrap();
        control.commands.push(ArmCommand::default()).unwrap();
        control.records.push(record(0, false, 0)).unwrap();
        control.records.push(record(1, true, 0)).unwrap();
        // Ticks 2 and 3 were dropped on the way.
        control.records.push(record(4, false, 2)).unwrap();
        telemetry.drain();
        // One more dropped after the last that arrived.
        let report = telemetry.finish(&Drops {
            records: 3,
            ..Drops::default()
        });
        assert_eq!(
            log.0,
            [
                "event 0",
                "command 0",
                "input 0",
                "lost 2 ticks",
                "input 4",
                "lost 1 ticks"
            ]
        );
        assert_eq!(
            (report.full.wake.len(), report.reference.wake.len()),
            (2, 1)
        );
    }
}
