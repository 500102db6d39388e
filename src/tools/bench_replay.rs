//! `sipnpuff bench replay DIR`: how fast a recorded session replays, read
//! against its floor: the core stepped through the recording's inputs and
//! nothing else. Each tick needs the last one's state, so no replay of the
//! recording, however it does its other work (checking, decoding,
//! comparing, the simulated arm), can be faster.
//!
//! Whole replays and core-alone rounds alternate in this process, after
//! one uncounted round of each, so the machine's noise falls on both
//! alike. The core-alone rounds decode a block of inputs at a time between
//! their timed stretches (memory stays bounded on a day's recording) and
//! check their events and arm commands against the recording's (or the
//! replay's counts, where the replay differs from it): a floor that did
//! other work than the replay would be no floor.

use std::path::Path;
use std::time::{Duration, Instant};

use serde::Serialize;

use crate::control::event::TimedEvent;
use crate::control::motion::stream::ArmCommand;
use crate::control::pipeline::Pipeline;
use crate::control::tick::TickOutput;
use crate::tools::recording::format::commands::CommandItem;
use crate::tools::recording::format::samples::SampleItem;
use crate::tools::recording::read::{Recording, RecordingError};
use crate::tools::recording::recording_replay::{give_to_core, replay};
use crate::tools::recording::{COMMANDS, SAMPLES};
use crate::tools::replay::ReplayError;

/// Inputs decoded between two timed stretches of the core-alone round.
const BLOCK: usize = 1 << 15;

/// What the core did: its steps, and its outputs counted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
struct CoreWork {
    ticks: u64,
    events: u64,
    arm_commands: u64,
}

/// A fingerprint of a stream of arm commands: every field's bits, in
/// order (not a cryptographic hash: it tells a different stream from the
/// recorded one, which is all it is for).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
struct Fingerprint(u64);

impl Fingerprint {
    fn add(&mut self, c: &ArmCommand) {
        let [v0, v1, v2] = c.linear;
        let [w0, w1, w2] = c.angular;
        for word in [c.seq, c.tick]
            .into_iter()
            .chain([v0, v1, v2, w0, w1, w2, c.fingers].map(f64::to_bits))
        {
            self.0 = (self.0.rotate_left(5) ^ word).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        }
    }
}

/// One run of `bench replay`: the times of every counted round.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayBench {
    /// Ticks the recording holds (the core's steps).
    pub ticks: u64,
    /// Events the replay produced.
    pub events: u64,
    /// Arm commands the replay produced.
    pub arm_commands: u64,
    /// The replay was identical to the recording, bit for bit.
    pub identical: bool,
    /// Each whole replay, s.
    pub whole_s: Vec<f64>,
    /// Each core-alone round, s.
    pub core_s: Vec<f64>,
}

/// Opens the recording in `dir` and benches its replay
/// ([`bench_replay`]); a replay that could not write names the directory.
pub fn bench_replay_dir(dir: &Path, rounds: u32) -> anyhow::Result<ReplayBench> {
    let recording = Recording::open(dir)?;
    match bench_replay(&recording, rounds) {
        Ok(bench) => Ok(bench),
        Err(ReplayError::Write(e)) => Err(anyhow::Error::new(e).context(dir.display().to_string())),
        Err(e) => Err(e.into()),
    }
}

