//! The scanning interface (BSP) through the whole core, the simulated
//! users and the study: which mode is highlighted when, a puff enters it,
//! inactivity returns to scanning from the first mode; the study is
//! deterministic for a seed and its comparison behaves as the design says.

use crate::common::TickByTick;
use sipnpuff::config::Config;
use sipnpuff::control::event::Event;
use sipnpuff::control::mode::{Mode, ModeState};
use sipnpuff::control::pipeline::Pipeline;
use sipnpuff::control::selection::Interface;
use sipnpuff::control::selection::scanning::ScanningConfig;
use sipnpuff::sim::sensor_model::{SignalGenerator, SignalParams, Step};
use sipnpuff::sim::study::fit_paper::{self, FitPlan, Targets};
use sipnpuff::sim::study::{StudyOptions, StudyReport, TaskResults, run_study};
use sipnpuff::sim::user::{RUN_STEPS, scripted_session};

use crate::common::{puff, rest, sip};

fn bsp() -> Config {
    Config::default().with_interface(Interface::Bsp).unwrap()
}

/// Every event of a clean script through a BSP core, with its tick.
fn events(config: &Config, script: &[Step]) -> Vec<(u64, Event)> {
    let mut core: Pipeline = Pipeline::new(config.core());
    let params = SignalParams::clean(config.core().detector(), 7);
    let mut out = Vec::new();
    for (t, v) in SignalGenerator::new(params, script).enumerate() {
        for e in core.tick(t as u64, v).events.iter() {
            out.push((t as u64, *e));
        }
    }
    out
}

fn highlights(events: &[(u64, Event)]) -> Vec<(u64, Mode)> {
    events
        .iter()
        .filter_map(|(t, e)| match e {
            Event::Highlight { mode } => Some((*t, *mode)),
            _ => None,
        })
        .collect()
}

#[test]
fn the_scan_highlights_each_mode_on_time() {
    // At rest: 3 s on translate_x, then 1.5 s on each next mode, round.
    let config = bsp();
    let seen = highlights(&events(&config, &[rest(20_000)]));
    let expected: Vec<(u64, Mode)> = [(0, Mode::TranslateX)]
        .into_iter()
        .chain((1..9).map(|k| (3000 + (k as u64 - 1) * 1500, Mode::ALL[k])))
        .chain([(15_000, Mode::TranslateX), (16_500, Mode::TranslateY)])
        .chain([(18_000, Mode::TranslateZ), (19_500, Mode::RotateX)])
        .collect();
    assert_eq!(seen, expected);
}

#[test]
fn a_puff_enters_the_highlighted_mode_and_inactivity_restarts_the_scan() {
    let config = bsp();
    // translate_z is highlighted 4500–5999: puff in the middle of it, then
    // sip 1 s (down), then rest past the inactivity timeout.
    let script = [rest(5000), puff(150), rest(500), sip(1000), rest(6000)];
    let all = events(&config, &script);
    let matches: Vec<(u64, Mode)> = all
        .iter()
        .filter_map(|(t, e)| match e {
            Event::Match { target, sequence } => {
                assert_eq!(
                    sequence.actions().unwrap().codes().collect::<Vec<_>>(),
                    [-1]
                );
                target.mode().map(|mode| (*t, mode))
            }
            _ => None,
        })
        .collect();
    assert_eq!(matches.len(), 1, "{all:?}");
    assert_eq!(matches[0].1, Mode::TranslateZ);
    // No highlight in command mode; after the inactivity timeout the scan
    // starts again from translate_x.
    let back = all
        .iter()
        .find(|(_, e)| matches!(e, Event::Detection { .. }))
        .expect("back to scanning")
        .0;
    let after: Vec<(u64, Mode)> = highlights(&all)
        .into_iter()
        .filter(|(t, _)| *t > matches[0].0)
        .collect();
    // (The scanner runs before the mode machine within a tick, so the scan
    // starts on the tick after the return.)
    assert_eq!(after[0], (back + 1, Mode::TranslateX), "{after:?}");
    assert_eq!(after[1], (back + 1 + 3000, Mode::TranslateY));
    // The sip moved the arm down (translate_z, negative) while in the mode.
    let mut core: Pipeline = Pipeline::new(config.core());
    let params = SignalParams::clean(config.core().detector(), 7);
    let moved_down = SignalGenerator::new(params, &script)
        .enumerate()
        .map(|(t, v)| core.tick(t as u64, v))
        .any(|o| {
            o.command.state == ModeState::Command(Mode::TranslateZ) && o.motion.linear[2] < 0.0
        });
    assert!(moved_down);
}

