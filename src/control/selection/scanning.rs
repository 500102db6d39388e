//! The scanning interface (BSP), the paper's baseline: Kinova's classic
//! sip-and-puff. In detection mode the modes are highlighted one after
//! the other on their own, `first_dwell_ms` for the first and `dwell_ms`
//! for each next, round and round; a puff enters the mode that was
//! highlighted when the puff began. Command mode, hold-to-run and the
//! return to scanning on inactivity are the same mode machine as ASP's.
//!
//! The highlight is a pure function of the tick the scan (re)started, so
//! the user and the replay see the same scan. RT-safe: no allocation.

use serde::Serialize;

use crate::control::Tick;
use crate::control::action::Breath;
use crate::control::detector::Burst;
use crate::control::mode::Mode;

/// The scanning interface's settings (`[scanning]` in the config file).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(into = "ScanningFields", from = "ScanningFields")]
pub struct ScanningConfig {
    /// How long each mode stays highlighted.
    pub dwell_ms: u32,
    /// How long the first mode stays highlighted when scanning (re)starts:
    /// time to see where the scan is.
    pub first_dwell_ms: u32,
    /// The modes in scan order (each once), as a fixed array and its length.
    pub order: [Mode; 9],
    /// Modes used in `order`.
    pub order_len: usize,
}

impl ScanningConfig {
    /// The modes in scan order (empty if `order_len` is 0; never more than
    /// the array holds).
    pub fn modes(&self) -> &[Mode] {
        self.order.get(..self.order_len).unwrap_or(&self.order)
    }
}

impl Default for ScanningConfig {
    fn default() -> Self {
        ScanningConfig {
            dwell_ms: 1500,
            first_dwell_ms: 3000,
            order: Mode::ALL,
            order_len: Mode::ALL.len(),
        }
    }
}

/// `[scanning]` as the config file has it: `order` is the list of mode
/// names (more than nine is left to the config's checks).
#[derive(Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
struct ScanningFields {
    dwell_ms: u32,
    first_dwell_ms: u32,
    order: Vec<Mode>,
}

impl Default for ScanningFields {
    fn default() -> Self {
        ScanningConfig::default().into()
    }
}

impl From<ScanningConfig> for ScanningFields {
    fn from(c: ScanningConfig) -> Self {
        ScanningFields {
            dwell_ms: c.dwell_ms,
            first_dwell_ms: c.first_dwell_ms,
            order: c.modes().to_vec(),
        }
    }
}

impl From<ScanningFields> for ScanningConfig {
    fn from(f: ScanningFields) -> Self {
        let mut order = Mode::ALL;
        for (slot, mode) in order.iter_mut().zip(&f.order) {
            *slot = *mode;
        }
        ScanningConfig {
            dwell_ms: f.dwell_ms,
            first_dwell_ms: f.first_dwell_ms,
            order,
            order_len: f.order.len(),
        }
    }
}

/// What the scanner says on one tick.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ScanOutput {
    /// The highlight moved to (or, when scanning starts, is on) this mode.
    pub highlight: Option<Mode>,
    /// A puff entered this mode.
    pub selected: Option<Mode>,
}

/// The scanner.
#[derive(Debug, Clone)]
pub struct Scanner {
    config: ScanningConfig,
    /// Tick the current scan started; `None` outside detection mode.
    started: Option<Tick>,
    highlighted: usize,
}

impl Scanner {
    /// A scanner that starts scanning on its first tick in detection mode.
    pub fn new(config: &ScanningConfig) -> Self {
        Scanner {
            config: *config,
            started: None,
            highlighted: 0,
        }
    }

    /// Index in the scan order highlighted `elapsed` ticks into a scan.
    fn index_after(&self, elapsed: Tick) -> usize {
        let first = u64::from(self.config.first_dwell_ms);
        if elapsed < first {
            return 0;
        }
        let dwell = u64::from(self.config.dwell_ms.max(1));
        let n = self.config.modes().len().max(1) as u64;
        ((1 + (elapsed - first) / dwell) % n) as usize
    }

    /// The mode highlighted now, if scanning.
    pub fn highlighted(&self) -> Option<Mode> {
        self.started.and(self.mode_at(self.highlighted))
    }

    /// The mode at `index` in the scan order; `None` for an empty order.
    fn mode_at(&self, index: usize) -> Option<Mode> {
        self.config.modes().get(index).copied()
    }

