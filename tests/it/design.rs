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
