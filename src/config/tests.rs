//! The whole configuration read, checked and reported: every error at once
//! with its key and line, the sensor, arm and output tables, the setters.

use super::*;
use crate::control::action::{Action, Breath, MAX_SEQUENCE_LEN};
use crate::control::mode::Mode;

fn errors(text: &str) -> Vec<ConfigError> {
    Config::from_toml_str(text).unwrap_err().0
}

fn keys(text: &str) -> Vec<String> {
    errors(text).into_iter().map(|e| e.key).collect()
}

#[test]
fn empty_file_is_the_default() {
    assert_eq!(Config::from_toml_str("").unwrap(), Config::default());
}

#[test]
fn a_uinput_name_of_79_bytes_is_refused() {
    // The kernel would keep 79, but evdev's builder panics on it.
    let named = |n: usize| format!("[output.uinput]\nname = \"{}\"\n", "x".repeat(n));
    assert_eq!(
        Config::from_toml_str(&named(78))
            .unwrap()
            .output()
            .uinput
            .name
            .len(),
        78
    );
    let e = errors(&named(79));
    let found: Vec<(&str, &str)> = e
        .iter()
        .map(|e| (e.key.as_str(), e.message.as_str()))
        .collect();
    assert_eq!(found, [("output.uinput.name", "79 bytes: at most 78 fit")]);
}

#[test]
fn the_scanning_interface_and_its_errors() {
    let c = Config::from_toml_str(
        r#"
            [interface]
            kind = "bsp"
            [scanning]
            dwell_ms = 1000
            first_dwell_ms = 2500
            order = ["fingers", "translate_x"]
            "#,
    )
    .unwrap();
    assert_eq!(c.core().interface(), Interface::Bsp);
    assert_eq!(c.core().scanning().dwell_ms, 1000);
    assert_eq!(c.core().scanning().first_dwell_ms, 2500);
    assert_eq!(
        c.core().scanning().modes(),
        [Mode::Fingers, Mode::TranslateX]
    );
    let e = errors(
        r#"
            [interface]
            kind = "scan"
            [scanning]
            dwell_ms = 0
            order = ["fingers", "fly", "fingers"]
            speed = 1
            "#,
    );
    let found: Vec<(&str, &str)> = e
        .iter()
        .map(|e| (e.key.as_str(), e.message.as_str()))
        .collect();
    // In file order: by line within a section.
    assert_eq!(
        found,
        [
            ("interface.kind", "\"scan\" is not `asp` or `bsp`"),
            ("scanning.dwell_ms", "must be greater than 0 ms"),
            (
                "scanning.order",
                "\"fly\" is not a mode (known: translate_x, translate_y, translate_z, rotate_x, rotate_y, rotate_z, fingers, save_point, goto_point)"
            ),
            ("scanning.order", "\"fingers\" appears twice"),
            (
                "scanning.speed",
                "unknown key (known: dwell_ms, first_dwell_ms, order)"
            ),
        ]
    );
}

#[test]
fn issue_example_parses() {
    let c = Config::from_toml_str(
        r#"
            [detector]
            neutral_volts = 2.5
            puff_threshold_volts = 3.0
            sip_threshold_volts = 2.0
            hysteresis_volts = 0.1
            min_burst_ms = 40
            long_burst_ms = 500

            [matcher]
            sequence_timeout_ms = 1000

            [command]
            inactivity_timeout_ms = 2000

            [[sequence]]
            actions = [1, 1]
            mode = "translate_x"
            "#,
    )
    .unwrap();
    assert_eq!(c.core().sequences().len(), 1);
    assert_eq!(
        c.core().sequences()[0].target.mode(),
        Some(Mode::TranslateX)
    );
    assert_eq!(
        c.core().sequences()[0].breaths().unwrap().as_slice(),
        &[Action::ShortSip, Action::ShortSip]
    );
    assert_eq!(c.core().matcher().sequence_timeout_ms, 1000);
}

#[test]
fn integer_volts_are_accepted() {
    let c = Config::from_toml_str("[detector]\npuff_threshold_volts = 4\n").unwrap();
    assert_eq!(c.core().detector().puff_threshold_volts, 4.0);
}

