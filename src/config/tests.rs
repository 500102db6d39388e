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
        c.core().sequences()[0].actions.as_slice(),
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
        all.contains("\"modbus\" is not a format (known: volts, counts, flipmouse, lipsync)"),
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

/// Each problem of `text` as `key: message`, in the order reported.
fn problems(text: &str) -> Vec<String> {
    Config::from_toml_str(text)
        .unwrap_err()
        .0
        .iter()
        .map(|e| format!("{}: {}", e.key, e.message))
        .collect()
}

#[test]
fn a_problem_inside_the_arm_table_names_its_own_key() {
    // `[arm]` holds the keys of three types; serde names only the table.
    let text = "[arm]\nhome_fingers = \"open\"\ncolour = 1\n[arm.ros2]\nmessage = \"twist\"\ndomian_id = 1\n";
    assert_eq!(
        problems(text),
        [
            "arm.home_fingers: wrong type (string): invalid type: string \"open\", expected f64",
            "arm.colour: unknown key (known: home_position_m, home_rotation_vector_rad, home_fingers, feedback, connect_timeout_ms, ros2, ros1, kinova_sdk)",
            "arm.ros2.message: \"twist\" is not a message (known: twist_stamped, pose_velocity, pose_velocity_with_finger_velocity)",
            "arm.ros2.domian_id: unknown key (known: message, frame_id, pose_topic, domain_id)",
        ]
    );
}

#[test]
fn entries_that_fire_actions_are_checked_all_at_once() {
    let text = "[[sequence]]\nactions = [1]\nkey = \"ctrl+hyper\"\n\
                    [[sequence]]\nactions = [-1]\nevent = \"lights_toggle\"\n\
                    [[sequence]]\nactions = [-2]\nevent = \"lights_toggle\"\n\
                    [[sequence]]\nactions = [1, 1]\nclick = \"middle\"\n\
                    [[sequence]]\nactions = [2]\nmode = \"scroll\"\n";
    assert_eq!(
        problems(text),
        [
            "sequence #1.key: \"ctrl+hyper\" cannot be typed: `hyper` is not a key the virtual keyboard can type (keys: a–z, 0–9, f1–f12, enter, space, tab, esc, arrows, media keys…; modifiers ctrl, shift, alt, super, altgr)",
            "sequence #3.event: \"lights_toggle\" is used twice: each home event has one sequence",
            "sequence #4.click: \"middle\" is not a click (known: left, right, double)",
        ]
    );
    let good = "[[sequence]]\nactions = [1]\nkey = \"ctrl+alt+t\"\n\
                    [[sequence]]\nactions = [2]\nmode = \"drag\"\n";
    let config = Config::from_toml_str(good).unwrap();
    let printed = config.to_toml().unwrap();
    assert!(printed.contains("key = \"ctrl+alt+t\""), "{printed}");
    assert_eq!(Config::from_toml_str(&printed).unwrap(), config);
}

#[test]
fn every_missing_key_of_an_entry_is_named_and_a_wrong_entry_is_not_compared() {
    // Entry 2's actions are wrong and entry 3 has none: the built-in
    // actions standing in for them ([-1, -1], as entry 1's) are not
    // reported as listed twice.
    let text = "[[sequence]]\nactions = [-1, -1]\nmode = \"fingers\"\n[[sequence]]\nactions = [9]\nmode = \"rotate_x\"\n[[sequence]]\nspeed = 1\n";
    assert_eq!(
        problems(text),
        [
            "sequence #2.actions: 9 not an action (1 = short sip, 2 = long sip, -1 = short puff, -2 = long puff)",
            "sequence #3.actions: missing",
            "sequence #3: says nothing to do: give one of `mode`, `key`, `click`, `event`",
            "sequence #3.speed: unknown key (known: actions, mode, key, click, event)",
        ]
    );
}

#[test]
fn a_value_of_the_wrong_kind_says_what_was_expected() {
    let text = "detector = 3\nsequence = [1, { actions = [1], mode = \"fingers\" }]\n[scanning]\norder = [\"fingers\", 2]\n";
    assert_eq!(
        problems(text),
        [
            "detector: must be a table, found integer",
            "sequence #1: must be a table, found integer",
            "scanning.order: wrong type (array): invalid type: integer `2`, expected a string",
        ]
    );
    assert_eq!(
        problems("sequence = 3\n"),
        ["sequence: must be an array of tables ([[sequence]]), found integer"]
    );
}

#[test]
fn every_printed_key_is_read_and_named_when_wrong() {
    // Each key `sipnpuff config` prints, given a table instead of its
    // value, is the one problem, named in full.
    let printed = Config::default().to_toml().unwrap();
    let lines: Vec<&str> = printed.lines().collect();
    let (mut table, mut entries) = (String::new(), 0);
    for (at, line) in lines.iter().enumerate() {
        if let Some(header) = line.strip_prefix("[[") {
            entries += 1;
            table = format!("{} #{entries}", &header[..header.find("]]").unwrap()]);
            continue;
        }
        if let Some(header) = line.strip_prefix('[') {
            table = header.trim_end_matches(']').to_string();
            continue;
        }
        let Some((key, _)) = line.split_once(" = ") else {
            continue;
        };
        let mut wrong = lines.clone();
        let replaced = format!("{key} = {{ wrong = 1 }}");
        wrong[at] = &replaced;
        let found = problems(&wrong.join("\n"));
        assert_eq!(found.len(), 1, "{table}.{key}: {found:?}");
        assert!(
            found[0].starts_with(&format!("{table}.{key}: wrong type (table): ")),
            "{table}.{key}: {found:?}"
        );
    }
    assert_eq!(entries, 9);
}

#[test]
fn the_ethernet_and_timeout_keys_are_read_and_checked() {
    let c = Config::from_toml_str(
        "[arm.kinova_sdk]\nserial_number = \"PJ1\"\nrobot_ip = \"10.0.0.2\"\nrobot_port = 4000\n",
    )
    .unwrap();
    let sdk = &c.arm().kinova_sdk;
    assert_eq!(
        (sdk.serial_number.as_str(), sdk.robot_ip.as_str()),
        ("PJ1", "10.0.0.2")
    );
    assert_eq!((sdk.robot_port, sdk.local_cmd_port), (4000, 25000));
    let errors = Config::from_toml_str(
        "[arm.kinova_sdk]\nlocal_ip = \"10.0.0\"\nrobot_port = 0\ncall_timeout_ms = 0\n",
    )
    .unwrap_err()
    .0;
    let keys: Vec<&str> = errors.iter().map(|e| e.key.as_str()).collect();
    for key in [
        "arm.kinova_sdk.local_ip",
        "arm.kinova_sdk.robot_port",
        "arm.kinova_sdk.call_timeout_ms",
    ] {
        assert!(keys.contains(&key), "{key} in {keys:?}");
    }
}
