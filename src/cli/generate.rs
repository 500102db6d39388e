//! `sipnpuff generate`: a synthetic recording of a scripted user, or of a
//! simulated person with known breathing (a breather) in ordinary use or
//! following the calibration protocol, with the truth beside it
//! ([`crate::tools::generate`]); or a simulated person wearing a head
//! IMU, as the IMU CSV.

use std::path::PathBuf;

use crate::cli::args::{ConfigArg, parse_volts};
use crate::fit::protocol::{DEFAULT_COUNT, DEFAULT_HOLDS, Protocol};
use crate::sim::breather::Breather;
use crate::sim::head_gesture::GestureName;
use crate::sim::imu_user::ImuUser;
use crate::tools::generate::{self, BreatherSession, Disturbances, ImuSessionKind, Script, Who};

/// The most samples an IMU session may have (a day at 100 Hz, ~0.5 GB
/// in memory).
const MAX_IMU_SAMPLES: u64 = 8_640_000;

/// What a simulated IMU user does (`--session`).
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum ImuSessionArg {
    /// The recording protocol: rest ≥ 3 s, 5 examples of each gesture
    /// (1.5–3 s apart, ≥ 3 s between gestures), then 60 s of ordinary
    /// movement.
    Protocol,
    /// `--minutes` of ordinary use: gestures now and then among long
    /// stretches of ordinary movement.
    Use,
    /// `--minutes` of ordinary movement alone.
    Ordinary,
}

/// `generate`'s options.
#[derive(clap::Args, Debug)]
#[group(id = "person", args = ["breather", "imu_user"], multiple = false)]
pub struct GenerateArgs {
    /// Output CSV file.
    #[arg(long)]
    out: PathBuf,
    /// TOML configuration (its thresholds shape the breaths and its
    /// library feeds the random user).
    #[command(flatten)]
    config: ConfigArg,
    /// Length of a random session, in seconds (exact; at most a week).
    #[arg(long, default_value_t = 60, value_parser = clap::value_parser!(u64).range(1..=604_800))]
    seconds: u64,
    /// Instead of a random session, the demo user: every kind of mode,
    /// save and go to a point, a finger end stop, the reach limit.
    #[arg(long, conflicts_with = "sequences")]
    demo: bool,
    /// Instead of a random session, every entry of the configured
    /// library in turn, used: each mode held a puff and a sip, each key,
    /// click and home event fired, a drag around a pointer move (e.g.
    /// with `--config fixtures/computer-and-home.toml`, to drive
    /// `run --output`).
    #[arg(long, conflicts_with_all = ["sequences", "demo"])]
    each_entry: bool,
    /// Instead of a random session, enter these sequences in order, e.g.
    /// `--sequences "1,2,-1 1,2 2,1"` (codes: 1 short sip, 2 long sip,
    /// -1 short puff, -2 long puff).
    #[arg(long, allow_hyphen_values = true)]
    sequences: Option<String>,
    /// Instead of the configured user, a simulated person with known
    /// breathing: typical, weak, short_capacity, slow, tremulous or
    /// asymmetric; or one whose rest is not clean noise: tremor_4hz,
    /// tremor_6hz, tremor_9hz (a tremor at rest and on every breath),
    /// hum_50hz, hum_60hz (mains hum), adc_8bit, adc_10bit (a coarse
    /// converter), wandering (a rest level that wanders ±0.1 V) or spiky
    /// (isolated spikes). Without `--protocol`, `--seconds` of random
    /// sequences from the configured library. Their own rest level, noise,
    /// drift and true crossings shape the signal, not the configuration's.
    #[arg(
        long,
        value_name = "NAME",
        value_parser = parse_breather,
        conflicts_with_all = ["demo", "sequences", "noise_volts", "hum_volts", "drift_volts", "spike_every_ms"]
    )]
    breather: Option<Breather>,
    /// With `--breather`: the calibration session instead (rest, then
    /// blocks of short puffs, long puffs, short sips and long sips).
    #[arg(long, requires = "breather", conflicts_with = "seconds")]
    protocol: bool,
    /// With `--protocol`: breaths per block.
    #[arg(long, default_value_t = DEFAULT_COUNT, requires = "protocol", value_parser = clap::value_parser!(u32).range(1..=1000))]
    count: u32,
    /// With `--protocol`: then 3 longest comfortable puffs and 3 sips.
    #[arg(long, requires = "protocol")]
    holds: bool,
    /// With `--breather`: also write the truth as JSON (the breather's
    /// parameters, the true crossings, and each breath's kind, first tick
    /// and length in ms).
    #[arg(long, value_name = "FILE.json", requires = "person")]
    truth: Option<PathBuf>,
    /// Instead of a breath signal, a simulated person wearing a head IMU,
    /// written as the IMU CSV (`tick,ax,ay,az,gx,gy,gz`: m/s² with
    /// gravity, rad/s): typical, slow_small, fast_large, tremor,
    /// wheelchair or drifting. With `--truth`, the user's parameters and
    /// each gesture's and ordinary stretch's ticks.
    #[arg(
        long,
        value_name = "NAME",
        value_parser = parse_imu_user,
        conflicts_with_all = ["demo", "sequences", "each_entry", "protocol", "noise_volts", "hum_volts", "drift_volts", "spike_every_ms"]
    )]
    imu_user: Option<ImuUserName>,
    /// With `--imu-user`: what they do.
    #[arg(long, value_enum, default_value_t = ImuSessionArg::Protocol, requires = "imu_user")]
    session: ImuSessionArg,
    /// With `--imu-user`: the gestures, in order, comma-separated, from
    /// nod, double_nod, shake, tilt_left, tilt_right, wobble, look_up,
    /// look_down, turn_left, turn_right (by default the first six: those
    /// ordinary movement does not imitate).
    #[arg(
        long,
        value_name = "LIST",
        default_value = "nod,double_nod,shake,tilt_left,tilt_right,wobble",
        value_parser = parse_gestures,
        requires = "imu_user"
    )]
    gestures: Gestures,
    /// With `--session use` or `ordinary`: its length, in minutes (at
    /// most a day, and at most 8 640 000 samples: a day at 100 Hz).
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..=1440), requires = "imu_user")]
    minutes: u32,
    /// With `--imu-user`: samples per second (ticks are whole ms, rounded).
    #[arg(long, default_value_t = ImuUser::DEFAULT_RATE_HZ, value_parser = clap::value_parser!(u32).range(1..=1000), requires = "imu_user")]
    rate_hz: u32,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Gaussian noise, standard deviation in volts.
    #[arg(long, default_value_t = 0.0, value_parser = parse_volts)]
    noise_volts: f64,
    /// 50 Hz hum amplitude in volts.
    #[arg(long, default_value_t = 0.0, value_parser = parse_volts)]
    hum_volts: f64,
    /// Neutral drift amplitude in volts (one-minute period).
    #[arg(long, default_value_t = 0.0, value_parser = parse_volts)]
    drift_volts: f64,
    /// A one-sample spike to a rail every this many ms (0 = none).
    #[arg(long, default_value_t = 0)]
    spike_every_ms: u64,
}