#[test]
fn sips_select_nothing_while_scanning() {
    let config = bsp();
    let script = [rest(1000), sip(150), rest(1000), sip(800), rest(3000)];
    let all = events(&config, &script);
    assert!(!all.iter().any(|(_, e)| matches!(e, Event::Match { .. })));
}

#[test]
fn the_run_users_session_selects_every_mode_of_its_plan() {
    // The session `sipnpuff run --interface bsp` plays: made in closed loop,
    // replayed open loop, it selects the planned modes in order.
    let config = bsp();
    let (params, script) = scripted_session(&config, &RUN_STEPS, 1);
    let mut core: Pipeline = Pipeline::new(config.core());
    let mut matched = Vec::new();
    for (t, v) in SignalGenerator::new(params, &script).enumerate() {
        for e in core.tick(t as u64, v).events.iter() {
            if let Event::Match { target, .. } = e {
                matched.extend(target.mode());
            }
        }
    }
    assert_eq!(
        matched,
        [
            Mode::SavePoint,
            Mode::TranslateX,
            Mode::Fingers,
            Mode::GotoPoint
        ]
    );
}

/// A study of `users` simulated users from `seed`.
fn study_options(users: usize, seed: u64) -> StudyOptions {
    StudyOptions {
        users,
        seed,
        ..StudyOptions::default()
    }
}

#[test]
fn the_study_is_deterministic_for_a_seed() {
    let config = Config::default();
    let options = study_options(3, 42);
    let report = |options: &StudyOptions| {
        let results = run_study(&config, options, |_, _| {}).unwrap();
        serde_json::to_value(StudyReport::of(&results, options)).unwrap()
    };
    let a = report(&options);
    assert_eq!(a, report(&options));
    let other = report(&StudyOptions {
        seed: 43,
        ..options
    });
    assert_ne!(a["tasks"], other["tasks"]);
}

#[test]
fn selection_is_the_only_difference() {
    // The same moves on both interfaces: moving times agree within the
    // users' hold variability (10 % SD per hold), completion times differ
    // by the scan. Every run finishes.
    let config = Config::default();
    let options = study_options(4, 5);
    for r in run_study(&config, &options, |_, _| {}).unwrap() {
        let s = r.summary();
        assert_eq!(s.timed_out, 0);
        let task_moving = f64::from(r.task.moving_ms()) / 1000.0;
        for moving in [s.asp_moving_mean_s, s.bsp_moving_mean_s] {
            assert!(
                (moving - task_moving).abs() < 0.1 * task_moving,
                "task {}: moving {moving} s vs {task_moving} s",
                s.task
            );
        }
        assert!(s.asp_mean_s < s.bsp_mean_s, "{s:?}");
        // Each completion at least the moving time plus one inactivity
        // timeout per mode change after the first.
        let floor = task_moving + 2.0 * (r.task.selections() - 1) as f64;
        for run in r.asp.iter().chain(&r.bsp) {
            assert!(run.completion_s > floor, "{run:?} vs floor {floor}");
        }
    }
}

/// Users who slip (start a selection before the
/// return to detection mode) at 20 % of their mode changes move the arm
/// without meaning to in the paper's design; with a motion onset longer
/// than every burst they breathe, no slip moves it and the mode changes
/// without the inactivity wait, so the tasks end sooner.
#[test]
fn a_motion_onset_removes_the_motion_of_slips_and_the_inactivity_wait() {
    use sipnpuff::sim::study::tasks::TASKS;
    use sipnpuff::sim::user::{UserModel, run_task};
    let user = UserModel {
        slip_rate: 0.2,
        ..UserModel::POPULATION
    };
    let task = &TASKS[0];
    let paper = Config::default();
    let onset = Config::default().with_motion_onset_ms(1300).unwrap();
    let (mut off_mm, mut off_slips, mut off_s, mut on_mm, mut on_s) = (0.0, 0, 0.0, 0.0, 0.0);
    for seed in 0..3 {
        let run = run_task(&paper, task, &user, seed);
        assert!(!run.timed_out);
        off_mm += run.unintended_mm;
        off_slips += run.slips;
        off_s += run.completion_s;
        let run = run_task(&onset, task, &user, seed);
        assert!(!run.timed_out);
        assert_eq!(run.slips, 0, "every switch is direct");
        assert!(run.direct_switches > 0);
        on_mm += run.unintended_mm;
        on_s += run.completion_s;
    }
    assert!(
        off_slips > 0 && off_mm > 10.0,
        "{off_slips} slips, {off_mm} mm"
    );
    assert_eq!(on_mm, 0.0);
    assert!(on_s < off_s, "{on_s} s with the onset, {off_s} s without");
}

