//! The gesture recording protocol, and a recording cut along it: rest
//! ≥ 3 s; then, for each gesture in the order given, [`EXAMPLES`]
//! examples with 1.5–3 s of rest between them and ≥ 3 s between
//! gestures; then ≥ 60 s of ordinary movement that must trigger nothing.
//! A recording made by any means that follows it can be cut offline; one
//! that does not is refused naming the gesture and example that are
//! missing or out of place.

use std::fmt;

use crate::control::Tick;

/// Examples of each gesture.
pub const EXAMPLES: usize = 5;
/// Rest at the start, ms: the rest posture and the gyro's bias.
pub const REST_MS: Tick = 3000;
/// Rest between the examples of a gesture, ms (least, most).
pub const BETWEEN_EXAMPLES_MS: (Tick, Tick) = (1500, 3000);
/// Rest between gestures, ms (least).
pub const BETWEEN_GESTURES_MS: Tick = 3000;
/// Ordinary movement after the last example, ms (least).
pub const ORDINARY_MS: Tick = 60_000;

/// A movement the segmenter found: its first and last tick of motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Span {
    /// First tick of the movement.
    pub start: Tick,
    /// Last tick of the movement.
    pub end: Tick,
}

/// A recording cut along the protocol: which movement is which example,
/// and where the ordinary movement lies.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ProtocolCut {
    /// For each gesture in the order given, the indices (into the spans
    /// given) of its examples, in order.
    pub examples: Vec<[usize; EXAMPLES]>,
    /// The ordinary movement: from the end of the last example to the
    /// recording's last tick.
    pub ordinary: Span,
}

/// Why a recording does not follow the protocol: one line, naming the
/// gesture and example where it can.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ProtocolError(pub String);

impl fmt::Display for ProtocolError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ProtocolError {}

/// Seconds, for messages: `12.3 s`.
fn s(ms: Tick) -> String {
    format!("{:.1} s", ms as f64 / 1000.0)
}

