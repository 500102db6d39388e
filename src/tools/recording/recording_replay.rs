//! Replaying a recording (`replay DIR`): a fresh core is given exactly
//! the recorded calls (each tick's step at its recorded tick, with its
//! sample or none, the arm's news and the start of the safe stop), and its events
//! and arm commands are compared with the recorded ones as they come:
//! events as their JSON lines (`serde_json` writes the shortest text that
//! reads back to the same bits), arm commands field by field, bit for bit.

use std::fmt;
use std::io::Write;

use crate::arm::sim::SimulatedJaco;
use crate::config::Config;
use crate::control::Tick;
use crate::control::event::TimedEvent;
use crate::control::motion::stream::ArmCommand;
use crate::control::pipeline::Pipeline;
use crate::control::tick::{ArmPose, TickOutput};
use crate::tools::recording::format::commands::{CommandDecoder, CommandItem};
use crate::tools::recording::format::samples::SampleItem;
use crate::tools::recording::read::{EventLines, Recording, RecordingError};
use crate::tools::recording::{COMMANDS, META, SAMPLES};
use crate::tools::replay::{ReplayError, ReplaySummary};
use crate::tools::trace::{TRACE_HEADER, TraceRows};

/// The first place where the replay and the recording part.
#[derive(Debug, Clone, PartialEq)]
pub enum Difference {
    /// The `number`th event (1-based: the line of `events.jsonl`).
    Event {
        /// Its number.
        number: u64,
        /// The recorded line, if there is one.
        recorded: Option<String>,
        /// The replayed line, if there is one.
        replayed: Option<String>,
    },
    /// The `number`th arm command (1-based).
    Command {
        /// Its number.
        number: u64,
        /// The recorded command, if there is one.
        recorded: Option<ArmCommand>,
        /// The replayed command, if there is one.
        replayed: Option<ArmCommand>,
    },
}

impl fmt::Display for Difference {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let or_none = |s: &Option<String>| s.clone().unwrap_or_else(|| "none".into());
        match self {
            Difference::Event {
                number,
                recorded,
                replayed,
            } => write!(
                f,
                "event {number} (line {number} of events.jsonl): recorded {}, replayed {}",
                or_none(recorded),
                or_none(replayed)
            ),
            Difference::Command {
                number,
                recorded: Some(a),
                replayed: Some(b),
            } => write!(
                f,
                "arm command {number} (seq {}, tick {}): {}",
                a.seq,
                a.tick,
                field_difference(a, b)
            ),
            Difference::Command {
                number,
                recorded,
                replayed,
            } => write!(
                f,
                "arm command {number}: recorded {}, replayed {}",
                or_none(&recorded.map(|c| format!("seq {} at tick {}", c.seq, c.tick))),
                or_none(&replayed.map(|c| format!("seq {} at tick {}", c.seq, c.tick)))
            ),
        }
    }
}

/// The first field in which two commands differ, with both values and
/// their bits.
fn field_difference(a: &ArmCommand, b: &ArmCommand) -> String {
    if a.seq != b.seq || a.tick != b.tick {
        return format!(
            "recorded seq {} at tick {}, replayed seq {} at tick {}",
            a.seq, a.tick, b.seq, b.tick
        );
    }
    let fields = |c: &ArmCommand| {
        let [v0, v1, v2] = c.linear;
        let [w0, w1, w2] = c.angular;
        [v0, v1, v2, w0, w1, w2, c.fingers]
    };
    const NAMES: [&str; 7] = [
        "linear x",
        "linear y",
        "linear z",
        "angular x",
        "angular y",
        "angular z",
        "fingers",
    ];
    for ((name, x), y) in NAMES.iter().zip(fields(a)).zip(fields(b)) {
        if x.to_bits() != y.to_bits() {
            return format!(
                "{name}: recorded {x:?} ({:#018x}), replayed {y:?} ({:#018x})",
                x.to_bits(),
                y.to_bits()
            );
        }
    }
    "identical".into()
}

/// Whether two commands are the same, bit for bit.
fn same(a: &ArmCommand, b: &ArmCommand) -> bool {
    let bits = |c: &ArmCommand| {
        let [v0, v1, v2] = c.linear;
        let [w0, w1, w2] = c.angular;
        [v0, v1, v2, w0, w1, w2, c.fingers].map(f64::to_bits)
    };
    a.seq == b.seq && a.tick == b.tick && bits(a) == bits(b)
}

