//! The virtual keyboard's key table against the evdev crate's names: every
//! key a chord may name is the Linux key its name says, so the table
//! cannot drift from `linux/input-event-codes.h`.

use std::str::FromStr;

use evdev::KeyCode;
use sipnpuff::control::keys::KEYS;

/// The evdev constant a config name stands for: `KEY_` and the name in
/// capitals, but for the modifiers (the left-hand ones; AltGr is the right
/// Alt) and PrintScreen (whose Linux name is SysRq).
fn constant(name: &str) -> String {
    match name {
        "ctrl" => "KEY_LEFTCTRL".to_owned(),
        "shift" => "KEY_LEFTSHIFT".to_owned(),
        "alt" => "KEY_LEFTALT".to_owned(),
        "super" => "KEY_LEFTMETA".to_owned(),
        "altgr" => "KEY_RIGHTALT".to_owned(),
        "print" => "KEY_SYSRQ".to_owned(),
        _ => format!("KEY_{}", name.to_ascii_uppercase()),
    }
}

#[test]
fn every_key_is_the_linux_key_its_name_says() {
    let mut wrong = Vec::new();
    for key in KEYS {
        let want = constant(key.name);
        match KeyCode::from_str(&want) {
            Ok(code) if code.code() == key.code => {}
            Ok(code) => wrong.push(format!(
                "{} has code {}, {want} is {}",
                key.name,
                key.code,
                code.code()
            )),
            Err(_) => wrong.push(format!("{}: evdev has no {want}", key.name)),
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
    // Spot checks of the rule itself.
    assert_eq!(constant("ctrl"), "KEY_LEFTCTRL");
    assert_eq!(KeyCode::from_str("KEY_LEFTCTRL").unwrap().code(), 29);
    assert_eq!(KeyCode::from_str("KEY_T").unwrap().code(), 20);
    assert_eq!(
        KEYS.iter().find(|k| k.name == "t").map(|k| k.code),
        Some(20)
    );
    assert_eq!(KEYS.len(), 88);
}
