//! The live calibration (`sipnpuff fit` without `--from`) through the real
//! binary: the built-in synthetic user breathes the protocol in time with
//! the prompts through the real 1 kHz loop; the session is guided to its
//! end, recorded, fitted, and its profile written where the defaults say;
//! the profile is a configuration `config` reads; the recording fits again
//! with `fit --from` to the same settings and the same report; the control
//! thread allocated nothing. Ctrl-C stops a session, keeps its recording
//! and writes nothing. In headless Chromium the page follows the session:
//! each prompt's words and count, then the summary.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use serde_json::Value;

use crate::common::{self, Running, free_port};
use crate::display_browser::{Browser, browser_test, wait_for_page};
use crate::scratch::Scratch;

/// Breaths per block in these sessions (the shortest `--count`): about
/// 40 s of session.
const COUNT: u32 = 3;

/// The prompts of a session of [`COUNT`] breaths per block, in order, as
/// the page shows them: ("short puff — now", "1 of 3"), …
fn expected_prompts() -> Vec<(String, String)> {
    let mut prompts = Vec::new();
    for ask in ["short puff", "long puff", "short sip", "long sip"] {
        for n in 1..=COUNT {
            prompts.push((format!("{ask} — now"), format!("{n} of {COUNT}")));
        }
    }
    prompts
}

/// The settings of a profile: its lines that are not comments.
fn settings(profile: &Path) -> Vec<String> {
    std::fs::read_to_string(profile)
        .unwrap_or_else(|e| panic!("{}: {e}", profile.display()))
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(String::from)
        .collect()
}

/// The control thread's heap allocations, from a recording's report.
fn control_thread_allocations(recording: &Path) -> u64 {
    let text = std::fs::read_to_string(recording.join("report.json")).unwrap();
    let report: Value = serde_json::from_str(&text).unwrap();
    report["control_thread_allocations"]
        .as_u64()
        .unwrap_or_else(|| panic!("no allocation count in {report}"))
}

/// The blocks a guided session's recording says it followed
/// (`calibration.json`): what each asked for.
fn protocol_followed(recording: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(recording.join("calibration.json")).unwrap();
    let protocol: Value = serde_json::from_str(&text).unwrap();
    protocol["blocks"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| {
            assert!(b["count"].as_u64().unwrap() >= 3, "{b}");
            b["ask"].as_str().unwrap().to_string()
        })
        .collect()
}