/// `--imu-user`: a built-in IMU user's name (the user itself is large to
/// keep in the arguments).
#[derive(Clone, Debug)]
struct ImuUserName(&'static str);

fn parse_imu_user(name: &str) -> Result<ImuUserName, String> {
    ImuUser::builtin(name).map(|user| ImuUserName(user.name))
}

/// `--gestures`: a list of gesture names.
#[derive(Clone, Debug)]
struct Gestures(Vec<GestureName>);

fn parse_gestures(text: &str) -> Result<Gestures, String> {
    GestureName::parse_list(text).map(Gestures)
}

/// A built-in breather's name; the error lists them all.
fn parse_breather(name: &str) -> Result<Breather, String> {
    Breather::named(name).ok_or_else(|| {
        let names: Vec<&str> = Breather::all().iter().map(|b| b.name).collect();
        format!("no breather {name:?}: one of {}", names.join(", "))
    })
}

/// Writes the recording.
pub fn generate(args: GenerateArgs) -> anyhow::Result<()> {
    let config = args.config.load()?;
    if let Some(ImuUserName(name)) = args.imu_user {
        let user = ImuUser::builtin(name).map_err(anyhow::Error::msg)?;
        let samples = u64::from(args.minutes) * 60 * u64::from(args.rate_hz);
        if args.session != ImuSessionArg::Protocol && samples > MAX_IMU_SAMPLES {
            return crate::cli::output::invalid(Err(anyhow::anyhow!(
                "--minutes {} at --rate-hz {} is {samples} samples: at most {MAX_IMU_SAMPLES} \
                 (the session is held in memory)",
                args.minutes,
                args.rate_hz
            )));
        }
        let who = Who::ImuUser {
            user: user.at_rate(args.rate_hz),
            session: match args.session {
                ImuSessionArg::Protocol => ImuSessionKind::Protocol,
                ImuSessionArg::Use => ImuSessionKind::Use {
                    minutes: args.minutes,
                },
                ImuSessionArg::Ordinary => ImuSessionKind::Ordinary {
                    minutes: args.minutes,
                },
            },
            gestures: args.gestures.0,
            truth: args.truth,
        };
        return generate::generate(&config, &who, args.seed, &args.out, &|line| note!("{line}"));
    }
    let who = match args.breather {
        Some(breather) => Who::Breather {
            breather,
            session: if args.protocol {
                let holds = if args.holds { DEFAULT_HOLDS } else { 0 };
                BreatherSession::Protocol(Protocol::new(args.count, holds))
            } else {
                BreatherSession::Practice {
                    seconds: args.seconds,
                }
            },
            truth: args.truth,
        },
        None => Who::Scripted {
            script: match args.sequences {
                None if args.demo => Script::Demo,
                None if args.each_entry => Script::EachEntry,
                Some(text) => Script::Sequences(text),
                None => Script::Random {
                    seconds: args.seconds,
                },
            },
            disturbances: Disturbances {
                noise_volts: args.noise_volts,
                hum_volts: args.hum_volts,
                drift_volts: args.drift_volts,
                spike_every_ms: args.spike_every_ms,
            },
        },
    };
    generate::generate(&config, &who, args.seed, &args.out, &|line| note!("{line}"))
}