/// The reductions and p-value of the study at a given scan and miss rate,
/// as the paper would report them.
fn figures_at(options: &StudyOptions, dwell_ms: u32, factor: f64, miss_rate: f64) -> Targets {
    let scanning = ScanningConfig {
        dwell_ms,
        first_dwell_ms: (factor * f64::from(dwell_ms)).round() as u32,
        ..ScanningConfig::default()
    };
    let config = Config::default().with_scanning(scanning).unwrap();
    let mut options = *options;
    options.population.miss_rate = miss_rate;
    let summaries: Vec<_> = run_study(&config, &options, |_, _| {})
        .unwrap()
        .iter()
        .map(TaskResults::summary)
        .collect();
    Targets {
        reduction_pct: std::array::from_fn(|t| summaries[t].reduction_pct),
        p_value: summaries[0].p_value,
    }
}

/// "Paper figures" made by the study itself at a known scan and miss rate
/// (none of them on the grid or a compass step from it), fitted with the
/// same seed.
fn fit_known() -> fit_paper::FitReport {
    let options = study_options(3, 11);
    let targets = figures_at(&options, TRUTH.0, TRUTH.1, TRUTH.2);
    let plan = FitPlan {
        grid: [vec![800.0, 1400.0], vec![1.5, 2.5], vec![0.05, 0.2]],
        steps: [200.0, 0.4, 0.05],
        min_steps: [40.0, 0.1, 0.02],
        ..FitPlan::default()
    };
    let report = fit_paper::fit(&Config::default(), &options, &targets, &plan, |_| {}).unwrap();
    for (task, target) in report.tasks.iter().zip(targets.reduction_pct) {
        assert!(
            (task.reduction_pct - target).abs() < 1.5,
            "task {}: {} % vs {target} %",
            task.task,
            task.reduction_pct
        );
    }
    report
}

/// Dwell, first-dwell factor and miss rate of the known study.
const TRUTH: (u32, f64, f64) = (1100, 1.8, 0.12);

/// The three reductions do not pin the three parameters one by one (a
/// longer first dwell trades against a shorter dwell and more misses), so
/// the fit is held to what it claims: the figures reproduced and the truth
/// within three of its standard deviations.
#[test]
fn the_fit_reproduces_known_figures_and_its_uncertainty_covers_the_truth() {
    let report = fit_known();
    let fit = &report.fit;
    for (estimate, truth) in [
        (fit.dwell_ms, f64::from(TRUTH.0)),
        (fit.first_dwell_factor, TRUTH.1),
        (fit.miss_rate, TRUTH.2),
    ] {
        assert!(
            (estimate.value - truth).abs() <= 3.0 * estimate.uncertainty,
            "{truth} outside {estimate:?}"
        );
    }
}

