//! The scanning interface (BSP), the paper's baseline: Kinova's classic
//! sip-and-puff. In detection mode the modes are highlighted one after
//! the other on their own, `first_dwell_ms` for the first and `dwell_ms`
//! for each next, round and round; a puff enters the mode that was
//! highlighted when the puff began. Command mode, hold-to-run and the
//! return to scanning on inactivity are the same mode machine as ASP's.
//!
//! The highlight is a pure function of the tick the scan (re)started, so
//! the user and the replay see the same scan. RT-safe: no allocation.

use crate::Tick;
use crate::action::Breath;
use crate::config::ScanningConfig;
use crate::detector::Burst;
use crate::modes::Mode;

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
        self.started.map(|_| self.config.modes()[self.highlighted])
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
        let start = *self.started.get_or_insert_with(|| {
            out.highlight = Some(self.config.modes()[0]);
            now
        });
        let index = self.index_after(now - start);
        if index != self.highlighted || out.highlight.is_some() {
            self.highlighted = index;
            out.highlight = Some(self.config.modes()[index]);
        }
        if let Some(b) = burst.filter(|b| b.action.breath() == Breath::Puff) {
            // The mode the user saw when the puff began (a puff that began
            // before this scan counts for its first mode).
            let at = self.index_after(b.start.saturating_sub(start));
            out.selected = Some(self.config.modes()[at]);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::action::Action;

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
}