#[test]
fn sensor_settings_are_read_and_every_error_named_with_its_line() {
    let c = Config::from_toml_str(
        r#"
            [sensor]
            reconnect = true
            [sensor.evdev]
            input = "switches"
            sip_keys = ["BTN_TRIGGER", "BTN_TRIGGER_HAPPY1"]
            puff_keys = ["KEY_ENTER"]
            [sensor.serial]
            format = "lipsync"
            volts_per_hpa = 0.1
            [sensor.iio]
            gain = 1.5151515151515151
            "#,
    )
    .unwrap();
    let s = c.sensor();
    assert!(s.reconnect && s.rezero);
    assert_eq!(s.evdev.input, crate::sensor::settings::EvdevInput::Switches);
    assert_eq!(s.evdev.sip_keys, ["BTN_TRIGGER", "BTN_TRIGGER_HAPPY1"]);
    assert_eq!(
        s.serial.format,
        crate::sensor::settings::SerialFormat::Lipsync
    );
    assert_eq!(s.iio.gain, 1.5151515151515151);
    let text = r#"[sensor]
rezero_ms = 0
rezero_max_shift_fraction = 1.5
colour = 1
[sensor.evdev]
input = "joystick"
axis = "ABS_PRESSURE_X"
sip_keys = ["BTN_SIP"]
puff_keys = []
volts_at_max = 0.0
[sensor.serial]
format = "modbus"
baud = 0
[sensor.iio]
rate_hz = 5000
gain = 0
"#;
    let errors = errors(text);
    let found: Vec<(String, Option<usize>)> =
        errors.iter().map(|e| (e.key.clone(), e.line)).collect();
    for (key, line) in [
        ("sensor.colour", 4),
        ("sensor.evdev.input", 6),
        ("sensor.serial.format", 12),
        ("sensor.rezero_ms", 2),
        ("sensor.rezero_max_shift_fraction", 3),
        ("sensor.evdev.volts_at_max", 10),
        ("sensor.evdev.axis", 7),
        ("sensor.evdev.sip_keys", 8),
        ("sensor.serial.baud", 13),
        ("sensor.iio.gain", 16),
        ("sensor.iio.rate_hz", 15),
    ] {
        assert!(
            found.contains(&(key.to_string(), Some(line))),
            "{key} at line {line}: {found:?}"
        );
    }
    let messages: Vec<String> = errors.iter().map(|e| e.to_string()).collect();
    let all = messages.join("\n");
    assert!(
        all.contains("\"ABS_PRESSURE_X\" is not a Linux absolute axis name"),
        "{all}"
    );
    assert!(
        all.contains("[\"BTN_SIP\"]: not Linux key or button names"),
        "{all}"
    );
    assert!(
        all.contains("\"modbus\" is not a format (known: volts, counts, flipmouse, lipsync, imu)"),
        "{all}"
    );
    // `puff_keys = []` only matters for switches.
    assert!(
        !found.iter().any(|(k, _)| k == "sensor.evdev.puff_keys"),
        "{found:?}"
    );
}

#[test]
fn every_error_is_reported_at_once_with_its_key() {
    let e = keys(
        r#"
            colour = "red"
            [detector]
            puff_threshold_volts = 2.0
            sip_threshold_volts = 2.6
            min_burst_ms = 0
            long_burst_ms = "long"
            typo_ms = 3
            [matcher]
            sequence_timeout_ms = -5
            [command]
            inactivity_timeout_ms = 0
            [[sequence]]
            actions = [1, 3]
            mode = "translate_x"
            [[sequence]]
            actions = []
            mode = "dance"
            [[sequence]]
            actions = [1, 1]
            mode = "fingers"
            [[sequence]]
            actions = [1, 1]
            mode = "rotate_z"
            speed = 2
            [[sequence]]
            mode = "rotate_y"
            "#,
    );
    let expected = [
        "detector.long_burst_ms",
        "detector.typo_ms",
        "detector.puff_threshold_volts",
        "detector.sip_threshold_volts",
        "detector.min_burst_ms",
        "detector.glitch_ms",
        "matcher.sequence_timeout_ms",
        "command.inactivity_timeout_ms",
        "sequence #1.actions",
        "sequence #2.actions",
        "sequence #2.mode",
        "sequence #4.speed",
        "sequence #4.actions",
        "sequence #5.actions",
        "colour",
    ];
    for key in expected {
        assert!(e.iter().any(|k| k == key), "no error for {key}: {e:?}");
    }
    assert_eq!(e.len(), expected.len(), "{e:?}");
}

