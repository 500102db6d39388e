//! The built-in configuration: each stage's default settings and the
//! built-in library (see
//! [`DEFAULT_LIBRARY`](crate::control::selection::DEFAULT_LIBRARY)).
//! A file's missing keys take these values.

use crate::control::action::ActionSeq;
use crate::control::core_config::CoreConfig;
use crate::control::selection::{DEFAULT_LIBRARY, SequenceEntry};

/// The built-in settings of the core: each stage's defaults and the
/// built-in library.
pub(super) fn core() -> CoreConfig {
    let sequences = DEFAULT_LIBRARY
        .iter()
        .filter_map(|&(actions, mode)| {
            Some(SequenceEntry::mode(ActionSeq::from_slice(actions)?, mode))
        })
        .collect();
    CoreConfig {
        detector: Default::default(),
        matcher: Default::default(),
        command: Default::default(),
        motion: Default::default(),
        workspace: Default::default(),
        home: Default::default(),
        feedback: Default::default(),
        interface: Default::default(),
        pointer: Default::default(),
        gesture_section: Default::default(),
        gestures: None,
        breath: true,
        scanning: Default::default(),
        sequences,
    }
}

#[cfg(test)]
mod tests {
    use super::core;
    use crate::control::mode::Mode;

    #[test]
    fn the_default_library_is_prefix_free_and_covers_every_mode() {
        let library = core().sequences;
        assert_eq!(library.len(), 9);
        for mode in Mode::ALL {
            assert!(
                library.iter().any(|s| s.target.mode() == Some(mode)),
                "{mode:?}"
            );
        }
        for a in &library {
            for b in &library {
                if a != b {
                    assert!(!b.actions.as_slice().starts_with(a.actions.as_slice()));
                }
            }
        }
    }
}
