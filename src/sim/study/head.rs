//! The paper's three tasks done with the head, beside the breath study:
//! each simulated IMU person records the six built-in gestures by the
//! protocol, their set is made from that recording alone, and they do
//! the tasks selecting modes with gestures and driving with head tilts,
//! in closed loop with the production core. The breath study's ASP and
//! BSP run in the same call, so the times are side by side.

use std::fmt::Write;
use std::path::PathBuf;

use serde::Serialize;

use crate::config::{Config, ConfigErrors};
use crate::control::gesture::GestureConfig;
use crate::control::gesture::name::GestureName as SetName;
use crate::control::mode::Mode;
use crate::control::selection::SequenceEntry;
use crate::control::sequence::Sequence;
use crate::control::token::Token;
use crate::gestures::record::record;
use crate::gestures::setup::setup;
use crate::sim::head_gesture::GestureName;
use crate::sim::head_user::{HeadParticipant, run_head_task};
use crate::sim::imu_session::protocol_session;
use crate::sim::imu_user::ImuUser;
use crate::sim::study::stats::{mean, sample_sd};
use crate::sim::study::tasks::TASKS;
use crate::sim::study::{StudyOptions, TaskSummary, run_study};
use crate::sim::user::{TaskRun, UserModel};

/// How the head study runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HeadStudyOptions {
    /// Seed of the recordings, the tasks and the breath study.
    pub seed: u64,
    /// Runs of each task per person.
    pub runs: u64,
}

impl Default for HeadStudyOptions {
    fn default() -> Self {
        HeadStudyOptions { seed: 1, runs: 3 }
    }
}

/// Which gesture selects which of the tasks' six modes: the simplest
/// gestures for the modes the tasks use most.
pub const HEAD_LIBRARY: [(GestureName, Mode); 6] = [
    (GestureName::Nod, Mode::TranslateX),
    (GestureName::DoubleNod, Mode::TranslateZ),
    (GestureName::Shake, Mode::TranslateY),
    (GestureName::TiltLeft, Mode::Fingers),
    (GestureName::TiltRight, Mode::RotateX),
    (GestureName::Wobble, Mode::RotateY),
];

/// One person's set and task runs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HeadPerson {
    /// The built-in IMU user's name.
    pub name: &'static str,
    /// How far they tilt their head to drive, degrees.
    pub drive_deg: f64,
    /// Their set's leave-one-out: examples read as themselves, of all.
    pub leave_one_out: (usize, usize),
    /// Per task (1–3), the runs.
    pub tasks: Vec<Vec<TaskRun>>,
}

/// One task's times: the breath study's ASP and BSP and the head's.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct HeadTaskRow {
    /// 1, 2 or 3.
    pub task: u8,
    /// The breath study's ASP, mean and SD over its participants, s.
    pub asp_mean_s: f64,
    /// See `asp_mean_s`.
    pub asp_sd_s: f64,
    /// The breath study's BSP, s.
    pub bsp_mean_s: f64,
    /// See `bsp_mean_s`.
    pub bsp_sd_s: f64,
    /// The head, mean and SD over every person's finished runs, s.
    pub head_mean_s: f64,
    /// See `head_mean_s`.
    pub head_sd_s: f64,
    /// Moving time with the head, mean over the finished runs, s.
    pub head_moving_s: f64,
    /// Head runs that did not finish within the simulation's cap (a
    /// gesture the person's set never reads).
    pub head_unfinished: usize,
    /// ASP's moving time, mean, s.
    pub asp_moving_s: f64,
}

/// The head study's outcome.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HeadStudyReport {
    /// Its seed.
    pub seed: u64,
    /// Runs of each task per person.
    pub runs: u64,
    /// Per task, the three interfaces side by side.
    pub tasks: Vec<HeadTaskRow>,
    /// Per person.
    pub people: Vec<HeadPerson>,
}

/// `user`'s configuration: their set, recorded by the protocol (seeded),
/// as the person; the defaults with [`HEAD_LIBRARY`]. With their set's
/// leave-one-out (right, of).
pub fn head_config(user: &ImuUser, seed: u64) -> Result<(Config, (usize, usize)), String> {
    let names: Vec<String> = GestureName::DEFAULT
        .iter()
        .map(|g| g.name().to_string())
        .collect();
    let protocol = protocol_session(user, &GestureName::DEFAULT, seed);
    let recorded = record(
        &protocol.samples,
        protocol.channels,
        &names,
        GestureConfig::default(),
        None,
    )?;
    let check = crate::gestures::check::check(&recorded.set, &[]);
    let loo = (
        check.gestures.iter().map(|g| g.right).sum(),
        check.gestures.iter().map(|g| g.examples).sum(),
    );
    let library = HEAD_LIBRARY
        .iter()
        .map(|(gesture, mode)| {
            let token = SetName::new(gesture.name()).map(Token::Gesture);
            let actions = token.and_then(|t| Sequence::from_slice(&[t]));
            actions
                .map(|a| SequenceEntry::mode(a, *mode))
                .ok_or_else(|| format!("{gesture}: not a gesture name"))
        })
        .collect::<Result<Vec<_>, String>>()?;
    let label = PathBuf::from(format!("{}'s gestures (recorded in the study)", user.name));
    let config = Config::default()
        .with_gesture_set(label)
        .and_then(|c| c.with_sequences(library))
        .map_err(|e: ConfigErrors| e.to_string())?;
    let setup = setup(config.core(), &recorded.set).map_err(|p| p.join("; "))?;
    Ok((config.for_imu(setup), loo))
}

