//! The display's frames, built from the core's records and events with
//! simulated ticks: what the user sees at each moment of a scripted
//! session (ASP with the paper's prefixes, BSP's scan, command mode,
//! faults), with the values the configuration fixes.

use sipnpuff::config::Config;
use sipnpuff::control::Tick;
use sipnpuff::control::event::{Event, TimedEvent};
use sipnpuff::control::pipeline::Pipeline;
use sipnpuff::control::sample::Sample;
use sipnpuff::control::tick::TickInput;
use sipnpuff::display::frame::{Cue, Frame};
use sipnpuff::display::screen::Screen;
use sipnpuff::rt::telemetry::TickRecord;
use sipnpuff::sim::sensor_model::{SignalGenerator, SignalParams, Step};

use crate::common::{self, TickByTick, puff, rest, sip};

/// The core and the screen, stepped together one simulated tick at a time
/// as the telemetry side sees them.
struct Session {
    core: Pipeline,
    screen: Screen,
    samples: Vec<f64>,
    tick: Tick,
    cues: Vec<(Tick, Cue)>,
    events: Vec<TimedEvent>,
}

impl Session {
    fn new(config: &Config, script: &[Step]) -> Session {
        let params = SignalParams::clean(config.core().detector(), 1);
        Session {
            core: Pipeline::new(config.core()),
            screen: Screen::new(config.core(), "simulated JACO"),
            samples: SignalGenerator::new(params, script).collect(),
            tick: 0,
            cues: Vec::new(),
            events: Vec::new(),
        }
    }

    /// Steps until `tick` (inclusive), feeding `sample` where the script
    /// has ended; returns the frame then.
    fn frame_at(&mut self, tick: Tick) -> Frame {
        while self.tick <= tick {
            let volts = self.samples.get(self.tick as usize).copied().unwrap_or(2.5);
            let sample = Sample::Volts(volts);
            let out = self.core.tick_with(self.tick, sample);
            let record = TickRecord {
                tick: self.tick,
                input: TickInput {
                    tick: self.tick,
                    sample,
                    ..TickInput::default()
                },
                view: self.core.view(),
                ..TickRecord::default()
            };
            self.screen.observe(&record);
            for event in out.events.iter() {
                let timed = TimedEvent {
                    tick: self.tick,
                    event: *event,
                };
                if let Some(cue) = self.screen.event(&timed) {
                    self.cues.push((self.tick, cue));
                }
                self.events.push(timed);
            }
            self.tick += 1;
        }
        self.screen.frame()
    }

    /// The end tick of the `n`th burst (0-based).
    fn burst_end(&self, n: usize) -> Tick {
        self.events
            .iter()
            .filter_map(|e| match e.event {
                Event::Burst(b) => Some(b.end),
                _ => None,
            })
            .nth(n)
            .expect("the burst was detected")
    }
}

fn names(frame: &Frame) -> Vec<String> {
    frame
        .sequence
        .iter()
        .map(|s| format!("{}{}", if s.long { "long " } else { "short " }, s.breath))
        .collect()
}

/// The breaths of the paper's example: a short sip, a long sip (<1, 2>),
/// the wait, a puff.
const PAPER_SESSION: [Step; 7] = [
    rest(500),
    sip(150),
    rest(300),
    sip(700),
    rest(1500),
    puff(800),
    rest(2500),
];