/// What a replay of a recording found.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayVerdict {
    /// Ticks replayed (the core's steps).
    pub ticks: u64,
    /// The first and last tick replayed.
    pub first_tick: Option<Tick>,
    /// The last tick replayed.
    pub last_tick: Option<Tick>,
    /// The tick on which the safe stop began.
    pub stop_tick: Option<Tick>,
    /// The replay was compared with the recording (not with
    /// another configuration).
    pub compared: bool,
    /// The recording is complete: nothing lost, every file ended.
    pub complete: bool,
    /// The recording's own account of what is missing (`meta.json`).
    pub problems: Vec<String>,
    /// An incomplete recording is compared only up to its first loss:
    /// the last tick compared.
    pub compared_through: Option<Tick>,
    /// The first difference, if any.
    pub difference: Option<Difference>,
    /// Events and arm commands replayed, and the simulated arm's end.
    pub summary: ReplaySummary,
}

impl ReplayVerdict {
    /// The replay is the recorded run, bit for bit: compared, complete,
    /// no difference.
    pub fn identical(&self) -> bool {
        self.compared && self.complete && self.difference.is_none()
    }
}

/// Compares the replay's output with the recorded streams as it comes.
struct Comparer<'a> {
    events: &'a mut EventLines,
    commands: &'a mut CommandDecoder<std::io::BufReader<std::fs::File>>,
    recording: &'a Recording,
    /// Still comparing (not after a loss, a difference or the end of an
    /// incomplete recording's stream).
    comparing: bool,
    /// The recording is complete: a stream that ends early is a
    /// difference, not the cut of a size cap.
    complete: bool,
    difference: Option<Difference>,
}

impl Comparer<'_> {
    fn differ(&mut self, difference: Difference) {
        self.difference = Some(difference);
        self.comparing = false;
    }

    fn event(&mut self, number: u64, replayed: &str) -> Result<(), ReplayError> {
        if !self.comparing {
            return Ok(());
        }
        match self.events.next_line()? {
            Some((_, recorded)) if recorded == replayed => {}
            Some((_, recorded)) => {
                let recorded = Some(recorded.to_string());
                self.differ(Difference::Event {
                    number,
                    recorded,
                    replayed: Some(replayed.into()),
                });
            }
            None if self.complete => self.differ(Difference::Event {
                number,
                recorded: None,
                replayed: Some(replayed.into()),
            }),
            None => self.comparing = false,
        }
        Ok(())
    }

    fn next_command(&mut self) -> Result<Option<CommandItem>, ReplayError> {
        self.commands
            .next_item()
            .map_err(|e| RecordingError::format(self.recording.path(COMMANDS), e).into())
    }

    fn command(&mut self, number: u64, replayed: &ArmCommand) -> Result<(), ReplayError> {
        if !self.comparing {
            return Ok(());
        }
        match self.next_command()? {
            Some(CommandItem::Command(recorded)) if same(&recorded, replayed) => {}
            Some(CommandItem::Command(recorded)) => self.differ(Difference::Command {
                number,
                recorded: Some(recorded),
                replayed: Some(*replayed),
            }),
            Some(CommandItem::Lost(_)) => self.comparing = false,
            None if self.complete => self.differ(Difference::Command {
                number,
                recorded: None,
                replayed: Some(*replayed),
            }),
            None => self.comparing = false,
        }
        Ok(())
    }

    /// At the end of a complete recording, nothing recorded may be left.
    fn finish(&mut self, events: u64, commands: u64) -> Result<(), ReplayError> {
        if !self.comparing || !self.complete {
            return Ok(());
        }
        if let Some((_, recorded)) = self.events.next_line()? {
            let recorded = Some(recorded.to_string());
            self.differ(Difference::Event {
                number: events + 1,
                recorded,
                replayed: None,
            });
        } else if let Some(item) = self.next_command()? {
            let recorded = match item {
                CommandItem::Command(c) => Some(c),
                CommandItem::Lost(_) => None,
            };
            self.differ(Difference::Command {
                number: commands + 1,
                recorded,
                replayed: None,
            });
        }
        Ok(())
    }
}

/// Gives the core the input one item of `samples.bin` holds, its output
/// into `out`; nothing for lost ticks. The tick stepped, if any. The
/// replay and `bench replay`'s core-alone rounds both give the core its
/// input through this.
pub fn give_to_core(item: SampleItem, core: &mut Pipeline, out: &mut TickOutput) -> Option<Tick> {
    match item {
        SampleItem::Input(input) => {
            core.step(&input, out);
            Some(input.tick)
        }
        SampleItem::Lost(_) => None,
    }
}