/// Cuts a recording from `first` to `last` tick, whose movements the
/// segmenter found at `spans` (in order), along the protocol for
/// `gestures`. The segmenter sees a movement begin and end a little away
/// from where the head truly starts and stops, so each rest may measure
/// up to `slack_ms` shorter or longer than it was.
pub fn cut(
    gestures: &[String],
    first: Tick,
    last: Tick,
    spans: &[Span],
    slack_ms: Tick,
) -> Result<ProtocolCut, ProtocolError> {
    if gestures.is_empty() {
        return Err(ProtocolError("no gesture named: give at least one".into()));
    }
    let Some(opening) = spans.first() else {
        return Err(ProtocolError(format!(
            "no movement found in the recording ({} to {}): the protocol asks for {EXAMPLES} examples of {}",
            s(first),
            s(last),
            gestures.join(", ")
        )));
    };
    if opening.start.saturating_sub(first) + slack_ms < REST_MS {
        return Err(ProtocolError(format!(
            "the recording moves at {} after its start: the protocol opens with at least {} of rest (the rest posture is measured there)",
            s(opening.start.saturating_sub(first)),
            s(REST_MS)
        )));
    }
    let mut examples: Vec<[usize; EXAMPLES]> = Vec::with_capacity(gestures.len());
    let mut next = 0usize;
    let mut previous_end: Option<Tick> = None;
    for (g, name) in gestures.iter().enumerate() {
        let found = gestures.get(..g).unwrap_or_default();
        let hint = |error: ProtocolError| {
            if found.is_empty() {
                error
            } else {
                ProtocolError(format!(
                    "{}; the examples of '{}' were found before it: is '{name}' in the recording?",
                    error.0,
                    found.join("', '")
                ))
            }
        };
        let mut indices = [0usize; EXAMPLES];
        for (k, slot) in indices.iter_mut().enumerate() {
            let example = k + 1;
            let Some(span) = spans.get(next) else {
                return Err(hint(ProtocolError(format!(
                    "gesture '{name}': example {example} of {EXAMPLES} missing: the recording has no more movement{}",
                    previous_end
                        .map(|end| format!(" after {}", s(end - first)))
                        .unwrap_or_default()
                ))));
            };
            if let Some(end) = previous_end {
                let rest = span.start.saturating_sub(end);
                if k == 0 {
                    if rest + slack_ms < BETWEEN_GESTURES_MS {
                        let before = gestures.get(g.wrapping_sub(1)).map_or("", |n| n.as_str());
                        return Err(ProtocolError(format!(
                            "gesture '{name}': its first example at {} follows '{before}' after {} of rest; the protocol rests at least {} between gestures (a movement of '{before}' too many?)",
                            s(span.start - first),
                            s(rest),
                            s(BETWEEN_GESTURES_MS)
                        )));
                    }
                } else if rest > BETWEEN_EXAMPLES_MS.1 + slack_ms {
                    let next_name = gestures.get(g + 1);
                    let after = if k + 1 == EXAMPLES && next_name.is_none() {
                        String::new()
                    } else {
                        format!(" (or this rest of {} ends the gesture)", s(rest))
                    };
                    return Err(hint(ProtocolError(format!(
                        "gesture '{name}': example {example} of {EXAMPLES} missing: {} of rest at {} where the protocol rests 1.5–3 s between examples{after}",
                        s(rest),
                        s(end - first)
                    ))));
                } else if rest + slack_ms < BETWEEN_EXAMPLES_MS.0 {
                    return Err(ProtocolError(format!(
                        "gesture '{name}': examples {} and {example} are {} apart at {}; the protocol rests 1.5–3 s between examples (one movement seen as two?)",
                        example - 1,
                        s(rest),
                        s(end - first)
                    )));
                }
            }
            *slot = next;
            previous_end = Some(span.end);
            next += 1;
        }
        examples.push(indices);
    }
    let end = previous_end.unwrap_or(first);
    let ordinary = Span {
        start: end,
        end: last,
    };
    if last.saturating_sub(end) + slack_ms < ORDINARY_MS {
        return Err(ProtocolError(format!(
            "ordinary movement: {} recorded after the last example at {}; the protocol asks for at least {} that must trigger nothing",
            s(last.saturating_sub(end)),
            s(end - first),
            s(ORDINARY_MS)
        )));
    }
    Ok(ProtocolCut { examples, ordinary })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(list: &[&str]) -> Vec<String> {
        list.iter().map(|n| n.to_string()).collect()
    }

    /// Movements of 800 ms: `rests` gives the rest before each, ms.
    fn spans(rests: &[Tick]) -> Vec<Span> {
        let mut at = 0;
        rests
            .iter()
            .map(|rest| {
                let start = at + rest;
                at = start + 800;
                Span { start, end: at }
            })
            .collect()
    }

    /// Two gestures by the protocol, then `ordinary` movements.
    fn protocol(ordinary: &[Tick]) -> Vec<Tick> {
        let mut rests = vec![4000, 2000, 2000, 2000, 2000, 4000, 2000, 2000, 2000, 2000];
        rests.extend_from_slice(ordinary);
        rests
    }

    #[test]
    fn a_recording_that_follows_the_protocol_is_cut_five_by_five() {
        let spans = spans(&protocol(&[3000, 5000, 20000]));
        let cut = cut(&names(&["nod", "shake"]), 0, 100_000, &spans, 300).unwrap();
        assert_eq!(cut.examples, vec![[0, 1, 2, 3, 4], [5, 6, 7, 8, 9]]);
        assert_eq!(
            cut.ordinary,
            Span {
                start: spans[9].end,
                end: 100_000
            }
        );
    }

    #[test]
    fn a_missing_example_is_named() {
        let mut rests = protocol(&[]);
        rests.remove(3);
        let error = cut(&names(&["nod", "shake"]), 0, 100_000, &spans(&rests), 300).unwrap_err();
        assert_eq!(
            error.0,
            "gesture 'nod': example 5 of 5 missing: 4.0 s of rest at 13.2 s where the protocol rests 1.5–3 s between examples (or this rest of 4.0 s ends the gesture)"
        );
    }

    #[test]
    fn too_short_an_opening_rest_or_ordinary_stretch_is_refused() {
        let mut rests = protocol(&[]);
        rests[0] = 1000;
        let error = cut(&names(&["nod", "shake"]), 0, 100_000, &spans(&rests), 300).unwrap_err();
        assert!(
            error.0.starts_with("the recording moves at 1.0 s"),
            "{error}"
        );
        let spans = spans(&protocol(&[]));
        let error = cut(&names(&["nod", "shake"]), 0, 60_000, &spans, 300).unwrap_err();
        assert_eq!(
            error.0,
            "ordinary movement: 28.0 s recorded after the last example at 32.0 s; the protocol asks for at least 60.0 s that must trigger nothing"
        );
    }

    #[test]
    fn a_gesture_too_few_and_the_next_gesture_too_soon_are_told_apart() {
        let mut rests = protocol(&[]);
        rests[5] = 2000; // shake follows nod's last example as if a sixth nod
        let error = cut(&names(&["nod", "shake"]), 0, 100_000, &spans(&rests), 300).unwrap_err();
        assert!(
            error.0.starts_with("gesture 'shake': its first example"),
            "{error}"
        );
        let error = cut(
            &names(&["nod", "shake", "tilt_left"]),
            0,
            100_000,
            &spans(&protocol(&[])),
            300,
        )
        .unwrap_err();
        assert_eq!(
            error.0,
            "gesture 'tilt_left': example 1 of 5 missing: the recording has no more movement after 32.0 s; the examples of 'nod', 'shake' were found before it: is 'tilt_left' in the recording?"
        );
    }
}
