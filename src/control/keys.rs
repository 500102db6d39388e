//! The keys a library entry may press, by the names people write
//! (`ctrl`, `alt`, `t`, `f5`, `playpause`) and their Linux key codes
//! (`linux/input-event-codes.h`, a stable kernel interface). The virtual
//! keyboard registers exactly these keys, so a chord of them can always be
//! typed.

/// A key: its name in config files, its label on the display, its Linux
/// key code.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Key {
    /// The name in config files, lower case.
    pub name: &'static str,
    /// How the display shows it.
    pub label: &'static str,
    /// The Linux key code (`KEY_*`).
    pub code: u16,
    /// A modifier (held while the others are pressed).
    pub modifier: bool,
}

const fn key(name: &'static str, label: &'static str, code: u16) -> Key {
    Key {
        name,
        label,
        code,
        modifier: false,
    }
}

const fn modifier(name: &'static str, label: &'static str, code: u16) -> Key {
    Key {
        name,
        label,
        code,
        modifier: true,
    }
}

/// Every key a chord may name.
pub const KEYS: &[Key] = &[
    modifier("ctrl", "Ctrl", 29),
    modifier("shift", "Shift", 42),
    modifier("alt", "Alt", 56),
    modifier("super", "Super", 125),
    modifier("altgr", "AltGr", 100),
    key("esc", "Esc", 1),
    key("1", "1", 2),
    key("2", "2", 3),
    key("3", "3", 4),
    key("4", "4", 5),
    key("5", "5", 6),
    key("6", "6", 7),
    key("7", "7", 8),
    key("8", "8", 9),
    key("9", "9", 10),
    key("0", "0", 11),
    key("minus", "-", 12),
    key("equal", "=", 13),
    key("backspace", "Backspace", 14),
    key("tab", "Tab", 15),
    key("q", "Q", 16),
    key("w", "W", 17),
    key("e", "E", 18),
    key("r", "R", 19),
    key("t", "T", 20),
    key("y", "Y", 21),
    key("u", "U", 22),
    key("i", "I", 23),
    key("o", "O", 24),
    key("p", "P", 25),
    key("leftbrace", "[", 26),
    key("rightbrace", "]", 27),
    key("enter", "Enter", 28),
    key("a", "A", 30),
    key("s", "S", 31),
    key("d", "D", 32),
    key("f", "F", 33),
    key("g", "G", 34),
    key("h", "H", 35),
    key("j", "J", 36),
    key("k", "K", 37),
    key("l", "L", 38),
    key("semicolon", ";", 39),
    key("apostrophe", "'", 40),
    key("grave", "`", 41),
    key("backslash", "\\", 43),
    key("z", "Z", 44),
    key("x", "X", 45),
    key("c", "C", 46),
    key("v", "V", 47),
    key("b", "B", 48),
    key("n", "N", 49),
    key("m", "M", 50),
    key("comma", ",", 51),
    key("dot", ".", 52),
    key("slash", "/", 53),
    key("space", "Space", 57),
    key("capslock", "CapsLock", 58),
    key("f1", "F1", 59),
    key("f2", "F2", 60),
    key("f3", "F3", 61),
    key("f4", "F4", 62),
    key("f5", "F5", 63),
    key("f6", "F6", 64),
    key("f7", "F7", 65),
    key("f8", "F8", 66),
    key("f9", "F9", 67),
    key("f10", "F10", 68),
    key("f11", "F11", 87),
    key("f12", "F12", 88),
    key("home", "Home", 102),
    key("up", "↑", 103),
    key("pageup", "PageUp", 104),
    key("left", "←", 105),
    key("right", "→", 106),
    key("end", "End", 107),
    key("down", "↓", 108),
    key("pagedown", "PageDown", 109),
    key("insert", "Insert", 110),
    key("delete", "Delete", 111),
    key("mute", "Mute", 113),
    key("volumedown", "Volume −", 114),
    key("volumeup", "Volume +", 115),
    key("print", "PrintScreen", 99),
    key("nextsong", "Next track", 163),
    key("playpause", "Play/Pause", 164),
    key("previoussong", "Previous track", 165),
    key("stopcd", "Stop", 166),
];

/// The key with this config name (case-insensitive), if any.
pub fn by_name(name: &str) -> Option<Key> {
    KEYS.iter()
        .find(|k| k.name.eq_ignore_ascii_case(name))
        .copied()
}

/// The key with this Linux code, if it is one of [`KEYS`].
pub fn by_code(code: u16) -> Option<Key> {
    KEYS.iter().find(|k| k.code == code).copied()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_codes_are_unique() {
        for (i, a) in KEYS.iter().enumerate() {
            for b in KEYS.iter().skip(i + 1) {
                assert_ne!(a.name, b.name);
                assert_ne!(a.code, b.code, "{} and {}", a.name, b.name);
            }
        }
    }

    #[test]
    fn lookups() {
        assert_eq!(by_name("CTRL").map(|k| k.code), Some(29));
        assert_eq!(by_code(20).map(|k| k.name), Some("t"));
        assert_eq!(by_name("hyper"), None);
    }
}
