//! Detection accuracy: a scripted user on the seeded synthetic sensor, run
//! through the whole core, scored against the script. The stress tests
//! demand a perfect score at the edges the detector must handle;
//! `sipnpuff bench accuracy` shows where accuracy falls off as noise and
//! hum grow past them.

use serde::Serialize;

use crate::config::Config;
use crate::control::detector::{Burst, FaultReason};
use crate::control::event::Event;
use crate::control::mode::Mode;
use crate::control::pipeline::Pipeline;
use crate::control::tick::{TickInput, TickOutput};
use crate::rt::alloc_counter;
use crate::sim::script::random_session;
use crate::sim::sensor_model::{ScriptedBreath, SignalGenerator, SignalParams, Step};

/// How one scripted session went, breath by breath and selection by
/// selection.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct SessionTally {
    /// Samples played.
    pub ticks: u64,
    /// Breaths in the script long enough to be bursts (`min_burst_ms`).
    pub scripted: u64,
    /// Breaths in the script shorter than `min_burst_ms`: no burst may
    /// come of them.
    pub too_short: u64,
    /// Breaths in the script longer than `max_hold_ms`: no burst may come
    /// of them; each begun while detecting should be one stuck fault.
    pub too_long: u64,
    /// Scripted breaths seen as exactly one burst of the right action
    /// (breath and length class): what the matcher needs.
    pub correct: u64,
    /// Scripted breaths no burst overlapped.
    pub missed: u64,
    /// Scripted breaths cut into several bursts (or merged with another
    /// breath into one).
    pub split_or_merged: u64,
    /// Scripted breaths seen as one burst of the other breath (sip for puff).
    pub wrong_breath: u64,
    /// Scripted breaths seen in the wrong length class (short for long).
    pub wrong_class: u64,
    /// Scripted breaths seen as one burst but measured further than the
    /// tolerance from their scripted length (counted whatever the action).
    pub mistimed: u64,
    /// Bursts that overlap no scripted burst (a burst made of a breath
    /// shorter than `min_burst_ms` counts here).
    pub invented: u64,
    /// Largest |measured − scripted| length among breaths seen as one burst, ms.
    pub max_timing_error_ms: u64,
    /// Mode selections in the script.
    pub selections: u64,
    /// Of those, matched in order (longest common subsequence).
    pub selections_matched: u64,
    /// Matches the script did not ask for.
    pub selections_extra: u64,
    /// Sequences reset (timeout or no library entry).
    pub resets: u64,
    /// Sensor faults raised.
    pub faults: u64,
    /// Of those, breaths held too long (stuck sensor).
    pub stuck_faults: u64,
    /// Recoveries from a fault.
    pub recoveries: u64,
    /// Stuck levels taken as the new neutral.
    pub rezeroes: u64,
    /// Heap allocations inside `Pipeline::step` (see [`Observed`]).
    pub core_allocations: u64,
}

impl SessionTally {
    /// Correct breaths, percent of those scripted (100 for none).
    pub fn accuracy_pct(&self) -> f64 {
        percent(self.correct, self.scripted)
    }

    /// Selections matched, percent of those scripted (100 for none).
    pub fn selection_pct(&self) -> f64 {
        percent(self.selections_matched, self.selections)
    }

    /// Every breath the right action and on time, nothing invented, every
    /// selection matched and none extra.
    pub fn is_perfect(&self) -> bool {
        self.correct == self.scripted
            && self.mistimed == 0
            && self.invented == 0
            && self.core_allocations == 0
            && self.selections_matched == self.selections
            && self.selections_extra == 0
    }
}

fn percent(part: u64, whole: u64) -> f64 {
    if whole == 0 {
        100.0
    } else {
        100.0 * part as f64 / whole as f64
    }
}

