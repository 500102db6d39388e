//! The paper's three tasks as scripts of steps: which mode, which breath
//! (direction) and for how long the arm moves. The paper describes the
//! tasks but not their motions; these step lists are our reconstruction
//! of a plausible way to do each with the JACO from its home pose. Moving
//! time is the same for both interfaces by construction: only selection
//! differs.

use crate::control::action::Breath;
use crate::control::mode::Mode;

/// One move of a task.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TaskStep {
    /// The mode to be in.
    pub mode: Mode,
    /// Puff or sip: the direction.
    pub breath: Breath,
    /// How long to move, ms.
    pub moving_ms: u32,
}

/// A task of the study.
#[derive(Debug, Clone, Copy)]
pub struct Task {
    /// 1, 2 or 3, as in the paper.
    pub number: u8,
    /// What the participant does.
    pub description: &'static str,
    /// The moves, in order.
    pub steps: &'static [TaskStep],
}

impl Task {
    /// Total moving time, ms.
    pub fn moving_ms(&self) -> u32 {
        self.steps.iter().map(|s| s.moving_ms).sum()
    }

    /// Mode changes the task needs (consecutive steps in one mode share a
    /// selection).
    pub fn selections(&self) -> usize {
        self.mode_changes().count()
    }

    /// The mode selected at each mode change, in order.
    pub fn mode_changes(&self) -> impl Iterator<Item = Mode> + '_ {
        self.steps
            .iter()
            .enumerate()
            .filter(|(i, s)| *i == 0 || self.steps[i - 1].mode != s.mode)
            .map(|(_, s)| s.mode)
    }
}

const fn step(mode: Mode, breath: Breath, moving_ms: u32) -> TaskStep {
    TaskStep {
        mode,
        breath,
        moving_ms,
    }
}

use Breath::{Puff, Sip};
use Mode::{Fingers, RotateX, RotateY, TranslateX, TranslateY, TranslateZ};

/// The three tasks of the paper's experiment.
pub const TASKS: [Task; 3] = [
    Task {
        number: 1,
        description: "grab a jar on a shelf, bring it to a table and drop it",
        steps: &[
            step(TranslateX, Puff, 3000), // towards the shelf
            step(TranslateZ, Puff, 1500), // up to the jar
            step(Fingers, Puff, 1000),    // open
            step(TranslateX, Puff, 1000), // around the jar
            step(Fingers, Sip, 1500),     // close on it
            step(TranslateZ, Puff, 500),  // lift off the shelf
            step(TranslateX, Sip, 2500),  // back out
            step(TranslateY, Puff, 2000), // over the table
            step(TranslateZ, Sip, 2000),  // down
            step(Fingers, Puff, 1000),    // drop it
        ],
    },
    Task {
        number: 2,
        description: "take a spoon from a shelf, a spoonful of coffee, into a mug",
        steps: &[
            step(TranslateX, Puff, 2500),
            step(TranslateZ, Puff, 1200),
            step(Fingers, Puff, 800),
            step(TranslateX, Puff, 800),
            step(Fingers, Sip, 1500), // grab the block holding the spoon
            step(TranslateZ, Puff, 400),
            step(TranslateX, Sip, 2000),
            step(TranslateY, Puff, 2000), // over the coffee
            step(RotateY, Puff, 1000),    // tilt the spoon
            step(TranslateZ, Sip, 1500),  // into the coffee
            step(TranslateZ, Puff, 1500), // out with a spoonful
            step(RotateY, Sip, 1000),     // level
            step(TranslateY, Sip, 1000),  // over the mug
            step(RotateY, Puff, 1500),    // pour it in
        ],
    },
    Task {
        number: 3,
        description: "take a bottle of water from a shelf and pour water in a glass",
        steps: &[
            step(TranslateX, Puff, 3000),
            step(TranslateZ, Puff, 1500),
            step(Fingers, Puff, 1000),
            step(TranslateX, Puff, 1000),
            step(Fingers, Sip, 1500),
            step(TranslateZ, Puff, 500),
            step(TranslateX, Sip, 2500),
            step(TranslateY, Puff, 1500), // next to the glass
            step(TranslateZ, Sip, 1000),
            step(RotateX, Puff, 2500), // pour
            step(RotateX, Sip, 2500),  // upright again
        ],
    },
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tasks_as_written() {
        assert_eq!(TASKS.map(|t| t.number), [1, 2, 3]);
        assert_eq!(TASKS.map(|t| t.moving_ms()), [16_000, 18_700, 18_500]);
        // Task 2 moves in translate_z twice in a row, task 3 rotates twice.
        assert_eq!(TASKS.map(|t| t.selections()), [10, 13, 10]);
    }
}
