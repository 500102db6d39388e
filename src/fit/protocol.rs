//! The calibration protocol: what the user is asked to breathe, in which
//! order. The order is fixed so that a recording made by any means that
//! follows it can be fitted offline: rest, short puffs, long puffs, short
//! sips, long sips, then (optionally) the longest comfortable puffs and
//! sips.

use serde::{Deserialize, Serialize};

use crate::control::action::{Action, Breath};

/// Rest at the start, ms: the neutral and the noise at rest.
pub const REST_MS: u32 = 5000;
/// Rest after each breath before the next prompt, ms.
pub const BETWEEN_BREATHS_MS: u32 = 1000;
/// Rest between blocks, ms.
pub const BETWEEN_BLOCKS_MS: u32 = 3000;
/// No breath this long after a prompt: the prompt repeats (once), then
/// the session stops.
pub const ANSWER_MS: u32 = 10_000;
/// Breaths per block of the default protocol.
pub const DEFAULT_COUNT: u32 = 8;
/// Holds per kind with `--holds`.
pub const DEFAULT_HOLDS: u32 = 3;

/// What one prompt asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ask {
    /// A short or long sip or puff.
    Breath(Action),
    /// The longest sip or puff the user can comfortably hold.
    Hold(Breath),
}

impl Ask {
    /// Sip or puff.
    pub fn breath(self) -> Breath {
        match self {
            Ask::Breath(action) => action.breath(),
            Ask::Hold(breath) => breath,
        }
    }

    /// The prompt's words, e.g. "short puff".
    pub fn words(self) -> &'static str {
        match self {
            Ask::Breath(Action::ShortPuff) => "short puff",
            Ask::Breath(Action::LongPuff) => "long puff",
            Ask::Breath(Action::ShortSip) => "short sip",
            Ask::Breath(Action::LongSip) => "long sip",
            Ask::Hold(Breath::Puff) => "longest comfortable puff",
            Ask::Hold(Breath::Sip) => "longest comfortable sip",
        }
    }
}

/// Written as its words ("short puff").
impl Serialize for Ask {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.words())
    }
}

/// Read from its words, as a guided session's `calibration.json` holds
/// them.
impl<'de> Deserialize<'de> for Ask {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let words = String::deserialize(deserializer)?;
        let mut asks = [
            Action::ShortPuff,
            Action::LongPuff,
            Action::ShortSip,
            Action::LongSip,
        ]
        .map(Ask::Breath)
        .into_iter()
        .chain([Breath::Puff, Breath::Sip].map(Ask::Hold));
        asks.find(|ask| ask.words() == words)
            .ok_or_else(|| serde::de::Error::custom(format!("{words:?} is not a prompt")))
    }
}

/// One block: the same breath asked for `count` times.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Block {
    /// What each prompt of the block asks for.
    pub ask: Ask,
    /// How many breaths.
    pub count: u32,
}

/// The blocks of a session, in the fixed order.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Protocol {
    /// The blocks, in order.
    pub blocks: Vec<Block>,
}

impl Default for Protocol {
    /// Eight of each short and long puff and sip, no holds.
    fn default() -> Self {
        Protocol::new(DEFAULT_COUNT, 0)
    }
}

impl Protocol {
    /// `count` breaths of each kind (short puff, long puff, short sip, long
    /// sip), then `holds` longest comfortable puffs and sips (0: none).
    pub fn new(count: u32, holds: u32) -> Protocol {
        let mut blocks: Vec<Block> = [
            Action::ShortPuff,
            Action::LongPuff,
            Action::ShortSip,
            Action::LongSip,
        ]
        .into_iter()
        .map(|action| Block {
            ask: Ask::Breath(action),
            count,
        })
        .collect();
        if holds > 0 {
            for breath in [Breath::Puff, Breath::Sip] {
                blocks.push(Block {
                    ask: Ask::Hold(breath),
                    count: holds,
                });
            }
        }
        Protocol { blocks }
    }

    /// Whether the longest comfortable holds are asked for.
    pub fn has_holds(&self) -> bool {
        self.blocks.iter().any(|b| matches!(b.ask, Ask::Hold(_)))
    }

    /// Every prompt in order.
    pub fn prompts(&self) -> impl Iterator<Item = Ask> + '_ {
        self.blocks
            .iter()
            .flat_map(|b| std::iter::repeat_n(b.ask, b.count as usize))
    }

    /// One line for a profile's header, e.g. "rest 5 s; 8 short puffs, …".
    pub fn describe(&self) -> String {
        format!(
            "rest {} s; {} (≥ {} s between breaths, ≥ {} s between blocks)",
            REST_MS / 1000,
            self.counts(),
            BETWEEN_BREATHS_MS / 1000,
            BETWEEN_BLOCKS_MS / 1000
        )
    }

    /// The breaths of ordinary use these blocks stand for, in words: no
    /// rest or spacing was asked for.
    pub fn describe_found(&self) -> String {
        format!(
            "{} (the breaths that selected a mode, short and long as made)",
            self.counts()
        )
    }

    /// "8 × short puff, 8 × long puff, …".
    fn counts(&self) -> String {
        let blocks: Vec<String> = self
            .blocks
            .iter()
            .map(|b| format!("{} × {}", b.count, b.ask.words()))
            .collect();
        blocks.join(", ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_order_is_fixed() {
        let p = Protocol::default();
        let asks: Vec<&str> = p.blocks.iter().map(|b| b.ask.words()).collect();
        assert_eq!(asks, ["short puff", "long puff", "short sip", "long sip"]);
        assert_eq!(p.prompts().count(), 32);
        let with_holds = Protocol::new(5, 3);
        assert_eq!(with_holds.blocks.len(), 6);
        assert_eq!(with_holds.prompts().count(), 26);
        assert!(with_holds.has_holds() && !p.has_holds());
    }

    #[test]
    fn a_protocol_reads_back_from_its_json() {
        let p = Protocol::new(5, 3);
        let json = serde_json::to_string(&p).unwrap();
        assert!(
            json.contains(r#""ask":"longest comfortable sip""#),
            "{json}"
        );
        assert_eq!(serde_json::from_str::<Protocol>(&json).unwrap(), p);
        let wrong = json.replace("short puff", "short puf");
        assert!(serde_json::from_str::<Protocol>(&wrong).is_err());
    }
}
