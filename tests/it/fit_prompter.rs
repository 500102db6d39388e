//! The live calibration's guide (`fit::prompter`) fed simulated breaths:
//! what it says, when, and what it counts.

use sipnpuff::control::Tick;
use sipnpuff::control::action::Breath;
use sipnpuff::control::detector::DetectorConfig;
use sipnpuff::control::sample::Sample;
use sipnpuff::fit::protocol::{
    ANSWER_MS, Ask, BETWEEN_BLOCKS_MS, BETWEEN_BREATHS_MS, Protocol, REST_MS,
};

use sipnpuff::control::action::Action;
use sipnpuff::fit::prompter::*;
use sipnpuff::sim::script::protocol_script;
use sipnpuff::sim::sensor_model::{SignalGenerator, SignalParams, Step};

/// What was said, with its tick.
type Said = Vec<(Tick, Say)>;

/// Plays `samples` through a new prompter until it is over; what it
/// said.
fn play(protocol: &Protocol, samples: impl IntoIterator<Item = Sample>) -> (Prompter, Said) {
    let mut prompter = Prompter::new(protocol);
    let mut said = Vec::new();
    for (t, sample) in samples.into_iter().enumerate() {
        if let Some(say) = prompter.step(t as Tick, sample) {
            said.push((t as Tick, say));
        }
        if prompter.is_over() {
            break;
        }
    }
    (prompter, said)
}

fn volts(params: SignalParams, script: &[Step]) -> Vec<Sample> {
    SignalGenerator::new(params, script)
        .map(Sample::Volts)
        .collect()
}

/// A user on the default detector: clean breaths, light noise.
fn user() -> SignalParams {
    SignalParams::clean(&DetectorConfig::default(), 3).with_noise(0.01)
}

fn puff(ms: u32) -> Step {
    Step::Breath {
        breath: Breath::Puff,
        ms,
    }
}

fn sip(ms: u32) -> Step {
    Step::Breath {
        breath: Breath::Sip,
        ms,
    }
}

fn rest(ms: u32) -> Step {
    Step::Rest { ms }
}

/// "short puff 1/3" for a prompt, the kind of anything else.
fn brief(say: &Say) -> String {
    let p = |p: &Prompt| format!("{} {}/{}", p.ask.words(), p.n, p.of);
    match say {
        Say::Rest { again } => format!("rest again={again}"),
        Say::Prompt(prompt) => format!("prompt {}", p(prompt)),
        Say::Repeat(prompt) => format!("repeat {}", p(prompt)),
        Say::WrongKind { prompt, got } => {
            format!("wrong {} for {}", got.word(), p(prompt))
        }
        Say::Early { breath } => format!("early {}", breath.word()),
        Say::Counted { prompt, .. } => format!("counted {}", p(prompt)),
        Say::Finished => "finished".into(),
        Say::Stopped(stop) => format!("stopped {stop:?}"),
    }
}

fn briefs(said: &Said) -> Vec<String> {
    said.iter().map(|(_, s)| brief(s)).collect()
}

#[test]
fn a_user_who_follows_the_prompts_is_guided_through_every_block_in_order() {
    let protocol = Protocol::new(3, 2);
    let d = DetectorConfig::default();
    let (params, script) = protocol_script(&d, &protocol, 5);
    let (prompter, said) = play(&protocol, volts(params, &script));
    let mut expected = vec!["rest again=false".to_string()];
    for block in &protocol.blocks {
        for n in 1..=block.count {
            let p = format!("{} {n}/{}", block.ask.words(), block.count);
            expected.push(format!("prompt {p}"));
            expected.push(format!("counted {p}"));
        }
    }
    expected.push("finished".into());
    assert_eq!(briefs(&said), expected);
    assert!(prompter.is_finished());
    let view = prompter.view();
    assert_eq!((view.counted, view.total), (16, 16));
    assert_eq!(view.headline(), "done — thank you");
    let band = prompter.band().unwrap();
    assert!((band.level - 2.5).abs() < 0.01, "{band:?}");
    // 6σ of the noise, or the floor.
    assert!((0.05..0.1).contains(&band.outside), "{band:?}");
    // The first prompt after the rest; each later one at least 1 s
    // (3 s after a block) after the breath before it was counted.
    assert_eq!(said[1].0, u64::from(REST_MS) - 1);
    for pair in said.windows(2) {
        if let ((counted, Say::Counted { prompt, .. }), (next, Say::Prompt(_))) = (pair[0], pair[1])
        {
            let rest = if prompt.n == prompt.of {
                BETWEEN_BLOCKS_MS
            } else {
                BETWEEN_BREATHS_MS
            };
            assert!(next - counted >= u64::from(rest), "{pair:?}");
        }
    }
    // Each breath answered its prompt: the script's breaths start
    // after them.
    let lines: Vec<String> = said.iter().map(|(_, s)| s.line()).collect();
    assert_eq!(
        lines[1],
        "block 1 of 6: 3 short puffs, one at each prompt\nshort puff — now (1 of 3)"
    );
    assert_eq!(lines[3], "short puff — now (2 of 3)");
    assert!(
        lines[2].starts_with("  counted: short puff 1 of 3 ("),
        "{}",
        lines[2]
    );
}

