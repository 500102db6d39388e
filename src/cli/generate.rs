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
/// `--session use` and `ordinary`: minutes unless told.
const DEFAULT_MINUTES: u32 = 10;
/// `--session practice`: examples of each gesture unless told.
const DEFAULT_PER_GESTURE: u32 = 10;
/// `--session drive`: the head's pitch after each gesture unless told,
/// degrees (past the default dead zone of 12°, short of full scale at 30°).
const DEFAULT_TILT_DEG: i32 = 24;
/// `--session drive`: how long each tilt is held unless told, ms.
const DEFAULT_HOLD_MS: u32 = 3000;
/// The longest a practice gesture can take, s: the gesture (under 6 s),
/// its rests (at most 3 s each) and a stretch of ordinary movement (at
/// most 15 s).
const PRACTICE_MOST_S: u64 = 30;

/// What a simulated IMU user does (`--session`).
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum ImuSessionArg {
    /// The recording protocol: rest ≥ 3 s, 5 examples of each gesture
    /// (1.5–3 s apart, ≥ 3 s between gestures), then 60 s of ordinary
    /// movement.
    Protocol,
    /// Practice: each gesture `--per-gesture` times in a shuffled order,
    /// 1.5–3 s of rest before and after each, now and then 5–15 s of
    /// ordinary movement between two.
    Practice,
    /// `--minutes` of ordinary use: gestures now and then among long
    /// stretches of ordinary movement.
    Use,
    /// `--minutes` of ordinary movement alone.
    Ordinary,
    /// Driving the arm: each gesture (selecting its mode), then the head
    /// pitched `--tilt-deg` and held `--hold-ms`, and back to rest.
    Drive,
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
    /// With `--imu-user` (not `--session ordinary`): the gestures, in
    /// order, comma-separated, from nod, double_nod, shake, tilt_left,
    /// tilt_right, wobble, look_up, look_down, turn_left, turn_right
    /// [default: the first six, those ordinary movement does not
    /// imitate].
    #[arg(long, value_name = "LIST", value_parser = parse_gestures, requires = "imu_user")]
    gestures: Option<Gestures>,
    /// With `--session use` or `ordinary`: its length, in minutes (at
    /// most a day, and at most 8 640 000 samples: a day at 100 Hz)
    /// [default: 10].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1440), requires = "imu_user")]
    minutes: Option<u32>,
    /// With `--session practice`: examples of each gesture [default: 10].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1000), requires = "imu_user")]
    per_gesture: Option<u32>,
    /// With `--session drive`: how far the head pitches after each gesture,
    /// degrees (positive: chin down) [default: 24].
    #[arg(long, allow_hyphen_values = true, value_parser = clap::value_parser!(i32).range(-45..=45), requires = "imu_user")]
    tilt_deg: Option<i32>,
    /// With `--session drive`: how long each tilt is held, ms [default:
    /// 3000].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=60_000), requires = "imu_user")]
    hold_ms: Option<u32>,
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

/// The IMU session `args` ask for; an option that does not apply to it,
/// or a session too long to hold, is refused (exit status 2).
fn imu_session(args: &GenerateArgs) -> anyhow::Result<ImuSessionKind> {
    let refuse = |message: String| crate::cli::output::invalid(Err(anyhow::anyhow!(message)));
    let session = args.session;
    if args.minutes.is_some() && !matches!(session, ImuSessionArg::Use | ImuSessionArg::Ordinary) {
        return refuse(format!(
            "--minutes is for --session use or ordinary: a {} session's length is set by its \
             gestures",
            session.name()
        ));
    }
    if args.gestures.is_some() && session == ImuSessionArg::Ordinary {
        return refuse(
            "--gestures is not for --session ordinary: ordinary movement makes no gesture".into(),
        );
    }
    if args.per_gesture.is_some() && session != ImuSessionArg::Practice {
        return refuse(format!(
            "--per-gesture is for --session practice, not {}",
            session.name()
        ));
    }
    if (args.tilt_deg.is_some() || args.hold_ms.is_some()) && session != ImuSessionArg::Drive {
        return refuse(format!(
            "--tilt-deg and --hold-ms are for --session drive, not {}",
            session.name()
        ));
    }
    let rate = u64::from(args.rate_hz);
    let minutes = args.minutes.unwrap_or(DEFAULT_MINUTES);
    let per_gesture = args.per_gesture.unwrap_or(DEFAULT_PER_GESTURE);
    let held = "(the session is held in memory)";
    let (kind, samples, asked) = match session {
        ImuSessionArg::Protocol => return Ok(ImuSessionKind::Protocol),
        ImuSessionArg::Drive => {
            return Ok(ImuSessionKind::Drive {
                tilt_deg: args.tilt_deg.unwrap_or(DEFAULT_TILT_DEG),
                hold_ms: args.hold_ms.unwrap_or(DEFAULT_HOLD_MS),
            });
        }
        ImuSessionArg::Practice => {
            let gestures = args
                .gestures
                .as_ref()
                .map_or(GestureName::DEFAULT.len(), |g| g.0.len());
            let samples = u64::from(per_gesture) * gestures as u64 * PRACTICE_MOST_S * rate;
            let asked = format!(
                "--per-gesture {per_gesture} of {gestures} gestures at --rate-hz {rate} is up to \
                 {samples} samples"
            );
            (ImuSessionKind::Practice { per_gesture }, samples, asked)
        }
        ImuSessionArg::Use | ImuSessionArg::Ordinary => {
            let samples = u64::from(minutes) * 60 * rate;
            let asked = format!("--minutes {minutes} at --rate-hz {rate} is {samples} samples");
            let kind = if session == ImuSessionArg::Use {
                ImuSessionKind::Use { minutes }
            } else {
                ImuSessionKind::Ordinary { minutes }
            };
            (kind, samples, asked)
        }
    };
    if samples > MAX_IMU_SAMPLES {
        return refuse(format!("{asked}: at most {MAX_IMU_SAMPLES} {held}"));
    }
    Ok(kind)
}

impl ImuSessionArg {
    /// Its name on the command line.
    fn name(self) -> &'static str {
        match self {
            ImuSessionArg::Protocol => "protocol",
            ImuSessionArg::Practice => "practice",
            ImuSessionArg::Use => "use",
            ImuSessionArg::Ordinary => "ordinary",
            ImuSessionArg::Drive => "drive",
        }
    }
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
    if let Some(ImuUserName(name)) = args.imu_user {
        let user = ImuUser::builtin(name).map_err(anyhow::Error::msg)?;
        let session = imu_session(&args)?;
        let config = args.config.load()?;
        let who = Who::ImuUser {
            user: user.at_rate(args.rate_hz),
            session,
            gestures: args.gestures.map_or(GestureName::DEFAULT.to_vec(), |g| g.0),
            truth: args.truth,
        };
        return generate::generate(&config, &who, args.seed, &args.out, &|line| note!("{line}"));
    }
    let config = args.config.load()?;
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