/// What the core made of a session, for scoring.
#[derive(Debug, Clone, Default)]
pub struct Observed {
    /// Samples played.
    pub ticks: u64,
    /// Where the script placed each breath.
    pub scripted: Vec<ScriptedBreath>,
    /// Bursts the detector emitted.
    pub bursts: Vec<Burst>,
    /// Modes matched, in order.
    pub matched: Vec<Mode>,
    /// Sequence resets.
    pub resets: u64,
    /// Faults raised.
    pub faults: u64,
    /// Of those, stuck faults.
    pub stuck_faults: u64,
    /// Recoveries.
    pub recoveries: u64,
    /// Re-zeroes.
    pub rezeroes: u64,
    /// Heap allocations inside `Pipeline::step`, as counted by
    /// [`crate::rt::alloc_counter`] (0 unless the counting allocator is the
    /// global allocator).
    pub core_allocations: u64,
}

/// Plays `script` through a fresh core, one sample per tick, and records
/// what the script placed and what the core saw.
pub fn observe(config: &Config, params: SignalParams, script: &[Step]) -> Observed {
    let mut core = Pipeline::new(config.core());
    let mut out = TickOutput::default();
    let mut signal = SignalGenerator::new(params, script);
    let mut seen = Observed::default();
    let mut tick = 0;
    while let Some(volts) = signal.next() {
        if let Some(b) = signal.scripted_breath()
            && seen.scripted.last() != Some(&b)
        {
            seen.scripted.push(b);
        }
        let before = alloc_counter::thread_allocations();
        core.step(&TickInput::volts(tick, volts), &mut out);
        seen.core_allocations += alloc_counter::thread_allocations() - before;
        for event in out.events.iter() {
            match *event {
                Event::Burst(b) => seen.bursts.push(b),
                Event::Match { target, .. } => {
                    if let Some(mode) = target.mode() {
                        seen.matched.push(mode);
                    }
                }
                Event::Reset { .. } => seen.resets += 1,
                Event::Fault { reason } => {
                    seen.faults += 1;
                    seen.stuck_faults += u64::from(matches!(reason, FaultReason::Stuck { .. }));
                }
                Event::Recovered => seen.recoveries += 1,
                Event::Rezeroed { .. } => seen.rezeroes += 1,
                Event::Detection { .. }
                | Event::Gesture { .. }
                | Event::GestureRejected { .. }
                | Event::Highlight { .. }
                | Event::Motion(_)
                | Event::ArmFault { .. } => {}
            }
        }
        tick += 1;
    }
    seen.ticks = tick;
    seen
}