/// The paper's example: S1 = <1, 2, −1> (translate_x), S2 = <1, 2>
/// (translate_y), S3 = <2, 1> (translate_z). After <1, 2> the matcher
/// waits 1000 ms for a −1 before selecting S2: the page shows the wait.
#[test]
fn asp_shows_the_sequence_the_sequences_still_possible_and_the_wait_on_a_prefix() {
    let config = common::paper_config();
    let mut s = Session::new(&config, &PAPER_SESSION);

    // Nothing breathed: every sequence is possible, nothing waits.
    let start = s.frame_at(100);
    assert_eq!(start.state, "selecting");
    assert_eq!(start.candidates, [0, 1, 2]);
    assert!(start.sequence.is_empty() && start.waiting.is_none());
    let setup = s.screen.setup();
    assert_eq!(setup.interface, "asp");
    let listed: Vec<&str> = setup.modes.iter().map(|m| m.mode.as_str()).collect();
    assert_eq!(listed, ["translate_x", "translate_y", "translate_z"]);
    assert_eq!(setup.long_ms, 500);

    // The short sip: S1 and S2 start with it and stay lit; S3 dims. The
    // matcher would drop <1> (no sequence is <1>) 1000 ms after it ended.
    let first_end_guess = 500 + 150 + 60;
    let f = s.frame_at(first_end_guess);
    let end = s.burst_end(0);
    assert_eq!(names(&f), ["short sip"]);
    assert_eq!(f.candidates, [0, 1]);
    let waiting = f.waiting.expect("waits for the next breath");
    assert_eq!(waiting.ms_left, end + 1000 - first_end_guess);
    assert_eq!((waiting.total_ms, waiting.selects), (1000, None));

    // Holding the long sip: the bar shows a sip held for as long as it has
    // been, and the wait is frozen at its whole length.
    let holding = s.frame_at(end + 300 + 400);
    assert_eq!(holding.pressure.held, Some("sip"));
    let start_of_hold = s.core.view().held.map(|(_, t)| t).expect("the sip is held");
    assert_eq!(holding.pressure.held_ms, end + 700 - start_of_hold + 1);
    assert_eq!(holding.waiting.unwrap().ms_left, 1000);

    // <1, 2>: S2 is complete, S1 could still follow: the page says which
    // mode the wait selects and how long is left.
    let after = s.frame_at(end + 300 + 700 + 100);
    let second_end = s.burst_end(1);
    assert_eq!(names(&after), ["short sip", "long sip"]);
    assert_eq!(after.candidates, [0, 1]);
    let waiting = after.waiting.unwrap();
    assert_eq!(waiting.selects.as_deref(), Some("translate_y"));
    assert_eq!(waiting.ms_left, second_end + 1000 - (end + 1100));

    // The wait runs out: translate_y is selected and lit, command mode.
    let selected = s.frame_at(second_end + 1000);
    assert_eq!(selected.state, "command");
    assert_eq!(selected.selected, Some("translate_y"));
    let command = selected.command.unwrap();
    assert_eq!((command.mode, command.moving), ("translate_y", "stopped"));
    assert_eq!(command.returns_in_ms, 2000);
    assert!(selected.sequence.is_empty() && selected.waiting.is_none());
    assert_eq!(s.cues, [(second_end + 1000, Cue::Match)]);

    // A puff held in translate_y moves left; the countdown waits.
    let puff_start = second_end + 1500;
    let moving = s.frame_at(puff_start + 400);
    let command = moving.command.unwrap();
    assert_eq!((command.moving, command.arrow), ("left", "left"));
    assert!(command.countdown_paused);
    assert_eq!(moving.pressure.held, Some("puff"));

    // Released, the countdown runs from 2000 ms; at 0 the user is back in
    // selection, with the selection sound.
    s.frame_at(puff_start + 800 + 100);
    let puff_end = s.burst_end(2);
    let released = s.frame_at(puff_end + 500);
    let command = released.command.unwrap();
    assert_eq!(command.moving, "stopped");
    assert!(!command.countdown_paused);
    let back = s.frame_at(puff_end + 2100);
    assert_eq!(back.state, "selecting");
    assert!(back.command.is_none());
    let (at, cue) = *s.cues.last().unwrap();
    assert_eq!(cue, Cue::Selection);
    assert!(at > puff_end && at <= puff_end + 2100, "{at}");
    // The last selection stays lit until a new one begins.
    assert_eq!(back.selected, Some("translate_y"));
}

