//! A live gesture recording (`gestures record --sensor IMU`): the IMU
//! read at 1 kHz on this thread, the guide's prompts said in the
//! terminal and on the page as they come (with the head's trace), the session written as an IMU recording (kept
//! whatever happens), and, once the guide is done, the set made from the
//! movements it labelled and checked on the session's ordinary minute.
//! `--sensor synthetic:NAME` is a simulated person who follows the
//! prompts, in real time.

use std::path::Path;
use std::time::{Duration, Instant};

use anyhow::bail;

use crate::config::Config;
use crate::control::Tick;
use crate::control::gesture::GestureConfig;
use crate::control::imu::{Channels, ImuInput};
use crate::gestures::check::{self, Ordinary};
use crate::gestures::guided::{self, Guided, Say};
use crate::gestures::record::{self, record_guided};
use crate::rt::signals;
use crate::sensor::imu_sensor::ImuSamples;
use crate::sensor::{Producer, Samples, Sensor, SensorSpec};
use crate::session::Console;
use crate::session::gestures::{RecordedSet, write_set};
use crate::session::imu::open_imu;
use crate::session::showing::{Display, DisplayChoice, Showing};
use crate::sim::guided_imu_user::GuidedImuUser;
use crate::sim::head_gesture::GestureName;
use crate::sim::imu_user::ImuUser;
use crate::tools::imu_csv::write_imu_csv;
use crate::tools::output_file::write_whole;

/// A live session's own settings.
pub struct LiveRecord<'a> {
    /// The IMU (`synthetic[:NAME]`: a simulated person).
    pub sensor: &'a SensorSpec,
    /// The gestures, in the order asked for.
    pub names: &'a [String],
    /// Where the set goes.
    pub out: &'a Path,
    /// Where the session's recording goes (never over a file).
    pub recording: &'a Path,
    /// `[sensor]` settings for the device.
    pub config: &'a Config,
    /// The page (the terminal view is not offered).
    pub display: DisplayChoice,
}

/// How long the page's last frame may take to reach the open pages.
const SUMMARY_WAIT: Duration = Duration::from_secs(3);

/// The head the session reads.
enum Head {
    /// A device or a recording played live.
    Sensor {
        samples: ImuSamples,
        producer: Producer,
    },
    /// A simulated person who hears the prompts.
    Simulated(Box<GuidedImuUser>),
}

impl Head {
    fn read(&mut self, tick: Tick, skipped: u64) -> ImuInput {
        match self {
            Head::Sensor { samples, .. } => samples.try_read(skipped).imu,
            Head::Simulated(person) => person.input(tick),
        }
    }

    fn hear(&mut self, tick: Tick, say: &Say) {
        if let Head::Simulated(person) = self {
            person.hear(tick, say);
        }
    }

    fn stop(self) -> anyhow::Result<()> {
        match self {
            Head::Sensor { producer, .. } => producer.stop().map_err(anyhow::Error::new),
            Head::Simulated(_) => Ok(()),
        }
    }
}

/// Opens the IMU for a live recording: its channels, described, started.
fn open(live: &LiveRecord) -> anyhow::Result<(Head, Channels, String)> {
    if let SensorSpec::Synthetic(name) = live.sensor {
        let user = ImuUser::builtin(name.as_deref().unwrap_or("typical"))
            .map_err(|e| anyhow::anyhow!("--sensor {}: {e}", live.sensor))?;
        let gestures = live
            .names
            .iter()
            .map(|n| GestureName::parse(n))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| {
                anyhow::anyhow!(
                    "--sensor {}: the simulated person makes only the built-in gestures: {e}",
                    live.sensor
                )
            })?;
        let person = GuidedImuUser::new(user, &gestures, 1);
        let described = format!("a simulated person ({}) following the prompts", user.name);
        return Ok((Head::Simulated(Box::new(person)), Channels::ALL, described));
    }
    let sensor = open_imu(live.sensor, live.config)?;
    let channels = sensor.channels();
    let described = sensor.describe();
    let started = sensor.start().map_err(anyhow::Error::new)?;
    Ok((
        Head::Sensor {
            samples: started.samples,
            producer: started.producer,
        },
        channels,
        described,
    ))
}

