//! A live calibration's guide on the telemetry thread: each tick's sample
//! (what the core was given, as recorded) to the [`Prompter`], what it
//! says to the terminal and the page; the run stopped once the session is
//! over. The page's hub watches the run behind it.

use crate::control::action::Breath;
use crate::control::event::TimedEvent;
use crate::fit::prompter::{Prompter, Say};
use crate::rt::stop::StopRequest;
use crate::rt::telemetry::{TelemetryObserver, TickRecord};
use crate::session::Console;
use crate::session::showing::Showing;

/// The guide of one session.
pub struct Guide<'a> {
    /// The protocol's progress.
    pub prompter: Prompter,
    showing: &'a mut Showing,
    stop: StopRequest,
    console: &'a dyn Console,
    /// The prompts go to stderr (stdout holds the JSON).
    to_stderr: bool,
    /// The breath held, as last shown.
    held: Option<Breath>,
    /// The rest's level was printed.
    told_rest: bool,
}

impl<'a> Guide<'a> {
    /// A guide for `prompter`, showing on `showing` and saying on
    /// `console` (the prompts on stderr if `to_stderr`), that sets `stop`
    /// when the session is over.
    pub fn new(
        prompter: Prompter,
        showing: &'a mut Showing,
        stop: StopRequest,
        console: &'a dyn Console,
        to_stderr: bool,
    ) -> Guide<'a> {
        Guide {
            prompter,
            showing,
            stop,
            console,
            to_stderr,
            held: None,
            told_rest: false,
        }
    }

    /// A line for the terminal; a failed stdout does not stop the
    /// session (the report will say it).
    fn print(&self, line: &str) {
        if self.to_stderr {
            self.console.note(line);
        } else {
            let _ = self.console.print_line(line);
        }
    }

    fn said(&mut self, say: &Say) {
        if let (Say::Prompt(_), false, Some(band)) = (say, self.told_rest, self.prompter.band()) {
            self.told_rest = true;
            self.print(&format!(
                "rest: {:.3} V; a breath is {:.3} V or more away from it",
                band.level, band.outside
            ));
        }
        self.print(&say.line());
    }
}

impl TelemetryObserver for Guide<'_> {
    fn record(&mut self, record: &TickRecord) {
        if !record.reference && !self.prompter.is_over() {
            let tick = record.input.tick;
            let said = self.prompter.step(tick, record.input.sample);
            if let Some(say) = &said {
                self.said(say);
            }
            let view = self.prompter.view();
            if said.is_some() || view.held != self.held {
                self.held = view.held;
                self.showing.calibrate(tick, &view, said.as_ref());
            }
            if self.prompter.is_over() {
                self.stop.finished();
            }
        }
        if let Some(observer) = self.showing.observer() {
            observer.record(record);
        }
    }

    fn event(&mut self, event: &TimedEvent) {
        if let Some(observer) = self.showing.observer() {
            observer.event(event);
        }
    }

    fn drained(&mut self) {
        if let Some(observer) = self.showing.observer() {
            observer.drained();
        }
    }
}
