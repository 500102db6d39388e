//! The terminal view (`run --tui`): the page's content for an engineer on
//! SSH, drawn with ratatui from the same [`Frame`]s. [`draw`] is pure (it
//! is tested with ratatui's test backend); [`TerminalView`] is the thread
//! that redraws the terminal from the [`Feed`].
//!
//! The terminal is not put in raw mode: Ctrl-C still sends SIGINT, which
//! stops the run safely.

use std::io::{self, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

use ratatui::Terminal;
use ratatui::backend::{Backend, CrosstermBackend};
use ratatui::crossterm::{cursor, execute, terminal};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Gauge, List, ListItem, Paragraph, Wrap};

use crate::display::frame::{Frame, Setup, Symbol};
use crate::display::hub::Feed;

/// How often the terminal is redrawn, ms.
const REDRAW_MS: u64 = 50;

fn symbol_span(s: &Symbol) -> Span<'static> {
    let (text, color) = match (s.gesture, s.breath, s.long) {
        (Some(name), _, _) => (
            format!(" {} ", name.as_str().to_uppercase()),
            Color::Magenta,
        ),
        (None, "sip", false) => (" sip ".into(), Color::Cyan),
        (None, "sip", true) => (" LONG SIP ".into(), Color::Cyan),
        (None, _, false) => (" puff ".into(), Color::Yellow),
        (None, _, true) => (" LONG PUFF ".into(), Color::Yellow),
    };
    Span::styled(
        text,
        Style::default()
            .fg(Color::Black)
            .bg(color)
            .add_modifier(Modifier::BOLD),
    )
}

fn symbols_line(symbols: &[Symbol]) -> Vec<Span<'static>> {
    let mut spans = Vec::new();
    for (i, s) in symbols.iter().enumerate() {
        if i > 0 {
            spans.push(Span::raw(" "));
        }
        spans.push(symbol_span(s));
    }
    spans
}

fn label<'a>(setup: &'a Setup, mode: &'a str) -> &'a str {
    setup
        .modes
        .iter()
        .find(|m| m.mode == mode)
        .map_or(mode, |m| m.label.as_str())
}

fn seconds(ms: u64) -> String {
    format!("{:.1} s", ms as f64 / 1000.0)
}

/// Draws `frame` of a run with `setup` into `area` of `out`.
pub fn draw(out: &mut ratatui::Frame<'_>, setup: &Setup, frame: &Frame) {
    let area = out.area();
    let [banner, body] = Layout::vertical([Constraint::Length(3), Constraint::Min(0)]).areas(area);
    let title = match (frame.state, &frame.command) {
        ("stopped", _) => "STOPPED — the arm is not moving".to_string(),
        (_, Some(c)) => {
            let moved = if ["pointer_x", "pointer_y", "scroll"].contains(&c.mode) {
                "the pointer"
            } else {
                "the arm"
            };
            format!("{} — {} {moved}", label(setup, c.mode), setup.movers)
        }
        _ if setup.interface == "asp" => {
            format!("Choose a mode: {} its sequence", setup.sequence_verb)
        }
        _ => "Choose a mode: puff when it is lit".into(),
    };
    let banner_style = match frame.state {
        "stopped" => Style::default().fg(Color::Red),
        "command" => Style::default().fg(Color::Green),
        _ => Style::default(),
    };
    out.render_widget(
        Paragraph::new(Line::styled(
            title,
            banner_style.add_modifier(Modifier::BOLD),
        ))
        .block(Block::default().borders(Borders::ALL).title(" sipnpuff ")),
        banner,
    );
    let [left, right] =
        Layout::horizontal([Constraint::Percentage(52), Constraint::Percentage(48)]).areas(body);
    draw_modes(out, left, setup, frame);
    draw_status(out, right, setup, frame);
}

