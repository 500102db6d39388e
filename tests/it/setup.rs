//! A person's setup from several files (`--config A --config B`): later
//! files override earlier ones key by key, a later library replaces the
//! whole library, `config` and `config --diff` say which file each
//! setting came from, and the problems of every file come at once, each
//! named by its file and line.

use std::path::Path;

use sipnpuff::config::Config;
use sipnpuff::config::layers::Layered;

use crate::common::{assert_exit, sipnpuff_output as sipnpuff};
use crate::scratch::Scratch;

const PROFILE: &str = "\
# sipnpuff profile for \"ana\"
[detector]
# midway between the rest noise and your weakest short puff
puff_threshold_volts = 2.81
long_burst_ms = 470

[matcher]
sequence_timeout_ms = 900

[[sequence]]
actions = [1, 1]
mode = \"translate_x\"
";

const LIBRARY: &str = "\
[matcher]
# she pauses between the breaths of a sequence
sequence_timeout_ms = 1200

# her own library: two entries
[[sequence]]
actions = [-1, -1]
mode = \"fingers\"

[[sequence]]
actions = [2, 2]
event = \"call_for_help\"
";

fn s(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// The two files, written in a fresh scratch folder.
fn two_files() -> (Scratch, std::path::PathBuf, std::path::PathBuf) {
    let dir = Scratch::new();
    let (profile, library) = (dir.join("profile.toml"), dir.join("library.toml"));
    std::fs::write(&profile, PROFILE).unwrap();
    std::fs::write(&library, LIBRARY).unwrap();
    (dir, profile, library)
}

#[test]
fn later_files_override_key_by_key_and_a_library_replaces_whole() {
    let (_dir, profile, library) = two_files();
    let setup = Layered::read(&[profile.clone(), library.clone()]).unwrap();
    let config = setup.config();
    let detector = config.core().detector();
    assert_eq!(detector.puff_threshold_volts, 2.81);
    assert_eq!(detector.long_burst_ms, 470);
    assert_eq!(config.core().matcher().sequence_timeout_ms, 1200);
    let library_entries: Vec<String> = config
        .core()
        .sequences()
        .iter()
        .map(|e| format!("{:?} {}", e.actions.as_slice(), e.target.description()))
        .collect();
    assert_eq!(library_entries.len(), 2, "{library_entries:?}");
    assert_eq!(setup.source_index("detector.puff_threshold_volts"), Some(0));
    assert_eq!(setup.source_index("matcher.sequence_timeout_ms"), Some(1));
    assert_eq!(setup.source_index("sequence #2.event"), Some(1));
    assert_eq!(setup.source_index("detector.glitch_ms"), None);
    // The other way round: the profile's library (one entry) wins.
    let reversed = Layered::read(&[library, profile]).unwrap();
    assert_eq!(reversed.config().core().sequences().len(), 1);
    assert_eq!(
        reversed.config().core().matcher().sequence_timeout_ms,
        900,
        "the later file's timeout"
    );
}

#[test]
fn config_prints_each_setting_with_the_file_it_came_from() {
    let (_dir, profile, library) = two_files();
    let out = sipnpuff(&["config", "--config", s(&profile), "--config", s(&library)]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_exit(out.status, &stderr, 0, "config with two files");
    let text = String::from_utf8(out.stdout).unwrap();
    for line in [
        format!("puff_threshold_volts = 2.81  # from {}", s(&profile)),
        format!("long_burst_ms = 470  # from {}", s(&profile)),
        format!("sequence_timeout_ms = 1200  # from {}", s(&library)),
        "glitch_ms = 5  # built-in".to_string(),
        format!(
            "[[sequence]]  # short puff, short puff: open (puff) / close (sip) the fingers (from {})",
            s(&library)
        ),
    ] {
        assert!(
            text.lines().any(|l| l == line),
            "no line {line:?} in\n{text}"
        );
    }
    assert_eq!(text.matches("[[sequence]]").count(), 2, "{text}");
    // Read back (the comments are comments), it is the same setup.
    let printed = Config::from_toml_str(&text).unwrap();
    let layered = Layered::read(&[profile, library]).unwrap();
    assert_eq!(&printed, layered.config());
}

#[test]
fn config_diff_says_which_file_each_change_came_from() {
    let (dir, _, _) = two_files();
    // Named as a clinician types them, from the folder that holds them.
    let out = crate::common::sipnpuff()
        .current_dir(dir.join(""))
        .args([
            "config",
            "--config",
            "profile.toml",
            "--config",
            "library.toml",
            "--diff",
        ])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_exit(out.status, &stderr, 0, "config --diff with two files");
    let text = String::from_utf8(out.stdout).unwrap();
    assert_eq!(
        text,
        "\
profile.toml, then library.toml: changes from default
key                                default    value      from          reason
---------------------------------  ---------  ---------  ------------  -----------------------------
detector.puff_threshold_volts      3.0 V      2.81 V     profile.toml  midway between the rest noise
                                                                       and your weakest short puff
detector.long_burst_ms             500 ms     470 ms     profile.toml
matcher.sequence_timeout_ms        1000 ms    1200 ms    library.toml  she pauses between the
                                                                       breaths of a sequence
sequence                           9 entries  2 entries  library.toml  her own library: two entries
sequence #1 (fingers)              [1, -1]    [-1, -1]   library.toml
sequence #2 (Home: call_for_help)  none       [2, 2]     library.toml
sequence (translate_x)             [-1, -1]   none       library.toml
sequence (translate_y)             [-1, 1]    none       library.toml
sequence (translate_z)             [1, 1]     none       library.toml
sequence (rotate_x)                [-2, -1]   none       library.toml
sequence (rotate_y)                [-2, 1]    none       library.toml
sequence (rotate_z)                [-2, -2]   none       library.toml
sequence (save_point)              [2, -1]    none       library.toml
sequence (goto_point)              [2, 1]     none       library.toml
sequences: 1 short sip, 2 long sip, -1 short puff, -2 long puff
"
    );
}

#[test]
fn problems_in_two_files_are_named_by_file_and_line_all_at_once() {
    let dir = Scratch::new();
    let (first, second) = (dir.join("first.toml"), dir.join("second.toml"));
    std::fs::write(&first, "[detector]\nmin_burst_ms = 40\nmin_burts_ms = 50\n").unwrap();
    std::fs::write(
        &second,
        "# the second file\n[matcher]\nsequence_timeout_ms = 0\ntimeout_typo = 3\n",
    )
    .unwrap();
    let out = sipnpuff(&["run", "--config", s(&first), "--config", s(&second)]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_exit(out.status, &stderr, 2, "run with two bad files");
    let known = "(known: neutral_volts, puff_threshold_volts, sip_threshold_volts, hysteresis_volts, min_burst_ms, long_burst_ms, glitch_ms, neutral_tracking_ms, fault_margin_volts, fault_recovery_ms, stale_ms, max_hold_ms, rezero_ms, sip_hysteresis_volts)";
    assert!(
        stderr.contains(&format!(
            "3 problems in the configuration:\n  - {first}:3:1: detector.min_burts_ms: unknown key {known}\n  - {second}:3:1: matcher.sequence_timeout_ms: must be greater than 0 ms\n  - {second}:4:1: matcher.timeout_typo: unknown key (known: sequence_timeout_ms)\n",
            first = s(&first),
            second = s(&second),
        )),
        "{stderr}"
    );
    // A check across the merged files names the file that set the key.
    std::fs::write(&first, "[detector]\nmin_burst_ms = 40\n").unwrap();
    std::fs::write(&second, "\n[matcher]\nsequence_timeout_ms = 0\n").unwrap();
    let out = sipnpuff(&["config", "--config", s(&first), "--config", s(&second)]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_exit(
        out.status,
        &stderr,
        2,
        "config with a bad value in the second",
    );
    assert!(
        stderr.contains(&format!(
            "1 problem in the configuration:\n  - {}:3:1: matcher.sequence_timeout_ms: must be greater than 0 ms\n",
            s(&second)
        )),
        "{stderr}"
    );
    // A file that is not there is named with the others.
    let missing = dir.join("missing.toml");
    let out = sipnpuff(&["config", "--config", s(&first), "--config", s(&missing)]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_exit(out.status, &stderr, 2, "config with a missing file");
    assert!(
        stderr.contains(&format!("  - {}: cannot read it:", s(&missing))),
        "{stderr}"
    );
}

#[test]
fn every_command_that_takes_config_takes_it_twice() {
    let (_dir, profile, library) = two_files();
    let dir = Scratch::new();
    let csv = dir.join("s.csv");
    let generated = sipnpuff(&[
        "generate",
        "--config",
        s(&profile),
        "--config",
        s(&library),
        "--sequences",
        "-1,-1 2,2",
        "--out",
        s(&csv),
    ]);
    let stderr = String::from_utf8_lossy(&generated.stderr);
    assert_exit(generated.status, &stderr, 0, "generate with two files");
    let replayed = sipnpuff(&[
        "replay",
        s(&csv),
        "--config",
        s(&profile),
        "--config",
        s(&library),
    ]);
    let stderr = String::from_utf8_lossy(&replayed.stderr);
    assert_exit(replayed.status, &stderr, 0, "replay with two files");
    let events = String::from_utf8(replayed.stdout).unwrap();
    let matched: Vec<&str> = events.lines().filter(|l| l.contains("\"match\"")).collect();
    assert_eq!(matched.len(), 2, "{events}");
    assert!(matched[0].contains("fingers"), "{}", matched[0]);
    assert!(matched[1].contains("call_for_help"), "{}", matched[1]);
    // The designer analyses the setup's library: the later file's.
    let checked = sipnpuff(&[
        "design",
        "--check",
        "--config",
        s(&profile),
        "--config",
        s(&library),
    ]);
    let stderr = String::from_utf8_lossy(&checked.stderr);
    assert_exit(checked.status, &stderr, 0, "design --check with two files");
    let report = String::from_utf8(checked.stdout).unwrap();
    assert!(
        report.starts_with(&format!("the library of {} analysed for: ", s(&library))),
        "{report}"
    );
    assert_eq!(report.matches("| fingers |").count(), 1, "{report}");
}