/// Scores what the core saw against the script. A burst and a scripted
/// breath belong together when their spans overlap; `tolerance_ms` is how
/// far a measured length may be from the scripted one, so a breath
/// scripted within it of `long_burst_ms` may land in either class. A
/// breath scripted longer than `max_hold_ms` is a stuck-sensor fault, not
/// a burst: like one too short, it must make none.
pub fn score(config: &Config, seen: &Observed, modes: &[Mode], tolerance_ms: u64) -> SessionTally {
    let long = u64::from(config.core().detector().long_burst_ms);
    let min = u64::from(config.core().detector().min_burst_ms);
    let max = u64::from(config.core().detector().max_hold_ms);
    let counts = |ms: u32| (min..=max).contains(&u64::from(ms));
    let span = |b: &ScriptedBreath| (b.start, b.start + u64::from(b.ms));
    let overlaps = |(s0, e0): (u64, u64), (s1, e1): (u64, u64)| s0 < e1 && s1 < e0;

    // For each scripted breath, the bursts overlapping it; for each burst,
    // how many scripted breaths it overlaps. Both lists are in time order.
    let mut per_breath = vec![Vec::new(); seen.scripted.len()];
    let mut per_burst = vec![0u32; seen.bursts.len()];
    let mut first = 0;
    for (j, burst) in seen.bursts.iter().enumerate() {
        let b = (burst.start, burst.end);
        while first < seen.scripted.len() && span(&seen.scripted[first]).1 <= b.0 {
            first += 1;
        }
        for (i, s) in seen.scripted.iter().enumerate().skip(first) {
            if span(s).0 >= b.1 {
                break;
            }
            if overlaps(span(s), b) {
                per_breath[i].push(j);
                per_burst[j] += 1;
            }
        }
    }

    // A burst overlapping only breaths too short or too long to count is
    // invented.
    let real_breaths = |j: usize| {
        per_breath
            .iter()
            .zip(&seen.scripted)
            .filter(|(bursts, s)| counts(s.ms) && bursts.contains(&j))
            .count()
    };
    let too_short = seen
        .scripted
        .iter()
        .filter(|s| u64::from(s.ms) < min)
        .count() as u64;
    let too_long = seen
        .scripted
        .iter()
        .filter(|s| u64::from(s.ms) > max)
        .count() as u64;
    let mut t = SessionTally {
        ticks: seen.ticks,
        scripted: seen.scripted.len() as u64 - too_short - too_long,
        too_short,
        too_long,
        invented: (0..seen.bursts.len())
            .filter(|&j| per_burst[j] == 0 || real_breaths(j) == 0)
            .count() as u64,
        resets: seen.resets,
        faults: seen.faults,
        stuck_faults: seen.stuck_faults,
        recoveries: seen.recoveries,
        rezeroes: seen.rezeroes,
        core_allocations: seen.core_allocations,
        ..SessionTally::default()
    };
    for (s, bursts) in seen.scripted.iter().zip(&per_breath) {
        if !counts(s.ms) {
            // No burst may come of it: one that did is counted as invented.
            continue;
        }
        let &[j] = bursts.as_slice() else {
            if bursts.is_empty() {
                t.missed += 1;
            } else {
                t.split_or_merged += 1;
            }
            continue;
        };
        if per_burst[j] > 1 {
            t.split_or_merged += 1;
            continue;
        }
        let burst = &seen.bursts[j];
        let ms = u64::from(s.ms);
        let error = burst.duration_ms().abs_diff(ms);
        t.max_timing_error_ms = t.max_timing_error_ms.max(error);
        let right_breath = burst.action.breath() == s.breath;
        // Measured within `tolerance_ms`, a breath scripted in
        // [long − tolerance, long + tolerance) may land either side.
        let either = ms + tolerance_ms >= long && ms < long + tolerance_ms;
        let right_class = burst.action.is_long() == (ms >= long) || either;
        let on_time = error <= tolerance_ms;
        t.wrong_breath += u64::from(!right_breath);
        t.wrong_class += u64::from(right_breath && !right_class);
        t.mistimed += u64::from(!on_time);
        t.correct += u64::from(right_breath && right_class);
    }

    let common = longest_common_subsequence(modes, &seen.matched);
    t.selections = modes.len() as u64;
    t.selections_matched = common;
    t.selections_extra = seen.matched.len() as u64 - common;
    t
}

/// Length of the longest common subsequence: selections matched in order,
/// so one missed selection costs one, not the rest of the session.
fn longest_common_subsequence(a: &[Mode], b: &[Mode]) -> u64 {
    let mut row = vec![0u64; b.len() + 1];
    for x in a {
        let mut diagonal = 0;
        for (j, y) in b.iter().enumerate() {
            let above = row[j + 1];
            row[j + 1] = if x == y {
                diagonal + 1
            } else {
                above.max(row[j])
            };
            diagonal = above;
        }
    }
    row[b.len()]
}

/// One cell of the accuracy grid; `--json` prints each cell's levels and
/// every field of its tally.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct GridCell {
    /// Gaussian noise, σ in volts.
    pub noise_volts: f64,
    /// 50 Hz hum amplitude, volts.
    pub hum_volts: f64,
    /// The session's score.
    #[serde(flatten)]
    pub tally: SessionTally,
}