fn draw_modes(out: &mut ratatui::Frame<'_>, area: Rect, setup: &Setup, frame: &Frame) {
    let selecting = frame.state == "selecting";
    let entered = !frame.sequence.is_empty();
    let mut items = Vec::new();
    for entry in &setup.modes {
        let indices: Vec<usize> = setup
            .sequences
            .iter()
            .enumerate()
            .filter(|(_, s)| s.mode == entry.mode)
            .map(|(i, _)| i)
            .collect();
        let lit = indices.iter().any(|i| frame.candidates.contains(i));
        let highlighted = frame.highlight.is_some_and(|h| h.mode == entry.mode);
        // Lit only in command mode; the last used is merely marked.
        let selected = frame.selected == Some(entry.mode.as_str()) && frame.state == "command";
        let last = frame.selected == Some(entry.mode.as_str()) && selecting && !entered;
        let (marker, style) = if highlighted {
            ("▶ ", Style::default().fg(Color::Black).bg(Color::Yellow))
        } else if selected {
            (
                "✔ ",
                Style::default()
                    .fg(Color::Green)
                    .add_modifier(Modifier::BOLD),
            )
        } else if selecting && entered && setup.interface == "asp" && !lit {
            ("  ", Style::default().fg(Color::DarkGray))
        } else {
            ("  ", Style::default())
        };
        let mut lines = vec![Line::styled(
            format!(
                "{marker}{}{}",
                entry.label,
                if last { "  (last used)" } else { "" }
            ),
            style,
        )];
        for (k, sequence) in entry.sequences.iter().enumerate() {
            let dim = selecting
                && entered
                && !indices.get(k).is_some_and(|i| frame.candidates.contains(i));
            let mut spans = vec![Span::raw("    ")];
            if dim {
                spans.push(Span::styled(
                    sequence
                        .iter()
                        .map(Symbol::words)
                        .collect::<Vec<_>>()
                        .join(" "),
                    Style::default().fg(Color::DarkGray),
                ));
            } else {
                spans.extend(symbols_line(sequence));
            }
            lines.push(Line::from(spans));
        }
        if let Some(h) = frame.highlight.filter(|h| h.mode == entry.mode) {
            lines.push(Line::raw(format!("    {} left", seconds(h.ms_left))));
        }
        items.push(ListItem::new(lines));
    }
    out.render_widget(
        List::new(items).block(Block::default().borders(Borders::ALL).title(" Modes ")),
        area,
    );
}

fn draw_status(out: &mut ratatui::Frame<'_>, area: Rect, setup: &Setup, frame: &Frame) {
    let [notices, middle, pressure, status] = Layout::vertical([
        Constraint::Length(frame.notices.len().min(3) as u16 + 2),
        Constraint::Length(6),
        Constraint::Length(5),
        Constraint::Min(3),
    ])
    .areas(area);
    let lines: Vec<Line> = frame
        .notices
        .iter()
        .map(|n| {
            let color = match n.level {
                "fault" => Color::Red,
                "limit" => Color::Yellow,
                _ => Color::White,
            };
            Line::styled(
                n.text.clone(),
                Style::default().fg(color).add_modifier(Modifier::BOLD),
            )
        })
        .collect();
    out.render_widget(
        Paragraph::new(lines)
            .wrap(Wrap { trim: true })
            .block(Block::default().borders(Borders::ALL).title(" Notices ")),
        notices,
    );

    let mut lines = Vec::new();
    if let Some(c) = &frame.command {
        lines.push(Line::styled(
            format!("{}: {}", label(setup, c.mode), c.moving),
            Style::default().add_modifier(Modifier::BOLD),
        ));
        lines.push(Line::raw(if c.countdown_paused {
            if frame.pressure.held.is_some() {
                "breath held — staying in this mode".to_string()
            } else {
                "head tilted — staying in this mode".to_string()
            }
        } else {
            format!("back to choosing a mode in {}", seconds(c.returns_in_ms))
        }));
    } else if setup.interface == "asp" {
        let title = if setup.head.is_some() {
            "Your sequence: "
        } else {
            "You breathed: "
        };
        let mut spans = vec![Span::raw(title)];
        if frame.sequence.is_empty() {
            spans.push(Span::raw("nothing yet"));
        } else {
            spans.extend(symbols_line(&frame.sequence));
        }
        lines.push(Line::from(spans));
        if let Some(w) = &frame.waiting {
            lines.push(Line::raw(match w.selects.as_deref() {
                Some(mode) => format!("{} in {}", label(setup, mode), seconds(w.ms_left)),
                None => format!("start again in {} unless you go on", seconds(w.ms_left)),
            }));
        }
    }
    out.render_widget(
        Paragraph::new(lines).block(Block::default().borders(Borders::ALL).title(
            if frame.command.is_some() {
                " Moving "
            } else {
                " Selection "
            },
        )),
        middle,
    );

    if !setup.breath {
        draw_head(out, pressure, setup, frame);
    } else {
        draw_pressure(out, pressure, setup, frame);
    }

    let saved = match frame.saved_point {
        "set" => "set",
        "reached" => "reached",
        _ => "not set",
    };
    let arm = if frame.arm == "fault" {
        Span::styled(
            "FAULT — stopped",
            Style::default().fg(Color::Red).add_modifier(Modifier::BOLD),
        )
    } else {
        Span::styled(
            format!("connected ({})", setup.arm),
            Style::default().fg(Color::Green),
        )
    };
    out.render_widget(
        Paragraph::new(vec![
            Line::from(vec![Span::raw("Arm: "), arm]),
            Line::raw(format!("Saved point: {saved}; tick {}", frame.tick)),
        ])
        .block(Block::default().borders(Borders::ALL)),
        status,
    );
}