/// Replays `recording` through a fresh core built from `config` and the
/// simulated arm, writing events as JSON lines to `out` and, if given, the
/// per-tick trace. With `compare`, checks the events and arm commands
/// against the recorded ones (pass the recording's own configuration).
/// Every stream is checked to its end before the first tick.
pub fn replay(
    recording: &Recording,
    config: &Config,
    compare: bool,
    out: &mut dyn Write,
    mut trace: Option<&mut dyn Write>,
) -> Result<ReplayVerdict, ReplayError> {
    let contents = recording.check()?;
    let meta = &recording.meta;
    if meta.status == "finished" {
        let held = (contents.ticks, contents.arm_commands, contents.events);
        let said = (
            meta.summary.ticks,
            meta.summary.arm_commands,
            meta.summary.events,
        );
        if held != said {
            return Err(RecordingError {
                path: recording.path(META),
                place: None,
                message: format!(
                    "says {} ticks, {} arm commands and {} events; the streams hold {}, {} and {}",
                    said.0, said.1, said.2, held.0, held.1, held.2
                ),
            }
            .into());
        }
    }
    let complete = meta.summary.complete && meta.status == "finished" && contents.losses == 0;
    let mut problems = meta.summary.problems.clone();
    if meta.status != "finished" {
        problems.insert(
            0,
            format!("status {:?}: its run never finished", meta.status),
        );
    }

    let mut core = Pipeline::new(config.core());
    let mut arm = SimulatedJaco::new(config.core());
    let mut samples = recording.samples()?;
    let mut events = recording.events()?;
    let mut commands = recording.commands()?;
    let mut cmp = Comparer {
        events: &mut events,
        commands: &mut commands,
        recording,
        comparing: compare,
        complete,
        difference: None,
    };
    let mut v = ReplayVerdict {
        ticks: 0,
        first_tick: None,
        last_tick: None,
        stop_tick: None,
        compared: compare,
        complete,
        problems,
        compared_through: None,
        difference: None,
        summary: ReplaySummary::default(),
    };
    if let Some(trace) = trace.as_deref_mut() {
        writeln!(trace, "{TRACE_HEADER}")?;
    }
    let mut line = Vec::new();
    // One output, written in place each tick.
    let mut output = TickOutput::default();
    let mut rows = TraceRows::default();
    while let Some(item) = samples
        .next_item()
        .map_err(|e| RecordingError::format(recording.path(SAMPLES), e))?
    {
        match item {
            SampleItem::Input(input) => {
                if let Some((ArmPose::Start, pose)) = input.arm.pose {
                    // The trace's arm starts where the real one did.
                    arm.move_to(pose);
                }
                if input.stop {
                    v.stop_tick = Some(input.tick);
                }
            }
            // What follows is not the core's whole input.
            SampleItem::Lost(_) => cmp.comparing = false,
        }
        let Some(tick) = give_to_core(item, &mut core, &mut output) else {
            continue;
        };
        v.ticks += 1;
        v.first_tick.get_or_insert(tick);
        v.last_tick = Some(tick);
        for &event in output.events.iter() {
            line.clear();
            serde_json::to_writer(&mut line, &TimedEvent { tick, event })
                .map_err(std::io::Error::from)?;
            v.summary.events += 1;
            cmp.event(v.summary.events, &String::from_utf8_lossy(&line))?;
            line.push(b'\n');
            out.write_all(&line)?;
        }
        if let Some(command) = &output.motion.arm_command {
            v.summary.arm_commands += 1;
            cmp.command(v.summary.arm_commands, command)?;
        }
        if cmp.comparing {
            v.compared_through = Some(tick);
        }
        arm.tick(output.motion.arm_command.as_ref());
        if !arm.inside_workspace() {
            v.summary.ticks_outside_workspace += 1;
        }
        if let Some(trace) = trace.as_deref_mut() {
            rows.write(trace, &output, &arm)?;
        }
    }
    cmp.finish(v.summary.events, v.summary.arm_commands)?;
    v.difference = cmp.difference.take();
    out.flush()?;
    if let Some(trace) = trace {
        trace.flush()?;
    }
    v.summary.samples = v.ticks;
    v.summary.set_arm_end(&arm);
    Ok(v)
}