/// BSP: the highlight moves with the core's scan (3000 ms on the first
/// mode, then 1500 ms each), its time left shown; a puff enters it.
#[test]
fn bsp_highlight_moves_with_the_scan_and_a_puff_enters_it() {
    let config = Config::from_toml_str("[interface]\nkind = \"bsp\"\n").unwrap();
    let script = [rest(4000), puff(150), rest(3000)];
    let mut s = Session::new(&config, &script);
    let setup = s.screen.setup().clone();
    assert_eq!(setup.interface, "bsp");
    assert_eq!(setup.modes.len(), 9);
    assert!(setup.modes.iter().all(|m| m.sequences.is_empty()));

    let first = s.frame_at(1000);
    let h = first.highlight.unwrap();
    assert_eq!((h.mode, h.dwell_ms, h.ms_left), ("translate_x", 3000, 2000));
    let second = s.frame_at(3500);
    let h = second.highlight.unwrap();
    assert_eq!((h.mode, h.dwell_ms, h.ms_left), ("translate_y", 1500, 1000));

    // The puff began under translate_y (4000 ms < 4500): it enters it.
    let after = s.frame_at(4400);
    assert_eq!(after.state, "command");
    assert_eq!(after.selected, Some("translate_y"));
    assert!(after.highlight.is_none(), "no scan in command mode");
    let matched: Vec<_> = s
        .events
        .iter()
        .filter(|e| matches!(e.event, Event::Match { .. }))
        .map(|e| (e.tick, Cue::Match))
        .collect();
    assert_eq!(matched.len(), 1);
    assert_eq!(s.cues, matched, "one sound, at the match");
}

/// A sensor fault is said in plain words while it lasts, with the fault
/// sound; the arm's connection is shown.
#[test]
fn a_sensor_fault_is_said_in_plain_words_until_it_clears() {
    let config = common::paper_config();
    let script = [rest(500), Step::Dropout { ms: 500 }, rest(3000)];
    let mut s = Session::new(&config, &script);
    let faulted = s.frame_at(700);
    assert_eq!(faulted.notices.len(), 1, "{:?}", faulted.notices);
    assert_eq!(faulted.notices[0].level, "fault");
    assert_eq!(
        faulted.notices[0].text,
        "sensor sample is NaN — arm stopped"
    );
    assert_eq!(faulted.arm, "connected");
    assert!(s.cues.iter().any(|&(_, c)| c == Cue::Fault));
    let recovered = s.frame_at(3900);
    assert!(recovered.notices.is_empty(), "{:?}", recovered.notices);
}

