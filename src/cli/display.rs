//! The display's options (`run`, `fit`): the page's address, none, or the
//! terminal view; the session wires what they choose
//! ([`crate::session::showing`]).

use std::net::{SocketAddr, ToSocketAddrs};

use crate::session::showing::DisplayChoice;

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

impl DisplayArgs {
    /// The display these options ask for.
    pub fn choice(&self) -> DisplayChoice {
        DisplayChoice {
            page: (!self.no_display).then_some(self.display),
            tui: self.tui,
        }
    }
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
