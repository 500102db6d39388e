//! `sipnpuff design` as a clinician meets it: a library analysed for a
//! person, a designed library written as a configuration the other
//! commands read, the study agreeing with the model's times, and clear
//! errors for what cannot be designed.

use std::path::Path;

use serde_json::Value;
use sipnpuff::config::Config;
use sipnpuff::design::analysis::{AttemptTiming, analyse};
use sipnpuff::design::breathing::Breathing;
use sipnpuff::design::usage::Usage;
use sipnpuff::gestures::set::GestureSet;
use sipnpuff::sim::study::libraries::{compare, mean_over_task_selections};
use sipnpuff::sim::user::UserModel;

use crate::scratch::Scratch;

use crate::common::refused;
use crate::common::sipnpuff_output as sipnpuff;

/// Runs a command that must succeed and parses its one JSON line.
fn json(args: &[&str]) -> Value {
    let out = sipnpuff(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// A fitted profile of the built-in breather `name`, as a clinician makes
/// one: the calibration breathed, then `fit`.
fn profile(dir: &Scratch, name: &str) -> String {
    let signal = dir.join(format!("{name}.csv"));
    let profile = dir.join(format!("{name}.toml"));
    let s = |p: &Path| p.to_str().unwrap().to_owned();
    let generated = sipnpuff(&[
        "generate",
        "--breather",
        name,
        "--protocol",
        "--holds",
        "--out",
        &s(&signal),
    ]);
    assert!(generated.status.success());
    let fitted = sipnpuff(&["fit", "--from", &s(&signal), "--out", &s(&profile)]);
    assert!(
        fitted.status.success(),
        "{}",
        String::from_utf8_lossy(&fitted.stderr)
    );
    s(&profile)
}

#[test]
fn the_check_gives_each_entry_its_time_and_error() {
    let a = json(&["design", "--check", "--json"]);
    let entries = a["entries"].as_array().unwrap();
    assert_eq!(entries.len(), 9);
    assert_eq!(entries[0]["actions"], serde_json::json!([-1, -1]));
    assert_eq!(entries[0]["mode"], "translate_x");
    for e in entries {
        let ms = e["expected_ms"].as_f64().unwrap();
        assert!(ms > 1000.0 && ms < 3000.0, "{e}");
        assert!(e["p_wrong"].as_f64().unwrap() > 0.0);
    }
    // rotate_z (long puff, long puff) takes two long breaths: the slowest.
    let slowest = entries
        .iter()
        .max_by(|x, y| {
            x["expected_ms"]
                .as_f64()
                .unwrap()
                .total_cmp(&y["expected_ms"].as_f64().unwrap())
        })
        .unwrap();
    assert_eq!(slowest["mode"], "rotate_z");
    assert!(a["expected_ms_per_selection"].as_f64().unwrap() > 1000.0);
    assert!(a["p_wrong_per_selection"].as_f64().unwrap() > 0.0);
    assert!(!a["findings"].as_array().unwrap().is_empty());
}

#[test]
fn the_check_json_names_the_library_and_why_this_usage() {
    let a = json(&["design", "--check", "--json"]);
    assert_eq!(a["library"], "the built-in library");
    assert_eq!(
        a["usage"],
        "the mode changes of the study's three tasks (33 selections, each entry one more)"
    );
    assert_eq!(
        a["usage_why"],
        "the default: the library selects the study's modes and no --usage recordings were given"
    );
    let text = sipnpuff(&["design", "--check"]);
    let first = String::from_utf8(text.stdout).unwrap();
    assert_eq!(
        first.lines().next().unwrap(),
        format!(
            "{} analysed for: {} ({})",
            a["library"].as_str().unwrap(),
            a["usage"].as_str().unwrap(),
            a["usage_why"].as_str().unwrap()
        )
    );
    let uniform = json(&["design", "--check", "--json", "--mix", "uniform"]);
    assert_eq!(uniform["usage"], "every entry as often");
    assert_eq!(uniform["usage_why"], "asked for (--mix uniform)");
}

#[test]
fn a_designed_library_is_a_configuration_the_other_commands_read() {
    let dir = Scratch::new();
    let out = dir.join("designed.toml");
    let out = out.to_str().unwrap();
    let report = json(&["design", "--no-study", "--out", out, "--json"]);
    assert_eq!(report["search"]["complete"], true);
    let config = Config::from_file(Path::new(out)).unwrap();
    assert_eq!(config.core().sequences().len(), 9);
    // What `design --check` says of the written file is what the search
    // said of the library it wrote.
    let check = json(&["design", "--check", out, "--json"]);
    assert_eq!(
        check["expected_ms_per_selection"],
        report["designed"]["expected_ms_per_selection"]
    );
    assert!(
        check["expected_ms_per_selection"].as_f64().unwrap()
            < report["before"]["expected_ms_per_selection"]
                .as_f64()
                .unwrap()
    );
    let text = std::fs::read_to_string(out).unwrap();
    assert!(text.contains("% of selections;"), "{text}");
    let study = json(&["study", "--config", out, "--json", "--users", "2"]);
    assert_eq!(study["tasks"].as_array().unwrap().len(), 3);
}

#[test]
fn a_profile_designs_for_its_person_and_a_plain_config_is_refused() {
    let dir = Scratch::new();
    let short = profile(&dir, "short_capacity");
    let a = json(&["design", "--check", "--user", &short, "--json"]);
    assert!(a["user"].as_str().unwrap().contains("short_capacity.toml"));
    let typical = json(&["design", "--check", "--json"]);
    assert_ne!(
        a["expected_ms_per_selection"],
        typical["expected_ms_per_selection"]
    );
    let plain = dir.join("plain.toml");
    std::fs::write(&plain, "[matcher]\nsequence_timeout_ms = 800\n").unwrap();
    let e = refused(&["design", "--check", "--user", plain.to_str().unwrap()]);
    assert!(e.contains("sipnpuff fit"), "{e}");
}

#[test]
fn impossible_constraints_say_what_to_change() {
    let e = refused(&["design", "--keep", "spin_around"]);
    assert!(
        e.contains("--keep spin_around") && e.contains("translate_x"),
        "{e}"
    );
    let e = refused(&[
        "design",
        "--max-breaths",
        "2",
        "--without",
        "long_sip",
        "long_puff",
    ]);
    assert!(e.contains("9 entries to place but only 4 sequences"), "{e}");
    let e = refused(&["design", "--min-breaths", "3", "--max-breaths", "2"]);
    assert!(e.contains("--min-breaths 3"), "{e}");
}

/// The model's time per mode change against the study's, over the tasks'
/// mode changes, for the built-in library and the study's participants.
#[test]
fn the_model_predicts_the_studys_selection_time_within_5_percent() {
    let config = Config::default();
    let library = config.core().sequences();
    let who = Breathing::of_model(&UserModel::POPULATION, config.core().detector(), "study");
    let timing = AttemptTiming::of(&who, &config, None);
    let a = analyse(library, &who, &Usage::tasks(library), &timing);
    let predicted = mean_over_task_selections(library, |i| a.entries[i].expected_ms) / 1000.0;
    let study = compare(&config, &config, &UserModel::POPULATION, 8, 1).unwrap();
    let measured = study.a_selection_s;
    let error = (predicted - measured) / measured;
    assert!(
        error.abs() < 0.05,
        "predicted {predicted:.3} s, measured {measured:.3} s"
    );
}

/// The entries `--keep` holds so the search places only the last three
/// (rotate_z, save_point, goto_point): a small, exact search.
const KEEP_SIX: [&str; 7] = [
    "--keep",
    "translate_x",
    "translate_y",
    "translate_z",
    "fingers",
    "rotate_x",
    "rotate_y",
];

/// Runs `design` with `args` and the six entries kept; its stdout.
fn design_text(args: &[&str]) -> String {
    let mut all = vec!["design"];
    all.extend_from_slice(args);
    all.extend_from_slice(&KEEP_SIX);
    let out = sipnpuff(&all);
    assert!(
        out.status.success(),
        "{all:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn the_first_line_says_the_usage_designed_for_and_why() {
    let first = |args: &[&str]| design_text(args).lines().next().unwrap().to_owned();
    assert_eq!(
        first(&["--no-study"]),
        "designed for: the mode changes of the study's three tasks (33 selections, each entry one more) (the default: the library selects the study's modes and no --usage recordings were given)"
    );
    assert_eq!(
        first(&["--no-study", "--mix", "uniform"]),
        "designed for: every entry as often (asked for (--mix uniform))"
    );
    assert_eq!(
        first(&["--no-study", "--usage", "fixtures/recording-built-in-user"]),
        "designed for: the matches of 1 recording(s) (1 selections, each entry one more) (the person's recorded use (--usage))"
    );
    let out = sipnpuff(&[
        "design",
        "fixtures/computer-and-home.toml",
        "--no-study",
        "--keep",
        "translate_x",
        "fingers",
        "pointer_x",
        "pointer_y",
        "scroll",
        "drag",
        "left",
    ]);
    assert!(out.status.success());
    assert_eq!(
        String::from_utf8_lossy(&out.stdout).lines().next().unwrap(),
        "designed for: every entry as often (the default: no --usage recordings, and the library lacks the study's translate_y, translate_z, rotate_x, rotate_y)"
    );
}

#[test]
fn a_study_of_another_usage_is_said_with_the_difference_on_each() {
    let text = design_text(&["--mix", "uniform", "--users", "2"]);
    let second = text.lines().nth(1).unwrap();
    assert!(
        second.starts_with(
            "the study below measures another usage, the mode changes of its three tasks: the designed library is "
        ),
        "{text}"
    );
    assert!(
        second.contains(" than the built-in library on every entry as often (the model, "),
        "{second}"
    );
    let last = text.lines().last().unwrap();
    assert!(
        last.starts_with(
            "bottom line: switch to the designed library if the person's use is every entry as often: "
        ) && last.contains("; the study measured its tasks instead, another usage: per mode change "),
        "{last}"
    );
    // On the study's own usage, no such line: the study measures it.
    let text = design_text(&["--users", "2"]);
    assert!(text.lines().nth(1).unwrap().is_empty(), "{text}");
}

#[test]
fn a_slower_library_is_never_written_without_force() {
    let dir = Scratch::new();
    let out = dir.join("slower.toml");
    let args = [
        "design",
        "--min-breaths",
        "3",
        "--no-study",
        "--out",
        out.to_str().unwrap(),
        "--keep",
        "translate_x",
        "translate_y",
        "translate_z",
        "fingers",
        "rotate_x",
        "rotate_y",
    ];
    let e = refused(&args);
    assert!(
        e.contains(
            "slower.toml: keep the built-in library: the model expects the designed library 0.4 % slower"
        ) && e.contains("not written without --force; --force writes it anyway"),
        "{e}"
    );
    assert!(!out.exists());
    let mut forced = args.to_vec();
    forced.push("--force");
    let written = sipnpuff(&forced);
    assert!(written.status.success());
    assert!(Config::from_file(&out).is_ok());
    let stdout = String::from_utf8(written.stdout).unwrap();
    let last = stdout.lines().last().unwrap();
    assert!(
        last.starts_with("bottom line: keep the built-in library: ")
            && last.ends_with("; written because of --force"),
        "{last}"
    );
}

#[test]
fn without_long_sips_the_built_in_library_is_not_kept() {
    let report = json(&[
        "design",
        "--without",
        "long_sip",
        "--no-study",
        "--json",
        "--keep",
        "translate_x",
        "translate_y",
        "translate_z",
        "fingers",
        "rotate_x",
        "rotate_y",
        "rotate_z",
    ]);
    assert_eq!(report["verdict"]["decision"], "switch");
    let text = report["verdict"]["text"].as_str().unwrap();
    assert!(
        text.starts_with(
            "use the designed library: the built-in library needs long sips, which this person cannot breathe (--without)"
        ),
        "{text}"
    );
    assert!(!text.contains("near-optimal"), "{text}");
}

#[test]
fn the_bottom_line_agrees_with_the_study_on_its_usage() {
    let report = json(&["design", "--json", "--users", "8"]);
    // The built-in library is within 1 % of the least cost on the tasks
    // and the study finds no difference (p 0.18–0.89): keep it.
    assert_eq!(report["study_measures_this_usage"], true);
    assert_eq!(report["verdict"]["decision"], "keep");
    let text = report["verdict"]["text"].as_str().unwrap();
    assert!(
        text.starts_with("keep the built-in library: it is near-optimal")
            && text.contains("the study measures no difference (per mode change 1.37 → 1.38 s (0.8 % slower), p 0.18–0.89"),
        "{text}"
    );
}

#[test]
fn a_profile_check_names_the_library_and_labels_its_rates() {
    let dir = Scratch::new();
    let short = profile(&dir, "short_capacity");
    let out = sipnpuff(&["design", "--check", "--user", &short]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.starts_with("the built-in library analysed for: "),
        "{text}"
    );
    assert!(!text.contains("the profile's library"), "{text}");
    assert!(
        text.contains("\nrates measured (fit): short sip read as long sip 0.00 %, "),
        "{text}"
    );
    assert!(
        text.contains(
            "\nrates assumed (the study's population): selections breathed with one burst at the wrong length 5.00 %\n"
        ),
        "{text}"
    );
    let a = json(&["design", "--check", "--user", &short, "--json"]);
    let rates = a["rates"].as_array().unwrap();
    let source = |what: &str| {
        rates
            .iter()
            .find(|r| r["what"] == what)
            .map(|r| r["source"].as_str().unwrap().to_owned())
            .unwrap()
    };
    assert_eq!(source("long puff read as short puff"), "measured (fit)");
    assert_eq!(
        source("selections breathed with one burst at the wrong length"),
        "assumed (the study's population)"
    );
    // The study's own user: modelled, not measured.
    let typical = json(&["design", "--check", "--json"]);
    assert_eq!(
        typical["rates"][0]["source"],
        "modelled (the study's simulated user)"
    );
}

#[test]
fn a_designed_file_keeps_the_profiles_reasons_and_the_sequences_replaced() {
    let dir = Scratch::new();
    let short = profile(&dir, "short_capacity");
    let out = dir.join("designed.toml");
    let designed = sipnpuff(&[
        "design",
        "--user",
        &short,
        "--no-study",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(designed.status.success());
    let text = std::fs::read_to_string(&out).unwrap();
    let profile_text = std::fs::read_to_string(&short).unwrap();
    for key in ["neutral_volts", "long_burst_ms"] {
        let reason = |t: &str| {
            let lines: Vec<&str> = t.lines().collect();
            let at = lines
                .iter()
                .position(|l| l.starts_with(&format!("{key} = ")))
                .unwrap();
            lines[at - 1].to_owned()
        };
        assert!(reason(&profile_text).starts_with("# "));
        assert_eq!(reason(&text), reason(&profile_text), "{text}");
    }
    assert!(
        text.contains(" (was [-1, -1]): ") || text.contains(" (kept): "),
        "{text}"
    );
    assert!(Config::from_file(&out).is_ok());
}

/// The simulated `typical` person's gesture set and a library of their
/// gestures (fixtures/gesture-user).
const GESTURE_USER: &str = "fixtures/gesture-user/config.toml";
const GESTURE_SET: &str = "fixtures/gesture-user/gestures.toml";

fn gesture_set() -> GestureSet {
    GestureSet::from_toml(&std::fs::read_to_string(GESTURE_SET).unwrap()).unwrap()
}

/// Each gesture's time in the set: its examples' mean length and the
/// front end's 300 ms of rest before it is read, ms.
fn gesture_ms(set: &GestureSet, name: &str) -> f64 {
    let g = set.gestures.iter().find(|g| g.name == name).unwrap();
    let total: u64 = g.examples.iter().map(|e| e.end - e.start).sum();
    total as f64 / g.examples.len() as f64 + f64::from(set.config.rest_ms)
}

/// The entry of `a` that selects `mode`.
fn entry<'a>(a: &'a Value, mode: &str) -> &'a Value {
    a["entries"]
        .as_array()
        .unwrap()
        .iter()
        .find(|e| e["mode"] == mode)
        .unwrap()
}

fn ms(v: &Value) -> f64 {
    v.as_f64().unwrap()
}

#[test]
fn a_gesture_set_is_the_person_and_each_gesture_costs_its_examples_time() {
    let set = gesture_set();
    let a = json(&["design", "--check", "--config", GESTURE_USER, "--json"]);
    assert_eq!(
        a["user"],
        "the study's simulated user, with the gestures of fixtures/gesture-user/gestures.toml"
    );
    let reaction = ms(&a["timing"]["reaction_ms"]);
    let gap = ms(&a["timing"]["gap_ms"]);
    // 5/5 in leave-one-out, each gesture: never rejected, never taken for
    // another, so each entry costs one attempt: the reaction, then each
    // gesture and the rest that ends it, a gap between.
    for (mode, gestures) in [
        ("translate_x", &["nod"][..]),
        ("translate_z", &["double_nod"]),
        ("translate_y", &["shake"]),
        ("fingers", &["tilt_left"]),
        ("rotate_z", &["tilt_right", "nod"]),
    ] {
        let e = entry(&a, mode);
        let made: f64 = gestures.iter().map(|g| gesture_ms(&set, g)).sum();
        let attempt = reaction + made + gap * (gestures.len() - 1) as f64;
        assert_eq!(ms(&e["attempt_ms"]), attempt, "{mode}");
        assert_eq!(ms(&e["expected_ms"]), attempt, "{mode}");
        assert_eq!((ms(&e["p_wrong"]), ms(&e["p_retry"])), (0.0, 0.0), "{mode}");
    }
    // The nod: 768 ms on average and 300 ms of rest, after the 459 ms
    // reaction.
    assert_eq!(gesture_ms(&set, "nod"), 1068.0);
    assert_eq!(
        entry(&a, "translate_x")["actions"],
        serde_json::json!(["nod"])
    );
    let rates = a["rates"].as_array().unwrap();
    let nod_rejected = rates.iter().find(|r| r["what"] == "nod rejected").unwrap();
    assert_eq!(
        nod_rejected["source"],
        "measured (leave-one-out of fixtures/gesture-user/gestures.toml)"
    );
    // A library of gestures alone: no breath's rates.
    assert!(
        rates
            .iter()
            .all(|r| !r["what"].as_str().unwrap().contains("sip"))
    );
    let text = sipnpuff(&["design", "--check", "--config", GESTURE_USER]);
    let text = String::from_utf8(text.stdout).unwrap();
    for line in [
        "gestures timed from their examples (fixtures/gesture-user/gestures.toml): nod 0.77 s, double_nod 1.24 s, shake 1.21 s, tilt_left 1.56 s, tilt_right 1.87 s, wobble 1.01 s; each read 0.30 s after it ends (the front end's rest_ms)",
        "| entry | sequence | used | expected s | wait s | wrong % | retry % | lands in |",
        "| rotate_z | tilt_right nod | 17 % | 4.00 | 0.0 | 0.00 | 0.00 | — |",
        "per selection: 2.26 s expected, 0.00 % of attempts select a wrong entry",
    ] {
        assert!(text.lines().any(|l| l == line), "{line}\n{text}");
    }
    // The same file as the library: its set with it.
    let same = json(&["design", "--check", GESTURE_USER, "--json"]);
    assert_eq!(
        same["expected_ms_per_selection"],
        a["expected_ms_per_selection"]
    );
}

#[test]
fn a_library_mixing_breaths_and_gestures_is_priced_item_by_item() {
    let dir = Scratch::new();
    let person = dir.join("person.toml");
    std::fs::write(
        &person,
        format!(
            "[gestures]\nset = \"{GESTURE_SET}\"\n\n\
             [[sequence]]\nactions = [-1, -1]\nmode = \"translate_x\"\n\n\
             [[sequence]]\nactions = [\"nod\", -1]\nmode = \"translate_y\"\n\n\
             [[sequence]]\nactions = [\"shake\"]\nmode = \"translate_z\"\n"
        ),
    )
    .unwrap();
    let a = json(&[
        "design",
        "--check",
        "--config",
        person.to_str().unwrap(),
        "--json",
    ]);
    let t = &a["timing"];
    let (reaction, gap, edge, latency) = (
        ms(&t["reaction_ms"]),
        ms(&t["gap_ms"]),
        ms(&t["edge_ms"]),
        ms(&t["latency_ms"]),
    );
    let set = gesture_set();
    // A nod (read when it has ended), the gap, a short puff of the study's
    // user (150 ms) with its rise, half its edges, and the detector's
    // latency.
    let mixed = entry(&a, "translate_y");
    assert_eq!(mixed["actions"], serde_json::json!(["nod", -1]));
    let attempt = reaction + gesture_ms(&set, "nod") + gap + 150.0 + 0.5 * edge + latency;
    assert!((ms(&mixed["attempt_ms"]) - attempt).abs() < 1e-9, "{mixed}");
    // Two short puffs as the breath library prices them.
    let puffs = entry(&a, "translate_x");
    let attempt = reaction + 150.0 + gap + 150.0 + 1.5 * edge + latency;
    assert!((ms(&puffs["attempt_ms"]) - attempt).abs() < 1e-9, "{puffs}");
    // The breaths' rates and the gestures' side by side.
    let sources: Vec<&str> = a["rates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["source"].as_str().unwrap())
        .collect();
    assert!(sources.contains(&"modelled (the study's simulated user)"));
    assert!(sources.contains(&"measured (leave-one-out of fixtures/gesture-user/gestures.toml)"));
}

#[test]
fn a_confused_pair_shows_where_each_lands() {
    // The person made the wrong gesture once each when prompted: the 5th
    // nod is recorded as a shake, the 5th shake as a nod.
    let dir = Scratch::new();
    let mut set = gesture_set();
    let nod = set.gestures[0].examples[4].clone();
    set.gestures[0].examples[4] = std::mem::replace(&mut set.gestures[2].examples[4], nod);
    let swapped = dir.join("swapped.toml");
    std::fs::write(&swapped, set.to_toml(&[])).unwrap();
    let swapped = swapped.to_str().unwrap();
    let check = json(&["gestures", "check", swapped, "--json"]);
    assert_eq!(
        check["confusion"][0],
        serde_json::json!([3, 0, 1, 0, 0, 0, 1])
    );
    assert_eq!(
        check["confusion"][2],
        serde_json::json!([2, 0, 3, 0, 0, 0, 0])
    );
    let a = json(&[
        "design",
        "--check",
        "--config",
        GESTURE_USER,
        "--gestures",
        swapped,
        "--json",
    ]);
    let wrong_cost = ms(&a["timing"]["wrong_cost_ms"]);
    let attempt = |g: &str| ms(&a["timing"]["reaction_ms"]) + gesture_ms(&set, g);
    // The nod: read as a shake 1 in 5 (translate_y, then 2 s back to
    // selection), rejected 1 in 5 (made again), right 3 in 5.
    let nod = entry(&a, "translate_x");
    assert_eq!((ms(&nod["p_wrong"]), ms(&nod["p_retry"])), (0.2, 0.2));
    assert_eq!(nod["confusions"][0]["label"], "translate_y");
    assert_eq!(
        nod["confusions"][0]["how"],
        "its 1st gesture (nod) read as shake"
    );
    let expected = (attempt("nod") + 0.2 * wrong_cost) / 0.6;
    assert!((ms(&nod["expected_ms"]) - expected).abs() < 1e-9, "{nod}");
    // The shake: read as a nod 2 in 5.
    let shake = entry(&a, "translate_y");
    assert_eq!((ms(&shake["p_wrong"]), ms(&shake["p_retry"])), (0.4, 0.0));
    assert_eq!(shake["confusions"][0]["label"], "translate_x");
    let expected = (attempt("shake") + 0.4 * wrong_cost) / 0.6;
    assert!(
        (ms(&shake["expected_ms"]) - expected).abs() < 1e-9,
        "{shake}"
    );
    // A tilt then a nod: a nod read as a shake or rejected lands nowhere,
    // and the head's motion holds the timeout until it ends: each failed
    // attempt takes as long as a good one.
    let both = entry(&a, "rotate_z");
    assert_eq!((ms(&both["p_wrong"]), ms(&both["p_retry"])), (0.0, 0.4));
    assert!((ms(&both["expected_ms"]) - ms(&both["attempt_ms"]) / 0.6).abs() < 1e-9);
    let findings: Vec<&str> = a["findings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f.as_str().unwrap())
        .collect();
    assert!(
        findings.contains(&"`translate_y` lands in `translate_x` when its 1st gesture (shake) read as nod: 40.0 % of `translate_y` attempts for this user"),
        "{findings:?}"
    );
    assert!(findings.iter().any(|f| f.starts_with(
        "this person's `shake` is read as `nod` 40.0 % of the time (leave-one-out of "
    ) && f.ends_with("(`design --without shake`)")));
}

#[test]
fn design_places_entries_on_the_persons_gestures() {
    let dir = Scratch::new();
    let out = dir.join("designed.toml");
    let out = out.to_str().unwrap();
    let run = sipnpuff(&["design", "--config", GESTURE_USER, "--out", out, "--json"]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let stderr = String::from_utf8_lossy(&run.stderr);
    // A library of gestures alone: the person may have no breath sensor.
    assert!(
        stderr.contains("placing 6 entries on 258 sequences of nod, double_nod, shake, tilt_left, tilt_right, wobble (no breaths: the library has none, so the person may have no breath sensor: --with-breaths places them too)…"),
        "{stderr}"
    );
    assert!(stderr.contains("no study: "), "{stderr}");
    let report: Value = serde_json::from_slice(&run.stdout).unwrap();
    assert_eq!(report["search"]["complete"], true);
    // rotate_z's tilt then nod becomes the tilt alone, which no entry
    // starts with: 1.37 s sooner, so 10.1 % faster over the six entries.
    assert_eq!(
        entry(&report["designed"], "rotate_z")["actions"],
        serde_json::json!(["tilt_right"])
    );
    for e in report["designed"]["entries"].as_array().unwrap() {
        let items = e["actions"].as_array().unwrap();
        assert!(items.iter().all(Value::is_string), "{e}");
    }
    assert_eq!(report["verdict"]["decision"], "switch");
    assert!(
        report["verdict"]["text"]
            .as_str()
            .unwrap()
            .contains("10.1 % faster and never wrong (nor is the other)"),
        "{}",
        report["verdict"]["text"]
    );
    // The file names the set, and `design --check` prices it as the search did.
    let written = Config::from_file(Path::new(out)).unwrap();
    assert_eq!(
        written.core().gesture_set_file(),
        Some(Path::new(GESTURE_SET))
    );
    let check = json(&["design", "--check", out, "--json"]);
    assert_eq!(
        check["expected_ms_per_selection"],
        report["designed"]["expected_ms_per_selection"]
    );
    // With breaths too, the four most used place on two short bursts.
    let both = json(&[
        "design",
        "--config",
        GESTURE_USER,
        "--with-breaths",
        "--no-study",
        "--json",
    ]);
    let breaths = both["designed"]["entries"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|e| e["actions"].as_array().unwrap().iter().all(Value::is_i64))
        .count();
    assert_eq!(breaths, 4);
}

#[test]
fn a_gesture_set_that_cannot_be_used_is_refused_with_what_is_wrong() {
    let dir = Scratch::new();
    let e = refused(&[
        "design",
        "--check",
        "--config",
        GESTURE_USER,
        "--gestures",
        "no-such-set.toml",
    ]);
    assert!(
        e.contains("the gesture set no-such-set.toml: cannot read it: ")
            && e.contains("(make it with `sipnpuff gestures record`)"),
        "{e}"
    );
    let broken = dir.join("broken.toml");
    std::fs::write(&broken, "features = 2\n").unwrap();
    let e = refused(&[
        "design",
        "--check",
        "--config",
        GESTURE_USER,
        "--gestures",
        broken.to_str().unwrap(),
    ]);
    assert!(
        e.contains("broken.toml: line 1: missing field `channels`"),
        "{e}"
    );
    // A set without the wobble the library names.
    let mut set = gesture_set();
    set.gestures.retain(|g| g.name != "wobble");
    let five = dir.join("five.toml");
    std::fs::write(&five, set.to_toml(&[])).unwrap();
    let e = refused(&[
        "design",
        "--config",
        GESTURE_USER,
        "--gestures",
        five.to_str().unwrap(),
    ]);
    assert!(
        e.contains("five.toml: sequence #6.actions: `wobble` not in the gesture set (it has nod, double_nod, shake, tilt_left, tilt_right)"),
        "{e}"
    );
    let e = refused(&["design", "--config", GESTURE_USER, "--without", "frown"]);
    assert!(
        e.contains("--without frown: not a burst (short_sip, long_sip, short_puff, long_puff, breaths) and the gesture set fixtures/gesture-user/gestures.toml has nod, double_nod, shake, tilt_left, tilt_right, wobble"),
        "{e}"
    );
    let e = refused(&["design", "--without", "frown"]);
    assert!(e.contains("no gesture set is given (--gestures"), "{e}");
}