/// Runs `rounds` whole replays of `recording` (compared with it, output
/// discarded) alternating with as many core-alone rounds. An error if the
/// recording is damaged, or if the core alone did other work than the
/// replay (other ticks, events or commands: then it is no floor).
pub fn bench_replay(recording: &Recording, rounds: u32) -> Result<ReplayBench, ReplayError> {
    let mut bench = ReplayBench {
        ticks: 0,
        events: 0,
        arm_commands: 0,
        identical: false,
        whole_s: Vec::new(),
        core_s: Vec::new(),
    };
    let recorded = recorded_commands(recording)?;
    let mut inputs = Vec::with_capacity(BLOCK);
    let mut events = Vec::new();
    // Round 0 warms the caches and is not counted.
    for round in 0..=rounds {
        let started = Instant::now();
        let verdict = replay(
            recording,
            &recording.config,
            true,
            &mut std::io::sink(),
            None,
        )?;
        let whole = started.elapsed();
        let (core, work, commands) = core_alone(recording, &mut inputs, &mut events)?;
        let replayed = CoreWork {
            ticks: verdict.ticks,
            events: verdict.summary.events,
            arm_commands: verdict.summary.arm_commands,
        };
        let not_the_work = if work != replayed {
            Some(format!(
                "made {} steps, {} events and {} arm commands, the replay {}, {} and {}",
                work.ticks,
                work.events,
                work.arm_commands,
                replayed.ticks,
                replayed.events,
                replayed.arm_commands
            ))
        } else if !verdict.identical() {
            None
        } else if commands != recorded {
            Some("made other arm commands than the recording's".to_string())
        } else {
            first_other_event(recording, &events)?
        };
        if let Some(what) = not_the_work {
            return Err(RecordingError {
                path: recording.dir.clone(),
                place: None,
                message: format!("the core alone {what}: it did not do the replay's work"),
            }
            .into());
        }
        (bench.ticks, bench.events, bench.arm_commands) =
            (work.ticks, work.events, work.arm_commands);
        bench.identical = verdict.identical();
        if round > 0 {
            bench.whole_s.push(whole.as_secs_f64());
            bench.core_s.push(core.as_secs_f64());
        }
    }
    Ok(bench)
}

/// The fingerprint of the recorded arm commands (lost ones skipped).
fn recorded_commands(recording: &Recording) -> Result<Fingerprint, ReplayError> {
    let mut commands = recording.commands()?;
    let mut fingerprint = Fingerprint::default();
    while let Some(item) = commands
        .next_item()
        .map_err(|e| RecordingError::format(recording.path(COMMANDS), e))?
    {
        if let CommandItem::Command(c) = item {
            fingerprint.add(&c);
        }
    }
    Ok(fingerprint)
}

/// The first of `events` that is not the recorded line of its number.
fn first_other_event(
    recording: &Recording,
    events: &[TimedEvent],
) -> Result<Option<String>, ReplayError> {
    let mut lines = recording.events()?;
    for (number, event) in (1u64..).zip(events) {
        let line = serde_json::to_string(event).map_err(std::io::Error::from)?;
        match lines.next_line()? {
            Some((_, recorded)) if recorded == line => {}
            _ => {
                return Ok(Some(format!(
                    "made event {number}, {line}, not the recorded one"
                )));
            }
        }
    }
    Ok(None)
}

/// A fresh core given exactly the replay's calls ([`give_to_core`]), the
/// inputs decoded a block at a time outside the timed stretches: the time
/// of its steps, what they produced, its events (in `events`) and the
/// fingerprint of its arm commands.
fn core_alone(
    recording: &Recording,
    inputs: &mut Vec<SampleItem>,
    events: &mut Vec<TimedEvent>,
) -> Result<(Duration, CoreWork, Fingerprint), ReplayError> {
    events.clear();
    let mut commands = Fingerprint::default();
    let mut samples = recording.samples()?;
    let mut core = Pipeline::new(recording.config.core());
    let mut output = TickOutput::default();
    let mut work = CoreWork::default();
    let mut time = Duration::ZERO;
    loop {
        inputs.clear();
        while inputs.len() < BLOCK {
            match samples
                .next_item()
                .map_err(|e| RecordingError::format(recording.path(SAMPLES), e))?
            {
                Some(item) => inputs.push(item),
                None => break,
            }
        }
        if inputs.is_empty() {
            return Ok((time, work, commands));
        }
        let started = Instant::now();
        for &item in inputs.iter() {
            let Some(tick) = give_to_core(item, &mut core, &mut output) else {
                continue;
            };
            work.ticks += 1;
            for &event in output.events.iter() {
                events.push(TimedEvent { tick, event });
            }
            work.events += output.events.len() as u64;
            if let Some(command) = &output.motion.arm_command {
                commands.add(command);
                work.arm_commands += 1;
            }
        }
        time += started.elapsed();
    }
}

