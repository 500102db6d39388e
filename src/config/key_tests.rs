//! Each table's keys read and, when wrong, named with their own key: the
//! arm's tables, the entries that fire actions, values of the wrong kind,
//! every key the configuration prints.

use super::*;

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

#[test]
fn an_unknown_key_lists_the_optional_keys_too() {
    assert_eq!(
        problems("[output.mqtt]\nhost = \"broker\"\ncolour = 1\n"),
        [
            "output.mqtt.colour: unknown key (known: host, port, prefix, credentials_file, tls, device_id, max_delay_ms)"
        ]
    );
}