/// The settings of `sipnpuff bench accuracy` besides the grid.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct GridOptions {
    /// Length of each cell's session, s.
    pub seconds: u64,
    /// Seed of the scripted user and the sensor.
    pub seed: u64,
    /// Neutral drift amplitude, volts.
    pub drift_volts: f64,
    /// Period of the drift, ms.
    pub drift_period_ms: f64,
    /// A rail spike every this many ms (0: none).
    pub spike_every_ms: u64,
    /// Timing tolerance, ms.
    pub tolerance_ms: u64,
}

/// A random scripted user (the same script in every cell) at each noise
/// and hum level.
pub fn accuracy_grid(
    config: &Config,
    noise_levels: &[f64],
    hum_levels: &[f64],
    options: GridOptions,
    mut progress: impl FnMut(usize, usize),
) -> Vec<GridCell> {
    let (script, modes) = random_session(config, options.seconds, options.seed);
    let total = noise_levels.len() * hum_levels.len();
    let mut cells = Vec::with_capacity(total);
    for &noise_volts in noise_levels {
        for &hum_volts in hum_levels {
            let params = SignalParams {
                drift_period_ms: options.drift_period_ms,
                ..SignalParams::clean(config.core().detector(), options.seed)
                    .with_noise(noise_volts)
                    .with_hum(hum_volts)
                    .with_drift(options.drift_volts)
                    .with_spikes_every(options.spike_every_ms)
            };
            let seen = observe(config, params, &script);
            cells.push(GridCell {
                noise_volts,
                hum_volts,
                tally: score(config, &seen, &modes, options.tolerance_ms),
            });
            progress(cells.len(), total);
        }
    }
    cells
}

/// `bench accuracy --json`: the settings and every cell.
#[derive(Debug, Clone, Serialize)]
pub struct GridReport {
    /// The settings besides the levels.
    pub options: GridOptions,
    /// One per noise and hum level, noise major.
    pub cells: Vec<GridCell>,
}

