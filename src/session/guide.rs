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
        // A stop is said once, on stderr, where the session's end says
        // why it ended.
        if matches!(say, Say::Stopped(_)) {
            return;
        }
        if let (Say::Prompt(_), false, Some(band)) = (say, self.told_rest, self.prompter.band()) {
            self.told_rest = true;
            self.print(&format!(
                "rest: {:.3} V; a breath is {:.3} V or more away from it (the durations shown are measured there; the fit measures each breath again at the thresholds it proposes)",
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

#[cfg(test)]
mod tests {
    use std::cell::RefCell;

    use super::*;
    use crate::config::Config;
    use crate::control::sample::Sample;
    use crate::fit::prompter::Stop;
    use crate::fit::protocol::Protocol;
    use crate::session::showing::{Display, DisplayChoice};

    /// A console that keeps what is said, stdout and stderr apart.
    #[derive(Default)]
    struct Kept {
        out: RefCell<Vec<String>>,
        err: RefCell<Vec<String>>,
    }

    impl Console for Kept {
        fn note(&self, line: &str) {
            self.err.borrow_mut().push(line.to_string());
        }
        fn print(&self, text: &str) -> std::io::Result<()> {
            self.out
                .borrow_mut()
                .extend(text.lines().map(str::to_string));
            Ok(())
        }
        fn print_line(&self, line: &str) -> std::io::Result<()> {
            self.print(line)
        }
    }

    #[test]
    fn a_session_that_stops_leaves_its_reason_to_the_end_of_the_session() {
        // Nobody breathes: the rest is measured, the first prompt goes
        // unanswered twice and the session stops. The guide prints the
        // prompts; why it stopped is said once, by the session's end.
        let console = Kept::default();
        let choice = DisplayChoice {
            page: None,
            tui: false,
        };
        let display = Display::open(&choice, &console).unwrap();
        let mut showing = display.start_fit(Config::default().core(), "sim").unwrap();
        let prompter = Prompter::new(&Protocol::new(3, 0));
        let mut guide = Guide::new(prompter, &mut showing, StopRequest::new(), &console, false);
        for tick in 0..120_000 {
            let mut record = TickRecord::default();
            record.input.tick = tick;
            record.input.sample = Sample::Volts(2.5 + 0.002 * ((tick % 7) as f64 - 3.0));
            guide.record(&record);
            if guide.prompter.is_over() {
                break;
            }
        }
        let stop = guide.prompter.stopped();
        assert!(matches!(stop, Some(Stop::Silence { .. })), "{stop:?}");
        let out = console.out.borrow();
        assert!(out.iter().any(|l| l.contains(" — now (")), "{out:#?}");
        let words = stop.unwrap().words();
        assert!(!out.iter().any(|l| l.contains(&words)), "{out:#?}");
        assert!(console.err.borrow().is_empty());
    }
}