/// Runs the guided session and makes the set: the prompts to `console`
/// and the page, the recording written whatever happens. An error if the
/// session stopped before its end (the recording so far kept) or the set
/// cannot be made; the page says so too.
pub fn record_live(live: &LiveRecord, console: &dyn Console) -> anyhow::Result<RecordedSet> {
    record::check_names(live.names).map_err(|e| anyhow::anyhow!(e))?;
    if live.recording.exists() {
        bail!(
            "{} exists: give --recording FILE.csv to keep the session elsewhere (a recording is never overwritten)",
            live.recording.display()
        );
    }
    // The page's address is taken before the IMU is opened.
    let display = Display::open(&live.display, console)?;
    let (head, channels, described) = open(live)?;
    let mut showing = display.start_gestures(live.config.core(), live.names)?;
    let result = session(live, console, head, channels, &described, &mut showing);
    let (summary, written) = match &result {
        Ok(made) => (
            format!(
                "written to {}: leave-one-out {}/{} right; ordinary movement: {} activations; the session is kept in {}",
                live.out.display(),
                made.check.right,
                made.check.examples,
                made.check.activations.len(),
                live.recording.display()
            ),
            true,
        ),
        Err(e) => (format!("{e:#}"), false),
    };
    showing.conclude_gestures(summary, written, SUMMARY_WAIT);
    result
}

/// The session on the IMU opened, shown on `showing`.
fn session(
    live: &LiveRecord,
    console: &dyn Console,
    mut head: Head,
    channels: Channels,
    described: &str,
    showing: &mut Showing,
) -> anyhow::Result<RecordedSet> {
    let stop = signals::stop_request()?;
    console.note(&format!(
        "sipnpuff: recording {} gestures ({}) from {described}: {} examples of each, then a minute of ordinary movement; the session is kept in {}",
        live.names.len(),
        live.names.join(", "),
        crate::gestures::protocol::EXAMPLES,
        live.recording.display()
    ));
    let base = GestureConfig::default();
    let mut guide = Guided::new(live.names.len(), base);
    let mut last = None;
    let start = Instant::now();
    let mut tick: Tick = 0;
    while !guide.is_over() && stop.reason().is_none() {
        let due = start + Duration::from_millis(tick);
        if let Some(wait) = due.checked_duration_since(Instant::now()) {
            std::thread::sleep(wait);
        }
        let now = u64::try_from(start.elapsed().as_millis()).unwrap_or(Tick::MAX);
        let skipped = now.saturating_sub(tick);
        tick = tick.max(now);
        let input = head.read(tick, skipped);
        showing.observe_imu(tick, input);
        if let Some(say) = guide.step(tick, input) {
            let max_ms = guide.fitted().map_or(base.max_ms, |c| c.max_ms);
            console.note(&format!(
                "sipnpuff: {}",
                guided::words(&say, live.names, max_ms)
            ));
            let seen = guide.examples().iter().map(Vec::len).sum();
            showing.guide_gestures(tick, &say, seen, max_ms);
            head.hear(tick, &say);
            last = Some(say);
        }
        tick += 1;
    }
    let stopped = head.stop();
    let samples = guide.samples();
    write_whole(live.recording, |w| Ok(write_imu_csv(w, channels, samples)?))?;
    stopped?;
    match last {
        Some(Say::Done) => {}
        Some(Say::Stopped(_)) => bail!(
            "the session stopped before its end; what was recorded is kept in {}",
            live.recording.display()
        ),
        _ => bail!(
            "the session was interrupted; what was recorded is kept in {}",
            live.recording.display()
        ),
    }
    let recording = live.recording.display().to_string();
    let recorded = record_guided(
        samples,
        channels,
        live.names,
        base,
        Some(recording.clone()),
        guide.examples(),
    )
    .map_err(|e| anyhow::anyhow!("{recording}: {e}"))?;
    let ordinary = recorded.cut.ordinary;
    let from = samples.partition_point(|(t, _)| *t < ordinary.start);
    let ordinary = Ordinary {
        source: format!("{recording} (ordinary stretch)"),
        samples: samples.get(from..).unwrap_or_default(),
    };
    let check = check::check(&recorded.set, &[ordinary]);
    let made_from = format!("a guided session recorded in {recording} ({channels})");
    write_set(live.out, live.names, &recorded, &check, &made_from)?;
    Ok(RecordedSet { recorded, check })
}