#[test]
fn a_sips_own_hysteresis_lies_inside_the_sip_band() {
    // Puffs 1.0 V from the neutral, sips 0.3 V: each hysteresis inside
    // its own kind's band.
    let text = "[detector]\npuff_threshold_volts = 3.5\nsip_threshold_volts = 2.2\nhysteresis_volts = 0.4\nsip_hysteresis_volts = 0.3\n";
    let e = errors(text);
    assert_eq!(e.len(), 1, "{e:?}");
    assert_eq!(e[0].key, "detector.sip_hysteresis_volts");
    assert_eq!(
        e[0].message,
        "0.3 V must be smaller than the distance from the neutral to the sip threshold (0.300 V)"
    );
    let fine = text.replace("sip_hysteresis_volts = 0.3", "sip_hysteresis_volts = 0.05");
    let config = Config::from_toml_str(&fine).unwrap();
    let d = config.core().detector();
    assert_eq!(
        (d.hysteresis_of(Breath::Puff), d.hysteresis_of(Breath::Sip)),
        (0.4, 0.05)
    );
    // Without its own, 0.4 V would not fit the sips' band.
    let e = errors(&text.replace("sip_hysteresis_volts = 0.3\n", ""));
    assert_eq!(e[0].key, "detector.hysteresis_volts");
}

#[test]
fn messages_say_what_is_wrong() {
    let e = errors(
        "[detector]\nhysteresis_volts = 0.6\n[[sequence]]\nactions = [1, 7]\nmode = \"fingers\"\n",
    );
    assert_eq!(e.len(), 2, "{e:?}");
    assert_eq!(e[0].key, "detector.hysteresis_volts");
    assert!(e[0].message.contains("0.500"), "{}", e[0].message);
    assert_eq!(e[1].key, "sequence #1.actions");
    assert!(
        e[1].message.starts_with("7 not an action"),
        "{}",
        e[1].message
    );
    let text = ConfigErrors(e).to_string();
    assert!(
        text.starts_with("2 problems in the configuration:"),
        "{text}"
    );
}

#[test]
fn max_hold_must_exceed_long_and_min_and_rezero_two_windows() {
    let e = errors("[detector]\nmax_hold_ms = 500\nrezero_ms = 150\n");
    let keys: Vec<_> = e.iter().map(|e| e.key.as_str()).collect();
    assert_eq!(
        keys,
        ["detector.max_hold_ms", "detector.rezero_ms"],
        "{e:?}"
    );
    assert!(
        e[0].message
            .starts_with("500 ms must be greater than detector.long_burst_ms (500 ms)"),
        "{}",
        e[0].message
    );
    assert!(e[1].message.contains("at least 200 ms"), "{}", e[1].message);
    let e = errors("[detector]\nmin_burst_ms = 40\nlong_burst_ms = 30\nmax_hold_ms = 35\n");
    let keys: Vec<_> = e.iter().map(|e| e.key.as_str()).collect();
    assert_eq!(
        keys,
        ["detector.long_burst_ms", "detector.max_hold_ms"],
        "{e:?}"
    );
    assert!(e[1].message.contains("detector.min_burst_ms (40 ms)"));
    assert!(
        errors("[detector]\nmax_hold_ms = 0\n")[0]
            .message
            .contains("greater than 0")
    );
    let c = Config::from_toml_str("[detector]\nmax_hold_ms = 9000\nrezero_ms = 3000\n").unwrap();
    assert_eq!(
        (
            c.core().detector().max_hold_ms,
            c.core().detector().rezero_ms
        ),
        (9000, 3000)
    );
}