#[test]
fn a_breath_of_the_wrong_kind_is_said_and_not_counted() {
    let protocol = Protocol::new(1, 0);
    let script = [
        rest(6000),
        sip(200), // a puff is asked for
        rest(1500),
        puff(150),
        rest(3500),
        puff(800),
        rest(3500),
        sip(150),
        rest(3500),
        sip(800),
        rest(2000),
    ];
    let (prompter, said) = play(&protocol, volts(user(), &script));
    assert_eq!(
        briefs(&said)[..6],
        [
            "rest again=false",
            "prompt short puff 1/1",
            "wrong sip for short puff 1/1",
            "prompt short puff 1/1",
            "counted short puff 1/1",
            "prompt long puff 1/1",
        ]
    );
    assert_eq!(said[2].1.message(), "that was a sip — again, a puff please");
    assert!(prompter.is_finished(), "{said:?}");
    assert_eq!(prompter.view().counted, 4);
}

#[test]
fn a_breath_before_its_prompt_is_told_to_wait_and_not_counted() {
    let protocol = Protocol::new(1, 0);
    // The second puff comes 0.4 s after the first: before the prompt.
    let script = [
        rest(6000),
        puff(150),
        rest(400),
        puff(150),
        rest(3500),
        puff(800),
        rest(2000),
    ];
    let (_, said) = play(&protocol, volts(user(), &script));
    assert_eq!(
        briefs(&said),
        [
            "rest again=false",
            "prompt short puff 1/1",
            "counted short puff 1/1",
            "early puff",
            "prompt long puff 1/1",
            "counted long puff 1/1",
        ]
    );
    assert_eq!(
        said[3].1.message(),
        "wait for the prompt — that puff was not counted"
    );
    // The rest before the block's prompt counts from the early puff.
    assert!(said[4].0 - said[3].0 >= u64::from(BETWEEN_BLOCKS_MS));
}

#[test]
fn silence_repeats_the_prompt_then_stops_with_what_to_check() {
    let protocol = Protocol::default();
    let (prompter, said) = play(&protocol, volts(user(), &[rest(40_000)]));
    let prompted = u64::from(REST_MS) - 1;
    let answer = u64::from(ANSWER_MS);
    let ticks: Vec<Tick> = said.iter().map(|(t, _)| *t).collect();
    assert_eq!(
        ticks,
        [0, prompted, prompted + answer, prompted + 2 * answer]
    );
    assert_eq!(
        briefs(&said),
        [
            "rest again=false",
            "prompt short puff 1/8",
            "repeat short puff 1/8",
            "stopped Silence { ask: Breath(ShortPuff) }",
        ]
    );
    assert_eq!(
        said[2].1.line(),
        "no breath in 10 s — once more — short puff — now (1 of 8)"
    );
    let words = said[3].1.line();
    assert!(
        words.contains("tube") && words.contains("sensor"),
        "{words}"
    );
    assert_eq!(
        prompter.stopped(),
        Some(Stop::Silence {
            ask: Ask::Breath(Action::ShortPuff)
        })
    );
    assert_eq!(prompter.view().headline(), "stopped");
}

