//! `run`'s display options and their wiring: the page's address is taken
//! before anything starts (a clash is an error then, not a display missing
//! later); for the run, a hub on the telemetry thread, the page's server
//! and the terminal view, ended before the report is printed. Built
//! without the `display` feature (the fuzz targets), there is none.

use std::net::{SocketAddr, ToSocketAddrs};

use crate::control::Tick;
use crate::control::core_config::CoreConfig;
use crate::fit::outcome::Outcome;
use crate::fit::prompter::{Say, View};
use crate::rt::report::RunReport;
use crate::rt::telemetry::TelemetryObserver;

/// The page's default address: this machine only (the wheelchair's own
/// screen).
pub const DEFAULT_ADDRESS: &str = "127.0.0.1:8080";

/// The display's options.
#[derive(clap::Args, Debug)]
pub struct DisplayArgs {
    /// Serve the display (the modes, the sequence breathed so far, the
    /// pressure, the arm's state, sounds) at this address, for a kiosk
    /// browser on the wheelchair's screen, a tablet or a laptop:
    /// `HOST:PORT` or `PORT` (on 127.0.0.1, this machine only).
    #[arg(long, value_name = "ADDR", default_value = DEFAULT_ADDRESS, env = "SIPNPUFF_DISPLAY", value_parser = parse_display)]
    display: SocketAddr,
    /// Don't serve the display (also `SIPNPUFF_NO_DISPLAY=1`).
    #[arg(long, env = "SIPNPUFF_NO_DISPLAY", value_parser = clap::builder::BoolishValueParser::new())]
    no_display: bool,
    /// Show the display in this terminal instead of printing events (the
    /// report follows when the run ends; Ctrl-C stops the run as always).
    #[arg(long)]
    pub tui: bool,
}

/// `--display`: `HOST:PORT` or a port on 127.0.0.1.
fn parse_display(text: &str) -> Result<SocketAddr, String> {
    if let Ok(port) = text.parse::<u16>() {
        return Ok(SocketAddr::from(([127, 0, 0, 1], port)));
    }
    text.to_socket_addrs()
        .ok()
        .and_then(|mut addresses| addresses.next())
        .ok_or_else(|| {
            format!(
                "{text:?}: not HOST:PORT or PORT (e.g. 127.0.0.1:8080, 0.0.0.0:8080 for a tablet on the network, 8081)"
            )
        })
}

#[cfg(feature = "display")]
mod wired {
    use std::net::TcpListener;

    use super::*;
    use crate::display::hub::DisplayHub;
    use crate::display::server::DisplayServer;
    use crate::display::tui::TerminalView;

    /// The display chosen, its address taken.
    pub struct Display {
        listener: Option<TcpListener>,
        tui: bool,
    }

    impl Display {
        /// Takes the page's address (unless `--no-display`).
        pub fn open(args: &DisplayArgs) -> anyhow::Result<Display> {
            Ok(Display {
                listener: if args.no_display {
                    None
                } else {
                    Some(DisplayServer::bind(args.display)?)
                },
                tui: args.tui,
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
                note!("sipnpuff: the display is at http://{}/", server.address());
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
    pub struct Display;

    impl Display {
        /// Says the display was asked for and is not built in.
        pub fn open(args: &DisplayArgs) -> anyhow::Result<Display> {
            if !args.no_display || args.tui {
                note!(
                    "sipnpuff: built without the `display` feature (on by default): no page, no terminal view"
                );
            }
            Ok(Display)
        }

        /// Nothing to start.
        pub fn start(&self, _config: &CoreConfig, _arm: &str) -> anyhow::Result<Showing> {
            Ok(Showing)
        }

        /// Nothing to start.
        pub fn start_fit(&self, _config: &CoreConfig, _arm: &str) -> anyhow::Result<Showing> {
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

        /// Nothing to end.
        pub fn finish(&mut self, _report: Option<&mut RunReport>) {}
    }
}

pub use wired::{Display, Showing};
