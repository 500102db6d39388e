//! The display of a session: the page's address taken before anything
//! starts (a clash is an error then, not a display missing later); for
//! the run, a hub on the telemetry thread, the page's server and the
//! terminal view, ended before the report is printed. Built without the
//! `display` feature (the fuzz targets), there is none.

use std::net::SocketAddr;

use crate::control::Tick;
use crate::control::core_config::CoreConfig;
use crate::control::imu::ImuInput;
use crate::fit::outcome::Outcome;
use crate::fit::prompter::{Say, View};
use crate::gestures::guided::Say as GuideSay;
use crate::rt::report::RunReport;
use crate::rt::telemetry::TelemetryObserver;
use crate::session::Console;

/// The display asked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DisplayChoice {
    /// Serve the page at this address (`None`: no page).
    pub page: Option<SocketAddr>,
    /// Show the display in the terminal instead of printing events.
    pub tui: bool,
}

#[cfg(feature = "display")]
mod wired {
    use std::net::TcpListener;

    use super::*;
    use crate::display::hub::DisplayHub;
    use crate::display::server::DisplayServer;
    use crate::display::tui::TerminalView;

    /// The display chosen, its address taken; it says on `console`
    /// where the page is.
    pub struct Display<'a> {
        listener: Option<TcpListener>,
        tui: bool,
        console: &'a dyn Console,
    }

    impl<'a> Display<'a> {
        /// Takes the page's address (if a page is asked for).
        pub fn open(choice: &DisplayChoice, console: &'a dyn Console) -> anyhow::Result<Self> {
            Ok(Display {
                listener: match choice.page {
                    Some(address) => Some(DisplayServer::bind(address)?),
                    None => None,
                },
                tui: choice.tui,
                console,
            })
        }

        /// Starts what was chosen for a run of `config` on `arm` (in words).
        pub fn start(&self, config: &CoreConfig, arm: &str) -> anyhow::Result<Showing> {
            self.start_hub(|| DisplayHub::new(config, arm))
        }

        /// Starts the page of a live calibration (`sipnpuff fit`) on
        /// `config` and `arm`: its prompts instead of the modes.
        pub fn start_fit(&self, config: &CoreConfig, arm: &str) -> anyhow::Result<Showing> {
            self.start_hub(|| DisplayHub::for_fit(config, arm))
        }

        /// Starts the page of a live gesture recording of `names`: its
        /// prompts and the head.
        pub fn start_gestures(
            &self,
            config: &CoreConfig,
            names: &[String],
        ) -> anyhow::Result<Showing> {
            self.start_hub(|| DisplayHub::for_gestures(config, names))
        }

        fn start_hub(&self, hub: impl FnOnce() -> DisplayHub) -> anyhow::Result<Showing> {
            if self.listener.is_none() && !self.tui {
                return Ok(Showing::default());
            }
            let hub = hub();
            let server = match &self.listener {
                Some(listener) => Some(DisplayServer::serve(listener.try_clone()?, hub.feed())?),
                None => None,
            };
            if let Some(server) = &server {
                self.console.note(&format!(
                    "sipnpuff: the display is at http://{}/",
                    server.address()
                ));
            }
            let view = if self.tui {
                Some(TerminalView::start(hub.feed())?)
            } else {
                None
            };
            Ok(Showing {
                hub: Some(hub),
                server,
                view,
            })
        }
    }

    /// The display of one run.
    #[derive(Default)]
    pub struct Showing {
        hub: Option<DisplayHub>,
        server: Option<DisplayServer>,
        view: Option<TerminalView>,
    }

    impl Showing {
        /// What watches the run from the telemetry thread.
        pub fn observer(&mut self) -> Option<&mut dyn TelemetryObserver> {
            self.hub.as_mut().map(|h| h as &mut dyn TelemetryObserver)
        }

        /// A live calibration's state from its guide, after it said
        /// `said` on `tick`.
        pub fn calibrate(&mut self, tick: Tick, view: &View, said: Option<&Say>) {
            if let Some(hub) = self.hub.as_mut() {
                hub.calibrate(tick, view, said);
            }
        }

        /// A live gesture recording's IMU input on `tick`.
        pub fn observe_imu(&mut self, tick: Tick, input: ImuInput) {
            if let Some(hub) = self.hub.as_mut() {
                hub.observe_imu(tick, input);
            }
        }

        /// What a live gesture recording's guide said on `tick`, `seen`
        /// examples in (`max_ms`: the longest gesture).
        pub fn guide_gestures(&mut self, tick: Tick, said: &GuideSay, seen: usize, max_ms: u32) {
            if let Some(hub) = self.hub.as_mut() {
                hub.guide_gestures(tick, said, seen, max_ms);
            }
        }

        /// A live gesture recording's end, the session's last frame:
        /// waits (at most `limit`) until every open page has it.
        pub fn conclude_gestures(
            &mut self,
            summary: String,
            written: bool,
            limit: std::time::Duration,
        ) {
            let Some(hub) = self.hub.as_mut() else {
                return;
            };
            hub.conclude_gestures(summary, written);
            if self.server.is_some() && hub.feed().wait_last_sent(limit) {
                std::thread::sleep(std::time::Duration::from_millis(100));
            }
        }

        /// A live calibration's summary, the session's last frame: waits
        /// (at most `limit`) until every open page has it, so the page
        /// keeps it when the server goes.
        pub fn conclude(&mut self, outcome: &Outcome, limit: std::time::Duration) {
            let Some(hub) = self.hub.as_mut() else {
                return;
            };
            hub.conclude(outcome);
            if self.server.is_some() && hub.feed().wait_last_sent(limit) {
                // Sent to the socket: a moment for it to leave.
                std::thread::sleep(std::time::Duration::from_millis(100));
            }
        }

        /// After the run: the last frame published, the terminal given
        /// back, the figures in `report` (when there is one).
        pub fn finish(&mut self, report: Option<&mut RunReport>) {
            if let Some(hub) = self.hub.as_mut() {
                hub.publish();
            }
            drop(self.view.take());
            if let (Some(hub), Some(report)) = (&self.hub, report) {
                let address = self.server.as_ref().map(|s| s.address().to_string());
                report.display = Some(hub.feed().summary(address));
            }
        }
    }
}