/// The pressure bar: the sample against the thresholds, a breath held.
fn draw_pressure(out: &mut ratatui::Frame<'_>, area: Rect, setup: &Setup, frame: &Frame) {
    let p = &frame.pressure;
    let volts = p.volts.unwrap_or(p.neutral_volts);
    let held = match p.held {
        Some(breath) => format!(
            "; {breath} held {} ({})",
            seconds(p.held_ms),
            if p.held_ms >= u64::from(setup.long_ms) {
                "long"
            } else {
                "short"
            }
        ),
        None => String::new(),
    };
    out.render_widget(
        Gauge::default()
            .block(Block::default().borders(Borders::ALL).title(format!(
                " Pressure: puff above {:.2} V, sip below {:.2} V ",
                p.neutral_volts + setup.puff_offset_volts,
                p.neutral_volts + setup.sip_offset_volts
            )))
            .ratio((volts / 5.0).clamp(0.0, 1.0))
            .label(format!("{volts:.2} V{held}")),
        area,
    );
}

/// The head in place of the pressure bar: its pitch (or roll) against
/// ±45°, with the dead zone in the title.
fn draw_head(out: &mut ratatui::Frame<'_>, area: Rect, setup: &Setup, frame: &Frame) {
    let (title, ratio, label) = match (setup.head, frame.head) {
        (Some(s), Some(h)) => {
            let roll = s.tilt == "roll";
            let deg = if roll { h.roll_deg } else { h.pitch_deg };
            (
                format!(" Head: {} past ±{}° moves ", s.tilt, s.dead_zone_deg),
                ((deg + 45.0) / 90.0).clamp(0.0, 1.0),
                format!(
                    "pitch {:+.0}° · roll {:+.0}°{}",
                    h.pitch_deg,
                    h.roll_deg,
                    if h.moving { " — moving" } else { "" }
                ),
            )
        }
        _ => (" Head ".to_string(), 0.5, "no sample".to_string()),
    };
    out.render_widget(
        Gauge::default()
            .block(Block::default().borders(Borders::ALL).title(title))
            .ratio(ratio)
            .label(label),
        area,
    );
}

/// Draws one frame on `terminal` (any backend).
pub fn render<B: Backend>(
    terminal: &mut Terminal<B>,
    setup: &Setup,
    frame: &Frame,
) -> Result<(), B::Error> {
    terminal.draw(|out| draw(out, setup, frame)).map(|_| ())
}

/// The thread that redraws the terminal; restores it when dropped.
pub struct TerminalView {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl TerminalView {
    /// Takes over stdout (the alternate screen) and redraws it from `feed`.
    pub fn start(feed: Arc<Feed>) -> anyhow::Result<TerminalView> {
        let mut stdout = io::stdout();
        execute!(stdout, terminal::EnterAlternateScreen, cursor::Hide)?;
        let mut terminal = Terminal::new(CrosstermBackend::new(io::stdout()))?;
        let stop = Arc::new(AtomicBool::new(false));
        let stopping = stop.clone();
        let thread = std::thread::Builder::new()
            .name("tui".into())
            .spawn(move || {
                let mut drawn = 0;
                while !stopping.load(Ordering::Relaxed) {
                    let latest = feed.latest();
                    if latest.seq != drawn {
                        drawn = latest.seq;
                        if render(&mut terminal, &feed.setup, &latest.frame).is_err() {
                            break; // the terminal is gone: the run goes on
                        }
                    }
                    std::thread::sleep(Duration::from_millis(REDRAW_MS));
                }
                let latest = feed.latest();
                let _ = render(&mut terminal, &feed.setup, &latest.frame);
            })?;
        Ok(TerminalView {
            stop,
            thread: Some(thread),
        })
    }
}

impl Drop for TerminalView {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
        let mut stdout = io::stdout();
        let _ = execute!(stdout, terminal::LeaveAlternateScreen, cursor::Show);
        let _ = stdout.flush();
    }
}