#[test]
fn the_fit_report_has_its_keys_and_is_deterministic_for_a_seed() {
    // One grid point and no compass search: the report's shape, cheaply.
    let options = study_options(2, 3);
    let plan = FitPlan {
        grid: [vec![1000.0], vec![2.0], vec![0.1]],
        steps: [0.0; 3],
        ..FitPlan::default()
    };
    let run = || {
        let report =
            fit_paper::fit(&Config::default(), &options, &Targets::PAPER, &plan, |_| {}).unwrap();
        serde_json::to_value(&report).unwrap()
    };
    let json = run();
    for key in ["dwell_ms", "first_dwell_factor", "miss_rate"] {
        assert!(json["fit"][key]["value"].is_f64(), "{key}: {json}");
        assert!(!json["fit"][key]["uncertainty"].is_string(), "{key}");
    }
    assert_eq!(json["fit"]["dwell_ms"]["value"], 1000.0);
    let tasks = json["tasks"].as_array().unwrap();
    assert_eq!(tasks.len(), 3);
    for (task, paper) in tasks.iter().zip([35.0, 30.0, 42.0]) {
        for key in ["reduction_pct", "residual_pct", "p_value"] {
            assert!(task[key].is_f64(), "{key}: {task}");
        }
        assert_eq!(task["paper_reduction_pct"], paper);
        let residual = task["reduction_pct"].as_f64().unwrap() - paper;
        assert!((task["residual_pct"].as_f64().unwrap() - residual).abs() < 1e-9);
    }
    assert_eq!(json, run());
}

/// A person who moves rather than breathes does the paper's first task
/// through the production core: their own set, recorded by the protocol,
/// reads their gestures; each selects its mode, and tilting the head
/// drives the arm. They finish, enter every mode the task needs and no
/// other, and move at the tilt's share of full speed, so for longer than
/// a breath at full speed would.
#[test]
fn a_head_gesture_user_does_the_first_task_with_their_own_set() {
    use sipnpuff::sim::head_user::{HeadParticipant, run_head_task};
    use sipnpuff::sim::imu_user::ImuUser;
    use sipnpuff::sim::study::head::head_config;
    use sipnpuff::sim::study::tasks::TASKS;
    use sipnpuff::sim::user::UserModel;

    let user = ImuUser::builtin("typical").unwrap();
    let (config, (right, examples)) = head_config(&user, 1).unwrap();
    assert_eq!((right, examples), (30, 30));
    let person = HeadParticipant {
        user,
        reaction_ms: UserModel::POPULATION.reaction_ms,
    };
    let task = &TASKS[0];
    let run = run_head_task(&config, task.steps, &person, 7);
    assert!(!run.timed_out, "{run:?}");
    assert_eq!(run.wrong_selections, 0, "{run:?}");
    assert_eq!(
        run.selections as usize,
        task.mode_changes().count(),
        "{run:?}"
    );
    assert!(
        run.moving_s > f64::from(task.moving_ms()) / 1000.0,
        "{run:?}"
    );
    // The same seed, the same run.
    assert_eq!(run_head_task(&config, task.steps, &person, 7), run);
}

/// `study --head`'s report: the breath study's ASP and BSP of the same
/// seed beside the head's, for each task; each of the six people with
/// their set, and runs that all finish with no wrong mode entered.
#[test]
fn the_head_study_sets_every_person_beside_the_breath_study() {
    use sipnpuff::sim::study::head::{self, HeadStudyOptions};

    let options = HeadStudyOptions { seed: 1, runs: 1 };
    let report = head::run(&options, |_, _| {}).unwrap();
    let breath = run_study(&Config::default(), &study_options(8, 1), |_, _| {}).unwrap();
    assert_eq!(report.tasks.len(), 3);
    for (row, task) in report.tasks.iter().zip(&breath) {
        let s = task.summary();
        assert_eq!(
            (row.task, row.asp_mean_s, row.bsp_mean_s),
            (s.task, s.asp_mean_s, s.bsp_mean_s)
        );
        assert_eq!(row.head_unfinished, 0, "{row:?}");
        assert!(row.head_mean_s > 0.0, "{row:?}");
    }
    let names: Vec<&str> = report.people.iter().map(|p| p.name).collect();
    assert_eq!(
        names,
        [
            "typical",
            "slow_small",
            "fast_large",
            "tremor",
            "wheelchair",
            "drifting"
        ]
    );
    for person in &report.people {
        assert_eq!(person.tasks.len(), 3);
        for run in person.tasks.iter().flatten() {
            assert_eq!(run.wrong_selections, 0, "{}: {run:?}", person.name);
        }
    }
    let text = head::text(&report);
    assert!(
        text.starts_with("| task | ASP s (breath) | BSP s (breath) | head s |"),
        "{text}"
    );
    assert_eq!(
        text.lines()
            .filter(|l| l.starts_with("| typical |"))
            .count(),
        1
    );
}