/// The grid as a Markdown table: rows noise, columns hum; each cell the
/// breaths detected as the right action, the selections matched, and the
/// largest timing error.
pub fn grid_table(cells: &[GridCell]) -> String {
    let mut hums: Vec<f64> = Vec::new();
    for c in cells {
        if !hums.contains(&c.hum_volts) {
            hums.push(c.hum_volts);
        }
    }
    let mut out = String::from("| noise σ (V) |");
    for h in &hums {
        out += &format!(" hum {h:.2} V |");
    }
    out += "\n|---|";
    out += &"---|".repeat(hums.len());
    for row in cells.chunks(hums.len().max(1)) {
        out += &format!("\n| {:.2} |", row[0].noise_volts);
        for c in row {
            let t = &c.tally;
            out += &format!(
                " {:.1} % ({:.0} %) ±{} ms",
                t.accuracy_pct(),
                t.selection_pct(),
                t.max_timing_error_ms
            );
            if t.invented > 0 {
                out += &format!(" +{}", t.invented);
            }
            out += " |";
        }
    }
    out.push('\n');
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::action::{Action, Breath};

    fn burst(action: Action, start: u64, end: u64) -> Burst {
        Burst { action, start, end }
    }

    fn scripted(breath: Breath, start: u64, ms: u32) -> ScriptedBreath {
        ScriptedBreath { breath, start, ms }
    }

    #[test]
    fn scores_each_kind_of_mistake() {
        let config = Config::default();
        let seen = Observed {
            ticks: 10_000,
            scripted: vec![
                scripted(Breath::Puff, 100, 150),  // right
                scripted(Breath::Sip, 1000, 800),  // seen as a short sip
                scripted(Breath::Puff, 2000, 150), // missed
                scripted(Breath::Puff, 3000, 800), // split in two
                scripted(Breath::Sip, 5000, 150),  // seen as a puff
                scripted(Breath::Puff, 6000, 150), // 9 ms long
                scripted(Breath::Puff, 7000, 30),  // too short, ignored: right
                scripted(Breath::Puff, 7500, 30),  // too short, yet a burst
            ],
            bursts: vec![
                burst(Action::ShortPuff, 100, 250),
                burst(Action::ShortSip, 1000, 1450),
                burst(Action::ShortPuff, 3000, 3300),
                burst(Action::ShortPuff, 3310, 3800),
                burst(Action::ShortPuff, 5000, 5150),
                burst(Action::ShortPuff, 6000, 6159),
                burst(Action::ShortPuff, 7500, 7545), // invented
                burst(Action::LongPuff, 8000, 8600),  // invented
            ],
            matched: vec![Mode::TranslateX, Mode::Fingers, Mode::Fingers],
            resets: 1,
            ..Observed::default()
        };
        let t = score(
            &config,
            &seen,
            &[Mode::TranslateX, Mode::RotateZ, Mode::Fingers],
            5,
        );
        assert_eq!(t.scripted, 6);
        assert_eq!(t.correct, 2); // the 9 ms long one is still a short puff
        assert_eq!(t.wrong_class, 1);
        assert_eq!(t.missed, 1);
        assert_eq!(t.split_or_merged, 1);
        assert_eq!(t.wrong_breath, 1);
        assert_eq!(t.mistimed, 2); // the short sip (350 ms off) and the 9 ms
        assert_eq!(t.max_timing_error_ms, 350);
        assert_eq!(t.too_short, 2);
        assert_eq!(t.invented, 2);
        assert_eq!((t.selections, t.selections_matched), (3, 2));
        assert_eq!(t.selections_extra, 1);
        assert!(!t.is_perfect());
        assert!((t.accuracy_pct() - 200.0 / 6.0).abs() < 1e-9);
    }

    #[test]
    fn the_boundary_band_is_the_tolerance_around_long_burst_ms() {
        // 500 ms is the default long boundary; a 500 ms breath measured
        // short is wrong with no tolerance and may be either with 5 ms, as
        // may a 495 ms one measured long; 505 ms is outside the band.
        let config = Config::default();
        let judge = |ms: u32, measured: Action, tolerance: u64| {
            let seen = Observed {
                scripted: vec![scripted(Breath::Puff, 1000, ms)],
                bursts: vec![burst(measured, 1000, 1000 + u64::from(ms))],
                ..Observed::default()
            };
            score(&config, &seen, &[], tolerance).wrong_class
        };
        assert_eq!(judge(500, Action::ShortPuff, 0), 1);
        assert_eq!(judge(500, Action::LongPuff, 0), 0);
        assert_eq!(judge(500, Action::ShortPuff, 5), 0);
        assert_eq!(judge(495, Action::LongPuff, 5), 0);
        assert_eq!(judge(494, Action::LongPuff, 5), 1);
        assert_eq!(judge(505, Action::ShortPuff, 5), 1);
    }

    #[test]
    fn a_clean_session_is_perfect() {
        let config = Config::default();
        let (script, modes) = random_session(&config, 120, 3);
        let params = SignalParams::clean(config.core().detector(), 3);
        let seen = observe(&config, params, &script);
        let t = score(&config, &seen, &modes, 0);
        assert!(t.is_perfect(), "{t:?}");
        assert_eq!(t.max_timing_error_ms, 0);
        assert!(t.scripted >= 40 && t.selections >= 10, "{t:?}");
    }

    #[test]
    fn heavy_hum_is_scored_not_hidden() {
        // 0.6 V of hum crosses the 0.5 V thresholds every cycle: the score
        // must show it.
        let config = Config::default();
        let (script, modes) = random_session(&config, 60, 4);
        let params = SignalParams::clean(config.core().detector(), 4).with_hum(0.6);
        let t = score(&config, &observe(&config, params, &script), &modes, 5);
        assert!(!t.is_perfect(), "{t:?}");
    }
}