/// Runs every built-in IMU person through the three tasks, `runs` times
/// each, and the breath study with the same seed. `progress(done, total)`
/// after each head run.
pub fn run(
    options: &HeadStudyOptions,
    mut progress: impl FnMut(usize, usize),
) -> Result<HeadStudyReport, String> {
    let breath_options = StudyOptions {
        seed: options.seed,
        ..StudyOptions::default()
    };
    let breath =
        run_study(&Config::default(), &breath_options, |_, _| {}).map_err(|e| e.to_string())?;
    let summaries: Vec<TaskSummary> = breath.iter().map(|t| t.summary()).collect();
    let users = ImuUser::all();
    let total = users.len() * TASKS.len() * options.runs as usize;
    let mut done = 0;
    let mut people = Vec::new();
    for (u, user) in users.iter().enumerate() {
        let (config, leave_one_out) = head_config(user, options.seed)?;
        let reaction = UserModel::POPULATION
            .participant(options.seed ^ (u as u64 + 1) << 32)
            .reaction_ms;
        let person = HeadParticipant {
            user: *user,
            reaction_ms: reaction,
        };
        let mut tasks = Vec::new();
        for task in &TASKS {
            let mut runs = Vec::new();
            for r in 0..options.runs {
                let seed = options.seed.wrapping_mul(0x9e37_79b9_7f4a_7c15)
                    ^ (u as u64) << 20
                    ^ u64::from(task.number) << 8
                    ^ r;
                runs.push(run_head_task(&config, task.steps, &person, seed));
                done += 1;
                progress(done, total);
            }
            tasks.push(runs);
        }
        people.push(HeadPerson {
            name: user.name,
            drive_deg: person.drive_deg(),
            leave_one_out,
            tasks,
        });
    }
    let tasks = summaries
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let runs = || people.iter().flat_map(|p| &p.tasks[i]);
            let finished = || runs().filter(|r| !r.timed_out);
            let times: Vec<f64> = finished().map(|r| r.completion_s).collect();
            let moving: Vec<f64> = finished().map(|r| r.moving_s).collect();
            HeadTaskRow {
                task: s.task,
                asp_mean_s: s.asp_mean_s,
                asp_sd_s: s.asp_sd_s,
                bsp_mean_s: s.bsp_mean_s,
                bsp_sd_s: s.bsp_sd_s,
                head_mean_s: mean(&times),
                head_sd_s: sample_sd(&times),
                head_moving_s: mean(&moving),
                head_unfinished: runs().filter(|r| r.timed_out).count(),
                asp_moving_s: s.asp_moving_mean_s,
            }
        })
        .collect();
    Ok(HeadStudyReport {
        seed: options.seed,
        runs: options.runs,
        tasks,
        people,
    })
}

/// The report as Markdown tables: the tasks side by side, then each
/// person's times (means of the finished runs) and selections.
pub fn text(report: &HeadStudyReport) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| task | ASP s (breath) | BSP s (breath) | head s | moving s ASP / head | head runs unfinished |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|");
    for t in &report.tasks {
        let _ = writeln!(
            s,
            "| {} | {:.1} ± {:.1} | {:.1} ± {:.1} | {:.1} ± {:.1} | {:.1} / {:.1} | {} |",
            t.task,
            t.asp_mean_s,
            t.asp_sd_s,
            t.bsp_mean_s,
            t.bsp_sd_s,
            t.head_mean_s,
            t.head_sd_s,
            t.asp_moving_s,
            t.head_moving_s,
            t.head_unfinished
        );
    }
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "| person | drive tilt | leave-one-out | task 1 s | task 2 s | task 3 s | modes entered | wrong | tried again | unfinished |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|");
    for p in &report.people {
        let all = || p.tasks.iter().flatten();
        let task_s = |i: usize| {
            let finished = p.tasks[i].iter().filter(|r| !r.timed_out);
            let times: Vec<f64> = finished.map(|r| r.completion_s).collect();
            if times.is_empty() {
                "–".to_string()
            } else {
                format!("{:.1}", mean(&times))
            }
        };
        let _ = writeln!(
            s,
            "| {} | {:.0}° | {}/{} | {} | {} | {} | {} | {} | {} | {} |",
            p.name,
            p.drive_deg,
            p.leave_one_out.0,
            p.leave_one_out.1,
            task_s(0),
            task_s(1),
            task_s(2),
            all().map(|r| r.selections).sum::<u32>(),
            all().map(|r| r.wrong_selections).sum::<u32>(),
            all().map(|r| r.retries).sum::<u32>(),
            all().filter(|r| r.timed_out).count(),
        );
    }
    s
}