    /// One tick. `scanning`: the interface is in detection mode and the
    /// sensor is sound (a fault stops the scan; it starts again from the
    /// first mode). `burst`: the burst that ended on this tick, if any.
    pub fn step(&mut self, now: Tick, scanning: bool, burst: Option<&Burst>) -> ScanOutput {
        let mut out = ScanOutput::default();
        if !scanning {
            self.started = None;
            return out;
        }
        let first = self.mode_at(0);
        let start = *self.started.get_or_insert_with(|| {
            out.highlight = first;
            now
        });
        let index = self.index_after(now.saturating_sub(start));
        if index != self.highlighted || out.highlight.is_some() {
            self.highlighted = index;
            out.highlight = self.mode_at(index);
        }
        if let Some(b) = burst.filter(|b| b.action.breath() == Breath::Puff) {
            // The mode the user saw when the puff began (a puff that began
            // before this scan counts for its first mode).
            out.selected = self.mode_at(self.index_after(b.start.saturating_sub(start)));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::action::Action;

    fn puff(start: Tick, end: Tick) -> Burst {
        Burst {
            action: Action::ShortPuff,
            start,
            end,
        }
    }

    #[test]
    fn the_highlight_moves_on_its_dwell_times() {
        let config = ScanningConfig::default(); // 3000 ms first, 1500 ms each
        let mut s = Scanner::new(&config);
        let mut moves = Vec::new();
        for t in 100..100 + 3000 + 9 * 1500 {
            if let Some(mode) = s.step(t, true, None).highlight {
                moves.push((t, mode));
            }
        }
        let expected: Vec<(Tick, Mode)> = std::iter::once((100, Mode::TranslateX))
            .chain((1..9).map(|k| (100 + 3000 + (k as u64 - 1) * 1500, Mode::ALL[k])))
            .chain([(100 + 3000 + 8 * 1500, Mode::TranslateX)])
            .collect();
        assert_eq!(moves, expected);
    }

    #[test]
    fn a_puff_enters_the_mode_highlighted_when_it_began() {
        let mut s = Scanner::new(&ScanningConfig::default());
        for t in 0..4450 {
            s.step(t, true, None);
        }
        assert_eq!(s.highlighted(), Some(Mode::TranslateY)); // 3000–4499: y
        // Begun at 4400 under translate_y, confirmed at 4605 under z.
        let out = s.step(4605, true, Some(&puff(4400, 4600)));
        assert_eq!(out.selected, Some(Mode::TranslateY));
        // A sip selects nothing.
        let sip = Burst {
            action: Action::ShortSip,
            start: 4610,
            end: 4760,
        };
        assert_eq!(s.step(4765, true, Some(&sip)).selected, None);
    }

    #[test]
    fn leaving_detection_restarts_the_scan_from_the_first_mode() {
        let mut s = Scanner::new(&ScanningConfig::default());
        for t in 0..6000 {
            s.step(t, true, None);
        }
        assert_eq!(s.highlighted(), Some(Mode::TranslateZ));
        assert_eq!(s.step(6000, false, None), ScanOutput::default());
        assert_eq!(s.highlighted(), None);
        let out = s.step(9000, true, None);
        assert_eq!(out.highlight, Some(Mode::TranslateX));
        assert_eq!(s.step(9000 + 2999, true, None).highlight, None);
        assert_eq!(
            s.step(9000 + 3000, true, None).highlight,
            Some(Mode::TranslateY)
        );
    }

    #[test]
    fn a_custom_order_wraps_around() {
        let mut config = ScanningConfig::default();
        config.order[..2].copy_from_slice(&[Mode::Fingers, Mode::TranslateZ]);
        config.order_len = 2;
        config.first_dwell_ms = 1000;
        config.dwell_ms = 500;
        let mut s = Scanner::new(&config);
        let seen: Vec<Mode> = (0..2600)
            .filter_map(|t| s.step(t, true, None).highlight)
            .collect();
        assert_eq!(
            seen,
            [
                Mode::Fingers,
                Mode::TranslateZ,
                Mode::Fingers,
                Mode::TranslateZ,
                Mode::Fingers
            ]
        );
    }

    #[test]
    fn an_empty_order_highlights_and_selects_nothing() {
        let config = ScanningConfig {
            order_len: 0,
            ..ScanningConfig::default()
        };
        let mut s = Scanner::new(&config);
        for t in 0..10_000 {
            let burst = (t == 5000).then(|| puff(4000, 4200));
            assert_eq!(s.step(t, true, burst.as_ref()), ScanOutput::default());
        }
        assert_eq!(s.highlighted(), None);
    }
}
