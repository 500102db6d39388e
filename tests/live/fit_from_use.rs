//! Re-fitting from ordinary use: a real run's recording of a slow breather
//! using a profile fitted to a typical one, fitted again (`fit --from`).

use sipnpuff::config::Config;

use crate::common::sipnpuff_output as sipnpuff;
use crate::scratch::Scratch;

/// Ordinary use, recorded by a real run: a slow breather uses the
/// interface with a profile fitted to a typical one. `fit --from DIR`
/// splits their breaths into their own short and long, says how far they
/// drifted from the profile's, and proposes their boundary.
#[test]
fn a_recording_of_ordinary_use_is_fitted_and_its_drift_said() {
    let dir = Scratch::new();
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    let (calibration, profile) = (dir.join("typical.csv"), dir.join("typical.toml"));
    let (practice, recording) = (dir.join("slow.csv"), dir.join("rec"));
    for args in [
        vec![
            "generate",
            "--protocol",
            "--breather",
            "typical",
            "--out",
            &s(&calibration),
        ],
        vec![
            "generate",
            "--breather",
            "slow",
            "--seconds",
            "40",
            "--seed",
            "4",
            "--out",
            &s(&practice),
        ],
        vec!["fit", "--from", &s(&calibration), "--out", &s(&profile)],
    ] {
        let out = sipnpuff(&args);
        assert!(
            out.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    crate::common::real_time(|| {
        // A retry on a starved machine records afresh.
        let _ = std::fs::remove_dir_all(&recording);
        let sensor = format!("csv:{}", s(&practice));
        let out = sipnpuff(&[
            "run",
            "--sensor",
            &sensor,
            "--config",
            &s(&profile),
            "--record",
            &s(&recording),
            "--no-display",
        ]);
        let stdout = String::from_utf8_lossy(&out.stdout);
        let tail: Vec<&str> = stdout.lines().rev().take(30).collect();
        assert!(
            out.status.success(),
            "{}: {}\nthe last lines of its stdout, last first:\n{}",
            out.status,
            String::from_utf8_lossy(&out.stderr),
            tail.join("\n")
        );
    });
    let refit = dir.join("refit.toml");
    let out = sipnpuff(&[
        "fit",
        "--from",
        &s(&recording),
        "--config",
        &s(&profile),
        "--out",
        &s(&refit),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(stderr.contains("a session of ordinary use"), "{stderr}");
    // Slow long breaths of 1500 ms against the typical 800 ms.
    assert!(stderr.contains("drift: your long puffs are"), "{stderr}");
    assert!(stderr.contains("longer than at fitting"), "{stderr}");
    let fitted = Config::from_file(&refit).unwrap();
    let long = fitted.core().detector().long_burst_ms;
    assert!(
        (500..=1000).contains(&long),
        "short 400 ms, long 1500 ms: {long}"
    );
}
