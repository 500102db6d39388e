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
        }
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