/// The terminal view draws the same frames: rendered with ratatui's test
/// backend at the paper's moments (a 100 × 30 terminal).
/// What a terminal view drew, row by row.
fn screen_text(terminal: &ratatui::Terminal<ratatui::backend::TestBackend>) -> String {
    let buffer = terminal.backend().buffer();
    let width = buffer.area.width as usize;
    let cells: Vec<&str> = buffer.content().iter().map(|c| c.symbol()).collect();
    cells
        .chunks(width)
        .map(|row| row.concat())
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn the_terminal_view_shows_the_sequence_the_wait_and_the_motion() {
    use ratatui::Terminal;
    use ratatui::backend::TestBackend;
    use sipnpuff::display::tui::render;

    let config = common::paper_config();
    let mut s = Session::new(&config, &PAPER_SESSION);
    let mut terminal = Terminal::new(TestBackend::new(100, 30)).unwrap();
    let setup = s.screen.setup().clone();

    let start = s.frame_at(100);
    render(&mut terminal, &setup, &start).unwrap();
    let text = screen_text(&terminal);
    assert!(
        text.contains("Choose a mode: breathe its sequence"),
        "{text}"
    );
    assert!(
        text.contains("Forward / back") && text.contains("Up / down"),
        "{text}"
    );
    assert!(text.contains("You breathed: nothing yet"), "{text}");

    // After <1, 2>: the sequence, and the wait that selects translate_y.
    s.frame_at(500 + 150 + 300 + 700 + 100);
    let end = s.burst_end(1);
    let waiting = s.frame_at(end + 100);
    render(&mut terminal, &setup, &waiting).unwrap();
    let text = screen_text(&terminal);
    assert!(text.contains("You breathed:  sip   LONG SIP "), "{text}");
    assert!(text.contains("Left / right in 0.9 s"), "{text}");

    // Moving left in translate_y.
    let moving = s.frame_at(end + 1000 + 500 + 400);
    render(&mut terminal, &setup, &moving).unwrap();
    let text = screen_text(&terminal);
    assert!(
        text.contains("Left / right — puff and sip move the arm"),
        "{text}"
    );
    assert!(text.contains("Left / right: left"), "{text}");
    assert!(
        text.contains("breath held — staying in this mode"),
        "{text}"
    );
    assert!(text.contains("puff held"), "{text}");
}

/// A live calibration's screen (`sipnpuff fit`): the guide's words in the
/// frame, a sound per prompt, another for a breath not counted, and the
/// summary at the end; the run's frames carry none of it.
#[test]
fn a_calibrations_frames_carry_the_guides_words_sounds_and_summary() {
    use sipnpuff::fit::outcome::Outcome;
    use sipnpuff::fit::prompter::Prompter;
    use sipnpuff::fit::protocol::Protocol;

    let config = Config::default();
    let run = Screen::new(config.core(), "simulated JACO");
    assert_eq!(run.setup().view, "run");
    let json = serde_json::to_string(&run.frame()).unwrap();
    assert!(!json.contains("calibration"), "{json}");

    let mut screen = Screen::new(config.core(), "simulated JACO").fitting();
    assert_eq!(screen.setup().view, "fit");
    let mut prompter = Prompter::new(&Protocol::new(3, 0));
    let params = SignalParams::clean(config.core().detector(), 2).with_noise(0.01);
    // A sip when a puff is asked for, then the puff.
    let script = [rest(6000), sip(150), rest(1500), puff(150), rest(500)];
    let mut cues = Vec::new();
    let mut frames = Vec::new();
    for (t, volts) in SignalGenerator::new(params, &script).enumerate() {
        if let Some(say) = prompter.step(t as Tick, Sample::Volts(volts)) {
            cues.push(screen.calibrate(&prompter.view(), Some(&say)));
            frames.push(screen.frame().calibration.unwrap());
        }
    }
    assert_eq!(
        cues,
        [
            None,
            Some(Cue::Prompt),
            Some(Cue::Again),
            Some(Cue::Prompt),
            None
        ]
    );
    let shown: Vec<(&str, &str, &str, &str)> = frames
        .iter()
        .map(|c| {
            (
                c.phase,
                c.headline.as_str(),
                c.count.as_str(),
                c.message.as_str(),
            )
        })
        .collect();
    assert_eq!(
        shown,
        [
            (
                "rest",
                "rest, please",
                "",
                "rest, please: no sip or puff for 5 s while the sensor at rest is measured"
            ),
            ("prompt", "short puff — now", "1 of 3", ""),
            (
                "pause",
                "rest — wait for the prompt",
                "1 of 3",
                "that was a sip — again, a puff please"
            ),
            (
                "prompt",
                "short puff — now",
                "1 of 3",
                "that was a sip — again, a puff please"
            ),
            ("pause", "rest — wait for the prompt", "2 of 3", "got it"),
        ]
    );
    assert_eq!(frames[2].message_level, "again");
    assert_eq!(frames[4].block, "block 1 of 4: 3 short puffs");
    assert_eq!((frames[4].counted, frames[4].total), (1, 12));
    assert!((frames[4].rest_volts.unwrap() - 2.5).abs() < 0.01);

    screen.conclude(&Outcome {
        profile: Some("p.toml".into()),
        ..Outcome::default()
    });
    let end = screen.frame().calibration.unwrap();
    assert_eq!(end.phase, "summary");
    assert_eq!(end.headline, "fitted — the profile is written");
    assert_eq!(end.outcome.unwrap().profile.as_deref(), Some("p.toml"));
}

/// A library for the computer and the home: each entry shows as what it
/// does, in the library's order.
#[test]
fn entries_show_as_what_they_do() {
    let path = common::fixture("computer-and-home.toml");
    let config = sipnpuff::config::Config::from_file(&path).unwrap();
    let screen = sipnpuff::display::screen::Screen::new(config.core(), "sim");
    let shown: Vec<(&str, &str)> = screen
        .setup()
        .modes
        .iter()
        .map(|m| (m.mode.as_str(), m.label.as_str()))
        .collect();
    assert_eq!(
        shown,
        [
            ("translate_x", "Forward / back"),
            ("fingers", "Fingers"),
            ("pointer_x", "Pointer ←→"),
            ("pointer_y", "Pointer ↑↓"),
            ("scroll", "Scroll ↑↓"),
            ("drag", "Drag"),
            ("click:left", "Click: left"),
            ("key:ctrl+alt+t", "Ctrl+Alt+T"),
            ("event:lights_toggle", "Lights: toggle"),
            ("event:call_for_help", "Call for help"),
        ]
    );
}

/// A person who moves rather than breathes (the fixture's set and
/// library, the IMU alone): the setup says so (no pressure bar, the
/// head's dead zone and full scale), and each frame carries the head as
/// its trace draws it: near 0° at rest, moving while a gesture is made,
/// and in the mode the nod selects, pitched as far as the person holds
/// it, the arm going forward.
#[test]
fn a_head_users_frames_carry_the_head_for_its_trace() {
    use sipnpuff::control::imu::ImuInput;
    use sipnpuff::display::frame::HeadSetup;
    use sipnpuff::sim::head_gesture::GestureName;
    use sipnpuff::sim::imu_session::{Drive, drive_session};
    use sipnpuff::sim::imu_user::ImuUser;

    let config =
        Config::from_file(std::path::Path::new("fixtures/gesture-user/config.toml")).unwrap();
    let core = sipnpuff::session::gestures::imu_core(&config).unwrap();
    let person = ImuUser::builtin("typical").unwrap();
    let drive = Drive {
        gesture: GestureName::Nod,
        pitch_deg: 20.0,
        hold_ms: 1500,
    };
    let (session, holds) = drive_session(&person, &[drive], 4);
    let mut pipeline = Pipeline::new(&core);
    let mut screen = Screen::new(&core, "simulated JACO");
    assert!(!screen.setup().breath);
    assert_eq!(
        screen.setup().head,
        Some(HeadSetup {
            tilt: "pitch",
            dead_zone_deg: 12.0,
            full_scale_deg: 30.0
        })
    );
    let mut samples = session.samples.iter().peekable();
    let mut out = sipnpuff::control::tick::TickOutput::default();
    let (hold_start, hold_end) = holds[0];
    let mut at_rest = Vec::new();
    let mut moved = false;
    let mut held = Vec::new();
    for tick in 0..hold_end {
        let mut imu = ImuInput::Missing;
        while let Some((_, s)) = samples.next_if(|(t, _)| *t <= tick) {
            imu = ImuInput::Sample(*s);
        }
        let input = TickInput::imu(tick, imu);
        pipeline.step(&input, &mut out);
        screen.observe(&TickRecord {
            tick,
            input,
            view: pipeline.view(),
            ..TickRecord::default()
        });
        for event in out.events.iter() {
            screen.event(&TimedEvent {
                tick,
                event: *event,
            });
        }
        let frame = screen.frame();
        assert_eq!(frame.pressure.volts, None);
        let Some(head) = frame.head else { continue };
        if (1000..2500).contains(&tick) {
            at_rest.push(head.pitch_deg.abs().max(head.roll_deg.abs()));
        }
        moved |= head.moving && frame.state == "selecting";
        if tick >= hold_start + 500 {
            assert_eq!(frame.state, "command", "tick {tick}");
            assert_eq!(frame.command.unwrap().moving, "forward", "tick {tick}");
            held.push(head.pitch_deg);
        }
    }
    // The terminal view draws the head in place of the pressure bar.
    let mut terminal = ratatui::Terminal::new(ratatui::backend::TestBackend::new(100, 30)).unwrap();
    let frame = screen.frame();
    sipnpuff::display::tui::render(&mut terminal, screen.setup(), &frame).unwrap();
    let text = screen_text(&terminal);
    for said in [
        "Forward / back — tilting your head moves the arm",
        "Head: pitch past ±12° moves",
        "head tilted — staying in this mode",
    ] {
        assert!(text.contains(said), "{said}\n{text}");
    }
    assert!(!text.contains("Pressure"), "{text}");
    let most = |v: &[f64]| v.iter().copied().fold(f64::MIN, f64::max);
    assert!(most(&at_rest) < 2.0, "at rest: {}", most(&at_rest));
    assert!(moved, "the nod showed as a movement under way");
    let mean = held.iter().sum::<f64>() / held.len() as f64;
    assert!((mean - 20.0).abs() < 3.0, "held at {mean:.1}°");
}

/// A live gesture recording's screen (`gestures record`), fed by the
/// guide and a simulated person on simulated ticks: the phases in order,
/// a sound per prompt, the head from the IMU itself, the ordinary minute
/// counting down, and the end; a run's frames carry none of it.
#[test]
fn a_gesture_recordings_frames_follow_the_guide() {
    use sipnpuff::control::gesture::GestureConfig;
    use sipnpuff::gestures::guided::Guided;
    use sipnpuff::sim::guided_imu_user::GuidedImuUser;
    use sipnpuff::sim::head_gesture::GestureName;
    use sipnpuff::sim::imu_user::ImuUser;

    let config = Config::default();
    let run = Screen::new(config.core(), "simulated JACO");
    assert!(
        !serde_json::to_string(&run.frame())
            .unwrap()
            .contains("recording")
    );

    let names = vec!["nod".to_string()];
    let mut screen = Screen::new(config.core(), "none").recording_gestures(&names);
    assert_eq!(screen.setup().view, "gestures");
    let first = screen.frame().recording.unwrap();
    assert_eq!((first.phase, first.total), ("rest", 5));
    let user = ImuUser::builtin("typical").unwrap();
    let mut person = GuidedImuUser::new(user, &[GestureName::Nod], 2);
    let mut guide = Guided::new(1, GestureConfig::default());
    let (mut phases, mut cues, mut left) = (Vec::new(), Vec::new(), Vec::new());
    let mut tick = 0;
    while !guide.is_over() {
        let input = person.input(tick);
        screen.observe_imu(tick, input);
        if let Some(say) = guide.step(tick, input) {
            person.hear(tick, &say);
            let seen = guide.examples().iter().map(Vec::len).sum();
            cues.extend(screen.guide_gestures(tick, &say, seen, 3360));
            let frame = screen.frame().recording.unwrap();
            if phases.last() != Some(&frame.phase) {
                phases.push(frame.phase);
            }
        }
        let frame = screen.frame();
        if let Some(ms) = frame.recording.unwrap().ordinary_ms_left {
            left.push(ms);
        }
        if tick == 2000 {
            let head = frame.head.expect("the head from the IMU");
            assert!(head.pitch_deg.abs() < 2.0, "{head:?}");
        }
        tick += 1;
    }
    assert_eq!(
        phases,
        [
            "rest", "prompt", "between", "prompt", "between", "prompt", "between", "prompt",
            "between", "prompt", "between", "ordinary", "finished"
        ]
    );
    assert_eq!(cues.iter().filter(|c| **c == Cue::Prompt).count(), 6);
    assert_eq!(cues.last(), Some(&Cue::Done));
    assert_eq!(left.first(), Some(&61_000));
    assert!(left.windows(2).all(|w| w[1] <= w[0]));
    screen.conclude_gestures("written".into(), true);
    let end = screen.frame().recording.unwrap();
    assert_eq!(
        (end.phase, end.headline.as_str()),
        ("summary", "Gesture set written")
    );
    assert_eq!(end.seen, 5);
}
