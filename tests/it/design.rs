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