#[test]
fn a_lost_sensor_stops_the_session_at_once() {
    let protocol = Protocol::default();
    let mut samples = volts(user(), &[rest(6000), puff(150), rest(500)]);
    samples[5600] = Sample::Lost;
    let (prompter, said) = play(&protocol, samples);
    assert_eq!(
        briefs(&said),
        [
            "rest again=false",
            "prompt short puff 1/8",
            "stopped Lost { tick: 5600 }",
        ]
    );
    assert!(said[2].1.line().contains("the sensor was lost 5.6 s into"));
    assert!(prompter.is_over() && !prompter.is_finished());
    // Lost during the rest too.
    let (_, said) = play(&protocol, [Sample::Volts(2.5), Sample::Lost]);
    assert_eq!(briefs(&said)[1], "stopped Lost { tick: 1 }");
}

#[test]
fn a_breath_during_the_rest_starts_the_rest_again_and_an_unsteady_one_stops() {
    let protocol = Protocol::default();
    let script = [rest(2500), puff(300), rest(8000), puff(150), rest(500)];
    let (_, said) = play(&protocol, volts(user(), &script));
    assert_eq!(
        briefs(&said),
        [
            "rest again=false",
            "rest again=true",
            "prompt short puff 1/8",
            "counted short puff 1/8",
        ]
    );
    let rest_ms = u64::from(REST_MS);
    assert_eq!(said[1].0, rest_ms - 1);
    assert_eq!(said[2].0, 2 * rest_ms - 1);
    // Puffing all the time: it never settles.
    let busy: Vec<Step> = (0..30).flat_map(|_| [puff(300), rest(500)]).collect();
    let (prompter, said) = play(&protocol, volts(user(), &busy));
    assert_eq!(said.len(), 1 + REST_TRIES as usize, "{said:?}");
    assert_eq!(prompter.stopped(), Some(Stop::NoRest));
}

#[test]
fn the_view_shows_the_prompt_the_count_and_the_last_message() {
    let protocol = Protocol::new(3, 0);
    let mut prompter = Prompter::new(&protocol);
    let samples = volts(user(), &[rest(6000), puff(150), rest(300)]);
    let mut views = Vec::new();
    for (t, s) in samples.into_iter().enumerate() {
        if prompter.step(t as Tick, s).is_some() {
            views.push(prompter.view());
        }
    }
    let [rest_view, prompted, counted] = views[..] else {
        panic!("{views:?}");
    };
    assert_eq!(rest_view.headline(), "rest, please");
    assert!(
        rest_view
            .message
            .unwrap()
            .message()
            .starts_with("rest, please: no sip or puff for 5 s")
    );
    assert_eq!(prompted.headline(), "short puff — now");
    assert_eq!(prompted.prompt.unwrap().count_words(), "1 of 3");
    assert_eq!(counted.phase, Phase::Pause);
    assert_eq!(counted.headline(), "rest — wait for the prompt");
    assert_eq!(counted.prompt.unwrap().count_words(), "2 of 3");
    assert_eq!(counted.message.unwrap().message(), "got it");
    assert_eq!((counted.counted, counted.total), (1, 12));
}

/// Every built-in breather, in the place of the live session's synthetic
/// user (`fit --sensor synthetic:NAME`), on simulated ticks: the guide
/// hears the rest, prompts every breath and counts each, and the session
/// ends finished.
#[test]
fn every_breather_is_guided_through_the_live_session() {
    use sipnpuff::config::Config;
    use sipnpuff::sensor::{Samples, Sensor};
    use sipnpuff::sim::breather::Breather;
    use sipnpuff::sim::synthetic_sensor::SyntheticSensor;

    let protocol = Protocol::new(8, 3);
    for b in Breather::all() {
        let user = SyntheticSensor::calibration_user(&Config::default(), &protocol, Some(b));
        let mut samples = user.start().unwrap().samples;
        let mut prompter = Prompter::new(&protocol);
        let mut said = Vec::new();
        let mut tick: Tick = 0;
        while !prompter.is_over() && !samples.ended() {
            let sample = samples.try_read(0).sample;
            if let Some(say) = prompter.step(tick, sample) {
                said.push(say.line());
            }
            tick += 1;
        }
        assert!(prompter.is_finished(), "{}: {said:#?}", b.name);
        let counted = said.iter().filter(|l| l.contains("counted")).count();
        assert_eq!(counted, 38, "{}: {said:#?}", b.name);
        assert!(
            !said.iter().any(|l| l.contains("not counted")),
            "{}: {said:#?}",
            b.name
        );
    }
}