/// Runs `sipnpuff` with `args` to its end; (status, stdout, stderr).
fn sipnpuff(args: &[&str]) -> (std::process::ExitStatus, String, String) {
    let mut command = common::sipnpuff();
    command.args(args);
    let out = crate::watchdog::output(&mut command);
    (
        out.status,
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn a_live_session_is_guided_recorded_and_fitted_and_its_recording_fits_again_alike() {
    common::real_time(|| {
        let dir = Scratch::new();
        // The defaults: the synthetic user, the session's directory and
        // its profile in the current directory.
        let mut command = common::sipnpuff();
        command
            .args(["fit", "--count", &COUNT.to_string()])
            .current_dir(&*dir);
        let (status, lines, stderr) = Running::start(command).finish();
        assert!(status.success(), "{status}\n{stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");

        // The prompts, in order, one line each, none repeated, nothing
        // refused: the synthetic user follows them.
        let prompts: Vec<&String> = lines.iter().filter(|l| l.contains(" — now (")).collect();
        let expected: Vec<String> = expected_prompts()
            .into_iter()
            .map(|(words, count)| format!("{words} ({count})"))
            .collect();
        assert_eq!(prompts, expected.iter().collect::<Vec<_>>(), "{lines:#?}");
        let counted = lines
            .iter()
            .filter(|l| l.starts_with("  counted: "))
            .count();
        assert_eq!(counted, 4 * COUNT as usize);
        assert!(lines[0].starts_with("rest, please"), "{lines:#?}");
        for refused in [
            "that was a",
            "wait for the prompt",
            "once more",
            "the session stops",
        ] {
            assert!(!lines.iter().any(|l| l.contains(refused)), "{lines:#?}");
        }

        // The session's directory, by default `fit-user-DATE`, with the
        // profile in it.
        let sessions: Vec<PathBuf> = std::fs::read_dir(&*dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        let [recording] = &sessions[..] else {
            panic!("one session directory expected: {sessions:?}");
        };
        let name = recording.file_name().unwrap().to_str().unwrap();
        assert!(name.starts_with("fit-user-20"), "{name}");
        assert!(
            stderr.contains(&format!("the session is recorded in {name}")),
            "{stderr}"
        );
        let profile = recording.join("profile.toml");
        assert!(
            stderr.contains(&format!("wrote the profile to {name}/profile.toml")),
            "{stderr}"
        );
        assert_eq!(control_thread_allocations(recording), 0);
        assert_eq!(
            protocol_followed(recording),
            ["short puff", "long puff", "short sip", "long sip"]
        );

        // The profile is a configuration.
        let (status, _, stderr) = sipnpuff(&["config", "--config", profile.to_str().unwrap()]);
        assert!(status.success(), "{stderr}");
        let fitted = settings(&profile);
        assert!(
            fitted.iter().any(|l| l.starts_with("puff_threshold_volts")),
            "{fitted:?}"
        );

        // The recording fits again to the same settings, with the same
        // report.
        let again = dir.join("again.toml");
        let (status, report, stderr) = sipnpuff(&[
            "fit",
            "--from",
            recording.to_str().unwrap(),
            "--count",
            &COUNT.to_string(),
            "--out",
            again.to_str().unwrap(),
        ]);
        assert!(status.success(), "{stderr}");
        assert_eq!(settings(&again), fitted);
        let live = lines.join("\n") + "\n";
        assert!(
            live.ends_with(&report),
            "the live report differs from --from's:\n{live}\n---\n{report}"
        );
        assert!(report.contains("read right"), "{report}");
    });
}

#[test]
fn ctrl_c_stops_a_live_session_keeps_its_recording_and_writes_nothing() {
    common::real_time(|| {
        let dir = Scratch::new();
        let recording = dir.join("session");
        let profile = dir.join("profile.toml");
        let mut run = Running::spawn(&[
            "fit",
            "--record",
            recording.to_str().unwrap(),
            "--out",
            profile.to_str().unwrap(),
        ]);
        run.wait_for("short puff — now (1 of 8)");
        run.signal(libc::SIGINT);
        let (status, _, stderr) = run.finish();
        assert_eq!(status.code(), Some(130), "{stderr}");
        assert!(stderr.contains("interrupted (SIGINT)"), "{stderr}");
        assert!(
            stderr.contains(&format!(
                "no profile written; the session so far is kept in {}",
                recording.display()
            )),
            "{stderr}"
        );
        assert!(!profile.exists());
        assert_eq!(protocol_followed(&recording).len(), 4);
        // The recording is whole: it replays.
        let (status, _, stderr) = sipnpuff(&["replay", recording.to_str().unwrap()]);
        assert!(status.success(), "{stderr}");
        assert_eq!(control_thread_allocations(&recording), 0);
    });
}

/// The page's calibration view, as the user reads it.
const SHOWN: &str = r##"
const text = (id) => document.getElementById(id).textContent;
const rows = Array.from(document.querySelectorAll("#fit-changes tr")).slice(1);
return {
  view: document.body.dataset.view,
  phase: document.body.dataset.fitPhase || "",
  banner: text("banner-text"),
  headline: text("fit-headline"),
  count: text("fit-count"),
  block: text("fit-block"),
  message: text("fit-message"),
  progress: text("fit-progress-text"),
  profile: text("fit-profile"),
  problem: text("fit-problem"),
  read: text("fit-read"),
  recording: text("fit-recording"),
  changed: rows.map((r) => Array.from(r.children).map((c) => c.textContent)),
  cues: window.sipnpuff.cues.map((c) => c.cue),
  ended: !!window.sipnpuff.ended,
};
"##;

fn text(value: &Value) -> &str {
    value.as_str().unwrap_or_default()
}

#[test]
fn a_live_session_in_a_real_browser_shows_each_prompt_its_count_and_the_summary() {
    browser_test(|| {
        let dir = Scratch::new();
        let recording = dir.join("session");
        let profile = dir.join("profile.toml");
        // The browser first: its start-up must not eat into the session.
        let browser = Browser::start();
        let port = free_port();
        let mut command = Command::new(env!("CARGO_BIN_EXE_sipnpuff"));
        command
            .args([
                "fit",
                "--count",
                &COUNT.to_string(),
                "--record",
                recording.to_str().unwrap(),
                "--out",
                profile.to_str().unwrap(),
                "--display",
                &format!("127.0.0.1:{port}"),
            ])
            .env_remove("SIPNPUFF_NO_DISPLAY");
        let run = Running::start(command);
        wait_for_page(port);
        browser.open(&format!("http://127.0.0.1:{port}/"));

        // Follow the page to the summary: every prompt shown, in order,
        // with its count; the messages seen on the way.
        let mut prompts: Vec<(String, String)> = Vec::new();
        let mut blocks: Vec<String> = Vec::new();
        let mut messages: Vec<String> = Vec::new();
        let mut shot = false;
        let started = Instant::now();
        let summary = loop {
            let shown = browser.eval(SHOWN);
            assert_eq!(shown["view"], "fit", "{shown:#}");
            let phase = text(&shown["phase"]);
            if phase == "summary" {
                break shown;
            }
            assert_ne!(phase, "stopped", "{shown:#}");
            if phase == "prompt" {
                let prompt = (
                    text(&shown["headline"]).to_string(),
                    text(&shown["count"]).to_string(),
                );
                if !shot && prompt.0 == "long puff — now" && prompt.1 == "2 of 3" {
                    browser.screenshot("fit-prompt");
                    shot = true;
                }
                if prompts.last() != Some(&prompt) {
                    prompts.push(prompt);
                }
                let block = text(&shown["block"]).to_string();
                if blocks.last() != Some(&block) {
                    blocks.push(block);
                }
            }
            let message = text(&shown["message"]).to_string();
            if messages.last() != Some(&message) {
                messages.push(message);
            }
            assert!(
                started.elapsed() < Duration::from_secs(150),
                "no summary; the page showed {shown:#}"
            );
            std::thread::sleep(Duration::from_millis(25));
        };
        assert_eq!(prompts, expected_prompts());
        assert_eq!(
            blocks,
            [
                "block 1 of 4: 3 short puffs",
                "block 2 of 4: 3 long puffs",
                "block 3 of 4: 3 short sips",
                "block 4 of 4: 3 long sips"
            ]
        );
        assert!(
            messages
                .iter()
                .any(|m| m.starts_with("rest, please: no sip or puff")),
            "{messages:?}"
        );
        assert!(messages.iter().any(|m| m == "got it"), "{messages:?}");
        browser.screenshot("fit-summary");
        let (status, _, stderr) = run.finish();
        assert!(status.success(), "{status}\n{stderr}");

        // The summary: the profile written, the breaths read right as
        // the profile's header says, each setting changed against its
        // value now; the page keeps it after the server has gone.
        assert_eq!(summary["banner"], "Fitted");
        assert_eq!(
            text(&summary["profile"]),
            format!("Profile written: {}", profile.display())
        );
        assert_eq!(text(&summary["problem"]), "");
        let header = std::fs::read_to_string(&profile).unwrap();
        let replayed = header
            .lines()
            .find_map(|l| l.strip_prefix("# the calibration replayed: "))
            .expect("the profile's replay line");
        // "12/12 vs 10/12 breaths read right"
        let counts: Vec<&str> = replayed
            .split(|c: char| !c.is_ascii_digit())
            .filter(|s| !s.is_empty())
            .collect();
        let [proposed, asked, current, _] = counts[..] else {
            panic!("{replayed}");
        };
        assert_eq!(asked, (4 * COUNT).to_string());
        assert_eq!(
            text(&summary["read"]),
            format!(
                "Breaths read right: {proposed} of {asked} with the proposed settings, {current} of {asked} with the current ones"
            )
        );
        let fitted = settings(&profile);
        let changed = summary["changed"].as_array().unwrap();
        assert!(!changed.is_empty(), "{summary:#}");
        for row in changed {
            let key = text(&row[0]);
            let proposed = text(&row[2]);
            let (_, name) = key.split_once('.').unwrap();
            assert!(
                fitted.contains(&format!("{name} = {proposed}")),
                "{key} = {proposed} is not in the profile: {fitted:?}"
            );
        }
        assert_eq!(
            text(&summary["recording"]),
            format!("The session is recorded in {}", recording.display())
        );
        let after = browser.eval(SHOWN);
        assert_eq!(after["phase"], "summary", "{after:#}");
        assert_eq!(after["ended"], true);
        let cues: Vec<&str> = after["cues"].as_array().unwrap().iter().map(text).collect();
        let prompt_cues = cues.iter().filter(|c| **c == "prompt").count();
        assert!(prompt_cues >= 4 * COUNT as usize - 1, "{cues:?}");
        assert!(cues.contains(&"done"), "{cues:?}");
    });
}