/// The median and the least of some times, and the median's rate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Times {
    /// Median, ms.
    pub median_ms: f64,
    /// Least, ms.
    pub min_ms: f64,
    /// The recording's length over the median time.
    pub real_time: f64,
}

impl Times {
    fn of(seconds: &[f64], recorded_s: f64) -> Times {
        let mut sorted = seconds.to_vec();
        sorted.sort_by(f64::total_cmp);
        let median = match sorted.len() {
            0 => f64::NAN,
            n if n % 2 == 1 => sorted[n / 2],
            n => (sorted[n / 2 - 1] + sorted[n / 2]) / 2.0,
        };
        Times {
            median_ms: median * 1e3,
            min_ms: sorted.first().map_or(f64::NAN, |s| s * 1e3),
            real_time: recorded_s / median,
        }
    }
}

/// `bench replay`'s figures, as `--json` prints them.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ReplayBenchReport {
    /// Ticks replayed.
    pub ticks: u64,
    /// The recording's length: a tick a millisecond.
    pub recorded_s: f64,
    /// Events replayed.
    pub events: u64,
    /// Arm commands replayed.
    pub arm_commands: u64,
    /// The replay was identical to the recording, bit for bit.
    pub identical: bool,
    /// Rounds counted of each.
    pub rounds: usize,
    /// The whole replay (as `sipnpuff replay` runs it, without the
    /// process's start and the summary).
    pub whole_replay: Times,
    /// The core alone: the floor.
    pub core_alone: Times,
    /// The core alone's median over the whole replay's.
    pub core_share: f64,
}

impl ReplayBench {
    /// The figures.
    pub fn report(&self) -> ReplayBenchReport {
        let recorded_s = self.ticks as f64 / 1000.0;
        let whole_replay = Times::of(&self.whole_s, recorded_s);
        let core_alone = Times::of(&self.core_s, recorded_s);
        ReplayBenchReport {
            ticks: self.ticks,
            recorded_s,
            events: self.events,
            arm_commands: self.arm_commands,
            identical: self.identical,
            rounds: self.whole_s.len(),
            whole_replay,
            core_alone,
            core_share: core_alone.median_ms / whole_replay.median_ms,
        }
    }
}

impl ReplayBenchReport {
    /// A table for people.
    pub fn to_text(&self) -> String {
        let row = |name: &str, t: &Times| {
            format!(
                "{name:<62} median {:>9.3} ms  min {:>9.3} ms  {:>8.0}x real time\n",
                t.median_ms, t.min_ms, t.real_time
            )
        };
        format!(
            "{} ticks ({:.1} s), {} events, {} arm commands, {}; {} rounds of each, alternating, in one process (its start not counted):\n{}{}the core alone takes {:.0} % of the whole replay: no replay of this recording runs faster than {:.0}x real time here\n",
            self.ticks,
            self.recorded_s,
            self.events,
            self.arm_commands,
            if self.identical {
                "identical to the recording"
            } else {
                "NOT identical to the recording (see `sipnpuff replay`)"
            },
            self.rounds,
            row(
                "whole replay (check, decode, core, compare, simulated arm)",
                &self.whole_replay
            ),
            row(
                "the core alone, stepped through the same inputs (the floor)",
                &self.core_alone
            ),
            self.core_share * 100.0,
            self.core_alone.real_time
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_median_and_the_rate_are_those_of_the_times() {
        let t = Times::of(&[0.25, 0.125, 1.0], 120.0);
        assert_eq!((t.median_ms, t.min_ms), (250.0, 125.0));
        assert_eq!(t.real_time, 480.0);
        // An even count: the mean of the middle two.
        let t = Times::of(&[0.25, 0.125, 1.0, 0.5], 60.0);
        assert_eq!(t.median_ms, 375.0);
        assert_eq!(t.real_time, 160.0);
    }
}