#[test]
fn long_must_exceed_min_and_glitch_must_be_shorter() {
    let e = errors("[detector]\nmin_burst_ms = 40\nlong_burst_ms = 40\nglitch_ms = 40\n");
    let keys: Vec<_> = e.iter().map(|e| e.key.as_str()).collect();
    assert_eq!(keys, ["detector.long_burst_ms", "detector.glitch_ms"]);
}

#[test]
fn too_long_sequence_is_rejected() {
    let codes = vec!["1"; MAX_SEQUENCE_LEN + 1].join(", ");
    let e = errors(&format!(
        "[[sequence]]\nactions = [{codes}]\nmode = \"fingers\"\n"
    ));
    assert_eq!(e.len(), 1);
    assert!(e[0].message.contains("at most 16"), "{}", e[0].message);
}

#[test]
fn nan_and_infinite_settings_are_rejected() {
    let e =
        keys("[detector]\nneutral_volts = nan\nhysteresis_volts = nan\nfault_margin_volts = inf\n");
    assert_eq!(
        e,
        [
            "detector.neutral_volts",
            "detector.hysteresis_volts",
            "detector.fault_margin_volts"
        ]
    );
}

#[test]
fn a_syntax_error_names_its_line_and_column() {
    let e = errors("[detector]\nmin_burst_ms = 40\n[detector\n");
    assert_eq!(e.len(), 1);
    assert_eq!((e[0].line, e[0].column), (Some(3), Some(10)), "{}", e[0]);
    assert!(e[0].message.starts_with("not valid TOML"), "{}", e[0]);
    assert!(
        e[0].to_string()
            .starts_with("line 3, column 10: not valid TOML")
    );
}

#[test]
fn errors_name_the_line_of_their_key() {
    let e = errors("[detector]\n\nmin_burst_ms = 0\n[[sequence]]\nactions = [1]\nmode = \"fly\"\n");
    let found: Vec<(&str, Option<usize>)> = e.iter().map(|e| (e.key.as_str(), e.line)).collect();
    assert_eq!(
        found,
        [
            ("detector.min_burst_ms", Some(3)),
            // Left at its default (5 ms), not in the file.
            ("detector.glitch_ms", None),
            ("sequence #1.mode", Some(6)),
        ]
    );
    assert!(
        e[0].to_string()
            .starts_with("line 3, column 1: detector.min_burst_ms: ")
    );
}