#[cfg(not(feature = "display"))]
mod wired {
    use super::*;

    /// No display in this build.
    pub struct Display<'a>(std::marker::PhantomData<&'a dyn Console>);

    impl<'a> Display<'a> {
        /// Says the display was asked for and is not built in.
        pub fn open(choice: &DisplayChoice, console: &'a dyn Console) -> anyhow::Result<Self> {
            if choice.page.is_some() || choice.tui {
                console.note(
                    "sipnpuff: built without the `display` feature (on by default): no page, no terminal view",
                );
            }
            Ok(Display(std::marker::PhantomData))
        }

        /// Nothing to start.
        pub fn start(&self, _config: &CoreConfig, _arm: &str) -> anyhow::Result<Showing> {
            Ok(Showing)
        }

        /// Nothing to start.
        pub fn start_fit(&self, _config: &CoreConfig, _arm: &str) -> anyhow::Result<Showing> {
            Ok(Showing)
        }

        /// Nothing to start.
        pub fn start_gestures(
            &self,
            _config: &CoreConfig,
            _names: &[String],
        ) -> anyhow::Result<Showing> {
            Ok(Showing)
        }
    }

    /// No display.
    pub struct Showing;

    impl Showing {
        /// None.
        pub fn observer(&mut self) -> Option<&mut dyn TelemetryObserver> {
            None
        }

        /// Nothing to show.
        pub fn calibrate(&mut self, _tick: Tick, _view: &View, _said: Option<&Say>) {}

        /// Nothing to show.
        pub fn conclude(&mut self, _outcome: &Outcome, _limit: std::time::Duration) {}

        /// Nothing to show.
        pub fn observe_imu(&mut self, _tick: Tick, _input: ImuInput) {}

        /// Nothing to show.
        pub fn guide_gestures(
            &mut self,
            _tick: Tick,
            _said: &GuideSay,
            _seen: usize,
            _max_ms: u32,
        ) {
        }

        /// Nothing to show.
        pub fn conclude_gestures(
            &mut self,
            _summary: String,
            _written: bool,
            _limit: std::time::Duration,
        ) {
        }

        /// Nothing to end.
        pub fn finish(&mut self, _report: Option<&mut RunReport>) {}
    }
}

pub use wired::{Display, Showing};