#[test]
fn a_file_error_names_the_file() {
    let dir = std::env::temp_dir().join(format!("sipnpuff-config-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bad.toml");
    std::fs::write(&path, "[matcher]\nsequence_timeout_ms = 0\n").unwrap();
    let text = Config::from_file(&path).unwrap_err().to_string();
    assert!(
        text.starts_with(&format!("{}: 1 problem", path.display())),
        "{text}"
    );
    assert!(
        text.contains("line 2, column 1: matcher.sequence_timeout_ms"),
        "{text}"
    );
    let missing = Config::from_file(&dir.join("missing.toml")).unwrap_err();
    assert!(
        missing.to_string().starts_with("cannot read config"),
        "{missing}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn every_with_setter_validates() {
    let c = Config::default();
    let empty = ScanningConfig {
        order_len: 0,
        ..ScanningConfig::default()
    };
    let e = c.clone().with_scanning(empty).unwrap_err().0;
    assert_eq!(e[0].key, "scanning.order");
    assert_eq!(e[0].message, "must list at least one mode");
    let twice = ScanningConfig {
        order: [Mode::Fingers; 9],
        order_len: 2,
        dwell_ms: 0,
        ..ScanningConfig::default()
    };
    let keys: Vec<String> = c
        .clone()
        .with_scanning(twice)
        .unwrap_err()
        .0
        .into_iter()
        .map(|e| format!("{}: {}", e.key, e.message))
        .collect();
    assert_eq!(
        keys,
        [
            "scanning.dwell_ms: must be greater than 0 ms",
            "scanning.order: \"fingers\" appears twice"
        ]
    );
    let too_long = ScanningConfig {
        order_len: 10,
        ..ScanningConfig::default()
    };
    let e = c.clone().with_scanning(too_long).unwrap_err().0;
    assert_eq!(e[0].message, "10 modes, at most 9 (each mode once)");
    assert_eq!(
        c.clone().with_sequences(Vec::new()).unwrap_err().0[0].key,
        "sequence"
    );
    let entry = c.core().sequences()[0];
    let e = c.clone().with_sequences(vec![entry, entry]).unwrap_err().0;
    assert_eq!(e[0].key, "sequence #2.actions");
    assert!(c.clone().with_sequence_timeout_ms(0).is_err());
    let bsp = c.clone().with_interface(Interface::Bsp).unwrap();
    assert_eq!(bsp.core().interface(), Interface::Bsp);
}

#[test]
fn a_mode_may_have_several_sequences() {
    let c = Config::from_toml_str(
        "[[sequence]]\nactions = [1]\nmode = \"fingers\"\n[[sequence]]\nactions = [2]\nmode = \"fingers\"\n",
    )
    .unwrap();
    assert_eq!(c.core().sequences().len(), 2);
}

#[test]
fn the_defaults_pass_validation() {
    let c = Config::default();
    assert_eq!(c.clone().with_sequence_timeout_ms(1000), Ok(c));
}

#[test]
fn an_iio_trigger_without_the_buffer_is_refused_naming_its_line() {
    let found = errors("[sensor.iio]\nrate_hz = 200\ntrigger = \"bmi160-dev0\"\n");
    let keys: Vec<(String, Option<usize>)> =
        found.iter().map(|e| (e.key.clone(), e.line)).collect();
    assert_eq!(keys, [("sensor.iio.trigger".to_string(), Some(3))]);
    assert!(
        found[0].message.contains("only with buffered = true"),
        "{}",
        found[0].message
    );
    assert!(
        Config::from_toml_str("[sensor.iio]\nbuffered = true\ntrigger = \"bmi160-dev0\"\n").is_ok()
    );
}

#[test]
fn rt_priorities_and_cpus_are_read_and_every_error_named_with_its_line() {
    let c = Config::from_toml_str(
        "[rt]\ncontrol_priority = 90\nsensor_priority = 85\narm_priority = 0\ncontrol_cpu = 3\nserving_cpus = [1, 2]\n",
    )
    .unwrap();
    let rt = c.rt();
    assert_eq!(
        (
            rt.control_priority,
            rt.sensor_priority,
            rt.arm_priority,
            rt.output_priority
        ),
        (90, 85, 0, 50)
    );
    assert_eq!(
        (rt.control_cpu, rt.serving_cpus.as_slice()),
        (Some(3), &[1, 2][..])
    );

    let e = errors(
        "[rt]\ncontrol_priority = 50\nsensor_priority = 60\narm_priority = 120\ncontrol_cpu = 1\nserving_cpus = [0, 1]\n",
    );
    let found: Vec<(&str, Option<usize>, &str)> = e
        .iter()
        .map(|e| (e.key.as_str(), e.line, e.message.as_str()))
        .collect();
    assert_eq!(
        found,
        [
            (
                "rt.sensor_priority",
                Some(3),
                "60 is not below control_priority = 50: the control thread must preempt every thread it waits on"
            ),
            (
                "rt.arm_priority",
                Some(4),
                "120: SCHED_FIFO priorities are 1–99 (0: SCHED_OTHER)"
            ),
            (
                "rt.serving_cpus",
                Some(6),
                "CPU 1 is the control thread's (control_cpu): it keeps its CPU to itself"
            ),
            // Not in the file: its default, named all the same.
            (
                "rt.output_priority",
                None,
                "50 is not below control_priority = 50: the control thread must preempt every thread it waits on"
            ),
        ]
    );
    // A control thread at SCHED_OTHER takes every thread with it.
    assert_eq!(
        keys("[rt]\ncontrol_priority = 0\n"),
        [
            "rt.sensor_priority",
            "rt.arm_priority",
            "rt.output_priority"
        ]
    );
    assert!(Config::from_toml_str(
        "[rt]\ncontrol_priority = 0\nsensor_priority = 0\narm_priority = 0\noutput_priority = 0\n"
    )
    .is_ok());
    assert_eq!(keys("[rt]\npriority = 80\n"), ["rt.priority"]);
}
