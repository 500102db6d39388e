//! The display in a real browser: Debian's headless Chromium, driven
//! through ChromeDriver (WebDriver), opens the page `sipnpuff run` serves
//! while a scripted user breathes into the CSV sensor. At scripted moments
//! (each marked by the run's own event on stdout) the page must show the
//! expected mode, sequence, lit and dimmed sequences, scan highlight,
//! direction and fault; a screenshot of each moment is kept in
//! `target/screenshots/`. The run's report with the page open is compared
//! with the same run without the display, and a client that never reads
//! its stream is shown not to disturb the loop.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use serde_json::{Value, json};
use sipnpuff::config::Config;
use sipnpuff::sim::sensor_model::{SignalGenerator, SignalParams, Step, write_csv};

use crate::common::{self, Running, free_port, poll_until, puff, rest, sip};
use crate::scratch::Scratch;

const CHROMIUM: &str = "/usr/bin/chromium";
const CHROMEDRIVER: &str = "/usr/bin/chromedriver";

/// One browser at a time: on 2 cores, two Chromiums rendering beside
/// real-time runs starve the runs' sensor threads.
static ONE_BROWSER: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Runs a real-time test (see [`common::real_time`]) if Chromium and
/// ChromeDriver are installed (tests/peers/browser/install.sh), one
/// browser test at a time; says why not otherwise (or fails, when peers
/// are required).
pub(crate) fn browser_test(test: impl Fn()) {
    let missing = [CHROMIUM, CHROMEDRIVER]
        .iter()
        .find(|p| !Path::new(p).exists())
        .map(|p| format!("{p} is missing (bash tests/peers/browser/install.sh)"));
    if common::have_peer(missing) {
        let _one = ONE_BROWSER.lock().unwrap_or_else(|e| e.into_inner());
        common::real_time(test);
    }
}

/// Where the screenshots go (CI keeps the directory).
fn screenshots() -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/screenshots");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A scripted session in a real browser: its config and recording in a
/// scratch folder, the browser, and `sipnpuff run` on them with the
/// display, its page served.
struct Session {
    config: PathBuf,
    csv: PathBuf,
    browser: Browser,
    port: u16,
    run: Running,
    /// Held until the test ends (the quiet run reads it again).
    _dir: Scratch,
}

impl Session {
    /// Writes `config_toml` and the recording of `script`, starts the
    /// browser and then the run (the browser first: its start-up, seconds
    /// on a loaded machine, must not eat into the rest before the first
    /// breath) and waits until the page is served.
    fn start(config_toml: &str, script: &[Step]) -> Session {
        let dir = Scratch::new();
        let config = Config::from_toml_str(config_toml).expect("the test's config");
        let params = SignalParams::clean(config.core().detector(), 7);
        let csv = dir.join("session.csv");
        let mut out = std::io::BufWriter::new(std::fs::File::create(&csv).unwrap());
        write_csv(&mut out, SignalGenerator::new(params, script)).unwrap();
        out.flush().unwrap();
        let config = dir.join("config.toml");
        std::fs::write(&config, config_toml).unwrap();
        let browser = Browser::start();
        let port = free_port();
        let run = run(&config, &csv, Some(port));
        wait_for_page(port);
        Session {
            config,
            csv,
            browser,
            port,
            run,
            _dir: dir,
        }
    }
}

/// A WebDriver session in headless Chromium.
pub(crate) struct Browser {
    /// Ended (dropped) after its session is deleted.
    _driver: Running,
    base: String,
    session: String,
}

impl Browser {
    pub(crate) fn start() -> Browser {
        let port = free_port();
        let mut command = Command::new(CHROMEDRIVER);
        command.arg(format!("--port={port}"));
        let driver = Running::start(command);
        let base = format!("http://127.0.0.1:{port}");
        assert!(
            poll_until(Duration::from_secs(30), Duration::from_millis(100), || {
                ureq::get(format!("{base}/status")).call().is_ok()
            }),
            "chromedriver did not answer on {base}"
        );
        let capabilities = json!({"capabilities": {"alwaysMatch": {
            "browserName": "chrome",
            "goog:chromeOptions": {
                "binary": CHROMIUM,
                "args": ["--headless=new", "--no-sandbox", "--disable-gpu",
                         "--disable-dev-shm-usage", "--hide-scrollbars",
                         "--window-size=1024,743", // a 1024 × 600 page, as on a 7-inch screen
                         "--autoplay-policy=no-user-gesture-required"]
            }
        }}});
        let reply: Value = ureq::post(format!("{base}/session"))
            .send_json(&capabilities)
            .expect("a browser session")
            .body_mut()
            .read_json()
            .unwrap();
        let session = reply["value"]["sessionId"].as_str().unwrap().to_string();
        Browser {
            _driver: driver,
            base,
            session,
        }
    }

    fn url(&self, path: &str) -> String {
        format!("{}/session/{}/{path}", self.base, self.session)
    }

    pub(crate) fn open(&self, page: &str) {
        ureq::post(self.url("url"))
            .send_json(json!({ "url": page }))
            .expect("the page opens");
    }

    /// Runs `script` in the page; its return value.
    pub(crate) fn eval(&self, script: &str) -> Value {
        let mut reply = ureq::post(self.url("execute/sync"))
            .send_json(json!({ "script": script, "args": [] }))
            .expect("the script runs");
        let reply: Value = reply.body_mut().read_json().unwrap();
        reply["value"].clone()
    }

    /// What the page shows, read from its elements.
    fn shown(&self) -> Value {
        self.eval(SHOWN)
    }

    /// Waits until `check` holds for what the page shows (or 5 s pass:
    /// then fails with what it showed). Returns what it showed.
    fn until(&self, what: &str, check: impl Fn(&Value) -> bool) -> Value {
        let started = Instant::now();
        loop {
            let shown = self.shown();
            if check(&shown) {
                return shown;
            }
            assert!(
                started.elapsed() < Duration::from_secs(5),
                "the page never showed {what}; it showed {shown:#}"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Keeps a screenshot of the page as `name`.png, and fails unless the
    /// page fits the 7-inch kiosk's 1024 × 600 without scrolling.
    pub(crate) fn screenshot(&self, name: &str) -> PathBuf {
        let size = self.eval(
            "const d = document.documentElement; \
             return { width: d.scrollWidth, height: d.scrollHeight, \
                      window_width: window.innerWidth, window_height: window.innerHeight };",
        );
        let reply: Value = ureq::get(self.url("screenshot"))
            .call()
            .expect("a screenshot")
            .body_mut()
            .read_json()
            .unwrap();
        use base64::Engine;
        let png = base64::engine::general_purpose::STANDARD
            .decode(reply["value"].as_str().unwrap())
            .unwrap();
        assert_eq!(&png[1..4], b"PNG");
        let path = screenshots().join(format!("{name}.png"));
        std::fs::write(&path, png).unwrap();
        eprintln!("screenshot: {}", path.display());
        assert_eq!(
            (&size["window_width"], &size["window_height"]),
            (&json!(1024), &json!(600)),
            "{name}: {size}"
        );
        assert!(
            size["height"].as_u64().unwrap() <= 600 && size["width"].as_u64().unwrap() <= 1024,
            "{name}: the page scrolls at 1024 × 600: {size}"
        );
        path
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = ureq::delete(format!("{}/session/{}", self.base, self.session)).call();
    }
}

/// The page's elements, as the user would read them.
const SHOWN: &str = r##"
const q = (s) => Array.from(document.querySelectorAll(s));
const text = (id) => document.getElementById(id).textContent;
return {
  state: document.body.dataset.state,
  interface: document.body.dataset.interface,
  frames: window.sipnpuff.frames,
  banner: text("banner-text"),
  entered: q("#entered .sym").map((e) => e.getAttribute("aria-label")),
  lit: q(".seq.lit").map((e) => Number(e.dataset.index)),
  dim: q(".seq.dim").map((e) => Number(e.dataset.index)),
  dim_modes: q(".mode.dim").map((e) => e.dataset.mode),
  selected: q(".mode.selected").map((e) => e.dataset.mode),
  last: q(".mode.last").map((e) => e.dataset.mode),
  highlight: q(".mode.highlight").map((e) => e.dataset.mode),
  wait: text("wait-text"),
  direction: text("direction-text"),
  arrow: text("arrow"),
  countdown: text("countdown-text"),
  held: text("held-text"),
  notices: q("#notices .notice").map((e) => e.className.replace("notice ", "") + ": " + e.textContent),
  latencies: window.sipnpuff.latencies.map((l) => l.ms),
  cues: window.sipnpuff.cues.map((c) => c.cue),
};
"##;

fn strings(value: &Value) -> Vec<String> {
    value
        .as_array()
        .map(|a| {
            a.iter()
                .map(|v| v.as_str().unwrap_or_default().to_string())
                .collect()
        })
        .unwrap_or_default()
}

fn numbers(value: &Value) -> Vec<u64> {
    value
        .as_array()
        .map(|a| a.iter().filter_map(Value::as_u64).collect())
        .unwrap_or_default()
}

/// `sipnpuff run` on `csv` with `config`, the display on `port` (or off).
fn run(config: &Path, csv: &Path, port: Option<u16>) -> Running {
    let mut command = Command::new(env!("CARGO_BIN_EXE_sipnpuff"));
    command.args([
        "run",
        "--json",
        "--config",
        config.to_str().unwrap(),
        "--sensor",
        &format!("csv:{}", csv.display()),
    ]);
    match port {
        Some(port) => command
            .args(["--display", &format!("127.0.0.1:{port}")])
            .env_remove("SIPNPUFF_NO_DISPLAY"),
        None => command.arg("--no-display"),
    };
    Running::start(command)
}

/// A client of the page's event stream with a 1 KiB receive buffer that
/// never reads.
fn stalled_client(port: u16) -> std::net::TcpStream {
    use std::os::fd::FromRawFd;
    // SAFETY: plain socket calls on a descriptor this function owns; the
    // address is a valid sockaddr_in of the size given.
    unsafe {
        let fd = libc::socket(libc::AF_INET, libc::SOCK_STREAM, 0);
        assert!(fd >= 0);
        let size: libc::c_int = 1024;
        libc::setsockopt(
            fd,
            libc::SOL_SOCKET,
            libc::SO_RCVBUF,
            (&size as *const libc::c_int).cast(),
            std::mem::size_of::<libc::c_int>() as libc::socklen_t,
        );
        let address = libc::sockaddr_in {
            sin_family: libc::AF_INET as libc::sa_family_t,
            sin_port: port.to_be(),
            sin_addr: libc::in_addr {
                s_addr: u32::from_be_bytes([127, 0, 0, 1]).to_be(),
            },
            sin_zero: [0; 8],
        };
        let rc = libc::connect(
            fd,
            (&address as *const libc::sockaddr_in).cast(),
            std::mem::size_of::<libc::sockaddr_in>() as libc::socklen_t,
        );
        assert_eq!(rc, 0, "connect to the page's server");
        let mut stream = std::net::TcpStream::from_raw_fd(fd);
        stream
            .write_all(b"GET /events HTTP/1.1\r\nHost: x\r\n\r\n")
            .unwrap();
        stream
    }
}

/// The report (the last stdout line, `--json`) and the event lines.
fn report_and_events(lines: &[String]) -> (Value, Vec<Value>) {
    let report: Value = serde_json::from_str(lines.last().expect("a report")).unwrap();
    let events = lines[..lines.len() - 1]
        .iter()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    (report, events)
}

/// The events without their ticks (a run that skipped ticks shifts them).
fn kinds(events: &[Value]) -> Vec<String> {
    events
        .iter()
        .map(|e| {
            let mut e = e.clone();
            let object = e.as_object_mut().unwrap();
            for key in ["tick", "start_tick", "duration_ms", "position"] {
                object.remove(key);
            }
            e.to_string()
        })
        .collect()
}

fn median(values: &mut [u64]) -> u64 {
    values.sort_unstable();
    values.get(values.len() / 2).copied().unwrap_or(0)
}

/// The paper's library with time to read the screen: after the short sip
/// and after the long sip the matcher waits 3 s.
const ASP_CONFIG: &str = r#"
[detector]
neutral_volts = 2.5
puff_threshold_volts = 3.0
sip_threshold_volts = 2.0
hysteresis_volts = 0.1
min_burst_ms = 40
long_burst_ms = 500

[matcher]
sequence_timeout_ms = 3000

[command]
inactivity_timeout_ms = 3000

[[sequence]]
actions = [1, 2, -1]
mode = "translate_x"

[[sequence]]
actions = [1, 2]
mode = "translate_y"

[[sequence]]
actions = [2, 1]
mode = "translate_z"
"#;

/// ASP: S1 = <1, 2, −1> translate_x, S2 = <1, 2> translate_y, S3 = <2, 1>
/// translate_z. The user breathes a short sip, a long sip (S2 complete, S1
/// still possible: the matcher waits on the prefix), lets it select
/// translate_y, puffs to move left, lets it return to selection, then the
/// sensor drops out.
#[test]
fn asp_in_a_real_browser_shows_sequences_waits_modes_directions_and_faults() {
    browser_test(|| {
        let script = [
            rest(2500),
            sip(150),
            rest(1500),
            sip(700),
            rest(4000), // the wait on the prefix ends: translate_y
            puff(2500), // left
            rest(4000), // back to selection
            Step::Dropout { ms: 1500 },
            rest(1500),
        ];
        let Session {
            config,
            csv,
            browser,
            port,
            mut run,
            _dir,
        } = Session::start(ASP_CONFIG, &script);
        // A client that connects to the stream and never reads it (a
        // receive buffer of 1 KiB): the run must not notice it, and must
        // end with it still connected.
        let stalled = stalled_client(port);
        browser.open(&format!("http://127.0.0.1:{port}/"));
        let start = browser.until("the modes", |s| s["state"] == "selecting");
        assert_eq!(start["interface"], "asp");
        assert!(strings(&start["entered"]).is_empty(), "{start:#}");
        browser.screenshot("asp-0-choose-a-mode");

        // The short sip: S1 and S2 lit, S3 dimmed, the sequence is no
        // mode yet (it is dropped unless the user goes on).
        run.wait_for("\"event\":\"burst\"");
        let first = browser.until("the short sip", |s| strings(&s["entered"]) == ["short sip"]);
        assert_eq!(numbers(&first["lit"]), [0, 1], "{first:#}");
        assert_eq!(numbers(&first["dim"]), [2], "{first:#}");
        assert_eq!(strings(&first["dim_modes"]), ["translate_z"]);
        assert!(
            first["wait"]
                .as_str()
                .unwrap()
                .starts_with("start again in"),
            "{first:#}"
        );
        browser.screenshot("asp-1-first-breath");

        // The long sip: <1, 2> is S2, and S1 could follow: the page says
        // which mode the wait selects.
        run.wait_for("\"event\":\"burst\"");
        let waiting = browser.until("the wait on the prefix", |s| {
            strings(&s["entered"]) == ["short sip", "long sip"]
        });
        assert_eq!(numbers(&waiting["lit"]), [0, 1], "{waiting:#}");
        assert_eq!(numbers(&waiting["dim"]), [2]);
        assert!(
            waiting["wait"]
                .as_str()
                .unwrap()
                .starts_with("Left / right in "),
            "{waiting:#}"
        );
        browser.screenshot("asp-2-waiting-on-a-prefix");

        // The wait ends: translate_y is selected, lit, command mode.
        run.wait_for("\"mode\":\"translate_y\"");
        let selected = browser.until("command mode", |s| s["state"] == "command");
        assert_eq!(strings(&selected["selected"]), ["translate_y"]);
        assert_eq!(selected["banner"], "Left / right");
        assert_eq!(selected["direction"], "stopped");
        assert!(strings(&selected["entered"]).is_empty());
        browser.screenshot("asp-3-translate-y-selected");

        // The puff moves left, the countdown waits while it is held.
        let moving = browser.until("moving left", |s| s["direction"] == "left");
        assert_eq!(moving["arrow"], "⇦");
        assert_eq!(moving["countdown"], "breath held — staying in this mode");
        assert!(moving["held"].as_str().unwrap().starts_with("puff held"));
        browser.screenshot("asp-4-moving-left");

        // Inactivity: back to choosing a mode, with its sound.
        run.wait_for("\"reason\":\"inactivity\"");
        let back = browser.until("selection again", |s| s["state"] == "selecting");
        assert_eq!(back["banner"], "Choose a mode");
        // The mode left is marked as the last used, not lit as if in it.
        assert!(strings(&back["selected"]).is_empty(), "{back:#}");
        assert_eq!(strings(&back["last"]), ["translate_y"]);

        // The sensor drops out: said in plain words, with the fault sound.
        run.wait_for("\"event\":\"fault\"");
        let fault = browser.until("the fault", |s| !strings(&s["notices"]).is_empty());
        assert_eq!(fault["banner"], "Fault — the arm is stopped");
        let notices = strings(&fault["notices"]);
        assert!(
            notices[0].starts_with("fault: sensor") && notices[0].ends_with("arm stopped"),
            "{notices:?}"
        );
        browser.screenshot("asp-5-sensor-fault");

        let (status, lines, stderr) = run.finish();
        assert_eq!(
            status.code(),
            Some(1),
            "the session's sensor fault fails the run: {status}: {stderr}"
        );
        let page = browser.shown();
        let cues = strings(&page["cues"]);
        for cue in ["match", "selection", "fault"] {
            assert!(cues.iter().any(|c| c == cue), "no {cue} sound: {cues:?}");
        }
        let mut latencies = numbers(&page["latencies"]);
        assert!(!latencies.is_empty());
        let worst = latencies.iter().max().copied().unwrap();
        let median_ms = median(&mut latencies);
        eprintln!(
            "event-to-screen latency in Chromium: median {median_ms} ms, worst {worst} ms over {} events",
            latencies.len()
        );
        drop(stalled);

        // The same session without the display: the same events, and in
        // both the control thread allocated nothing.
        let (with_page, events_with) = report_and_events(&lines);
        let quiet = self::run(&config, &csv, None);
        let (status, lines, stderr) = quiet.finish();
        assert_eq!(
            status.code(),
            Some(1),
            "the session's sensor fault fails the run: {status}: {stderr}"
        );
        let (without, events_without) = report_and_events(&lines);
        for (name, report) in [("with the page", &with_page), ("without", &without)] {
            assert_eq!(report["control_thread_allocations"], 0, "{name}");
            eprintln!(
                "{name}: compute p50 {} ns p99 {} ns, wake p99 {} ns, missed deadlines {}, skipped ticks {}",
                report["full"]["compute_ns"]["p50"],
                report["full"]["compute_ns"]["p99"],
                report["full"]["wake_latency_ns"]["p99"],
                report["stats"]["missed_deadlines"],
                report["stats"]["skipped_ticks"]
            );
        }
        if with_page["stats"]["skipped_ticks"] == 0 && without["stats"]["skipped_ticks"] == 0 {
            assert_eq!(kinds(&events_with), kinds(&events_without));
        }
        let display = &with_page["display"];
        assert!(display["pages_opened"].as_u64().unwrap() >= 2, "{display}");

        assert!(without["display"].is_null());
        eprintln!("display with a stalled client: {display}");
    });
}

/// BSP: the highlight moves with the core's scan; a puff enters the
/// highlighted mode.
#[test]
fn bsp_in_a_real_browser_moves_the_highlight_with_the_scan() {
    browser_test(|| {
        // Scan: translate_x for 3 s, then translate_y for 1.5 s; the puff
        // begins under translate_y.
        let script = [rest(3600), puff(200), rest(1500), puff(1500), rest(1000)];
        let Session {
            browser,
            port,
            mut run,
            _dir,
            ..
        } = Session::start("[interface]\nkind = \"bsp\"\n", &script);
        browser.open(&format!("http://127.0.0.1:{port}/"));
        let first = browser.until("the scan", |s| {
            s["interface"] == "bsp" && !strings(&s["highlight"]).is_empty()
        });
        assert_eq!(first["state"], "selecting");
        run.wait_for("\"mode\":\"translate_y\"");
        let second = browser.until("the highlight on translate_y", |s| {
            strings(&s["highlight"]) == ["translate_y"]
        });
        assert_eq!(strings(&second["highlight"]).len(), 1);
        browser.screenshot("bsp-1-scan-on-left-right");
        run.wait_for("\"event\":\"match\"");
        let entered = browser.until("command mode", |s| s["state"] == "command");
        assert_eq!(strings(&entered["selected"]), ["translate_y"]);
        assert!(strings(&entered["highlight"]).is_empty());
        let moving = browser.until("moving left", |s| s["direction"] == "left");
        assert_eq!(moving["banner"], "Left / right");
        browser.screenshot("bsp-2-moving-left");
        let (status, _, stderr) = run.finish();
        assert!(status.success(), "{status}: {stderr}");
    });
}

/// A page that stops reading skips frames — the latest replaces them —
/// and nothing queues for it, however fast frames are published: the real
/// server over loopback, a client with a 1 KiB receive buffer that never
/// reads, and 20 000 frames published as fast as the hub can; a page that
/// reads gets the last one.
#[test]
fn a_page_that_stops_reading_skips_frames_and_holds_up_nothing() {
    use sipnpuff::control::event::{Event, TimedEvent};
    use sipnpuff::display::hub::DisplayHub;
    use sipnpuff::display::server::DisplayServer;
    use sipnpuff::rt::telemetry::{TelemetryObserver, TickRecord};
    use std::io::{BufRead, BufReader};

    let config = common::paper_config();
    let mut hub = DisplayHub::new(config.core(), "simulated JACO");
    let listener = DisplayServer::bind("127.0.0.1:0".parse().unwrap()).unwrap();
    let server = DisplayServer::serve(listener, hub.feed()).unwrap();
    let port = server.address().port();
    let stalled = stalled_client(port);
    let feed = hub.feed();
    let started = Instant::now();
    while feed
        .stats
        .pages_open
        .load(std::sync::atomic::Ordering::Relaxed)
        == 0
    {
        assert!(started.elapsed() < Duration::from_secs(10), "no page");
        std::thread::sleep(Duration::from_millis(5));
    }
    const FRAMES: u64 = 20_000;
    for tick in 0..FRAMES {
        hub.record(&TickRecord {
            tick,
            ..TickRecord::default()
        });
        // An event every tick publishes a frame every tick.
        hub.event(&TimedEvent {
            tick,
            event: Event::Recovered,
        });
        hub.drained();
        if tick % 1000 == 0 {
            std::thread::sleep(Duration::from_millis(10));
        }
    }
    std::thread::sleep(Duration::from_millis(300));
    let summary = feed.summary(None);
    eprintln!("{summary:?}");
    assert_eq!(summary.counts.frames_published, FRAMES + 1);
    assert!(summary.counts.frames_skipped > 0, "{summary:?}");
    assert!(summary.counts.frames_sent < FRAMES, "{summary:?}");

    // A page that reads now gets the setup and the latest frame at once.
    let mut reader = BufReader::new(std::net::TcpStream::connect(("127.0.0.1", port)).unwrap());
    reader
        .get_mut()
        .write_all(b"GET /events HTTP/1.1\r\nHost: x\r\n\r\n")
        .unwrap();
    let mut frame = None;
    let mut line = String::new();
    while frame.is_none() {
        line.clear();
        assert!(reader.read_line(&mut line).unwrap() > 0, "the stream ended");
        if let Some(data) = line.strip_prefix("data: ")
            && data.contains("\"seq\"")
        {
            frame = Some(serde_json::from_str::<Value>(data).unwrap());
        }
    }
    let frame = frame.unwrap();
    assert_eq!(frame["seq"], FRAMES + 1);
    assert_eq!(frame["tick"], FRAMES - 1);
    drop(stalled);
    drop(server);
}

/// Waits until the page's server on `port` answers (30 s at most).
pub fn wait_for_page(port: u16) {
    assert!(
        poll_until(Duration::from_secs(30), Duration::from_millis(20), || {
            ureq::get(format!("http://127.0.0.1:{port}/state"))
                .call()
                .is_ok()
        }),
        "no page served"
    );
}

/// What the head panel shows.
const HEAD_SHOWN: &str = r##"
const f = window.sipnpuff.state.frame;
return {
  state: document.body.dataset.state,
  breath: document.body.dataset.breath,
  head: document.body.dataset.head,
  pressure_shown: getComputedStyle(document.getElementById("pressure-panel")).display !== "none",
  head_shown: getComputedStyle(document.getElementById("head-panel")).display !== "none",
  head_text: document.getElementById("head-text").textContent,
  pitch: f && f.head ? f.head.pitch_deg : null,
  entered_title: document.getElementById("entered-title").textContent,
  glyphs: Array.from(document.querySelectorAll("#modes .sym.gesture")).map((e) => e.textContent),
  direction: document.getElementById("direction-text").textContent,
  countdown: document.getElementById("countdown-text").textContent,
};
"##;

/// `sipnpuff run` with the display on `port`, its sensors and config.
fn run_with(args: &[&str], port: u16) -> Running {
    let mut command = Command::new(env!("CARGO_BIN_EXE_sipnpuff"));
    command
        .args(["run", "--json"])
        .args(args)
        .args(["--display", &format!("127.0.0.1:{port}")])
        .env_remove("SIPNPUFF_NO_DISPLAY");
    Running::start(command)
}

/// Waits (10 s at most) until `check` holds for what the head panel
/// shows; returns it.
fn until_head(browser: &Browser, what: &str, check: impl Fn(&Value) -> bool) -> Value {
    let started = Instant::now();
    loop {
        let shown = browser.eval(HEAD_SHOWN);
        if check(&shown) {
            return shown;
        }
        assert!(
            started.elapsed() < Duration::from_secs(10),
            "the page never showed {what}; it showed {shown:#}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// A person who moves rather than breathes, in a real browser: the head's
/// trace in place of the pressure bar, the gestures listed as words with
/// their glyphs, and in the mode a nod selects, the head pitched past the
/// dead zone moving the arm forward. A person who does both sees both.
/// Each page fits the 7-inch 1024 × 600 kiosk without scrolling (each
/// screenshot checks it).
#[test]
fn a_head_users_page_traces_the_head_and_fits_the_kiosk() {
    use sipnpuff::control::imu::Channels;
    use sipnpuff::sim::head_gesture::GestureName;
    use sipnpuff::sim::imu_session::{Drive, drive_session};
    use sipnpuff::sim::imu_user::ImuUser;
    use sipnpuff::tools::imu_csv::write_imu_csv;

    let dir = Scratch::new();
    let person = ImuUser::builtin("typical").unwrap();
    let drive = Drive {
        gesture: GestureName::Nod,
        pitch_deg: 22.0,
        hold_ms: 4000,
    };
    let (session, _) = drive_session(&person, &[drive], 4);
    let imu = dir.join("imu.csv");
    let mut text = Vec::new();
    write_imu_csv(&mut text, Channels::ALL, &session.samples).unwrap();
    std::fs::write(&imu, text).unwrap();
    let imu_sensor = format!("csv:{}", imu.display());
    // A breath recording at rest beside it, as long.
    let config = Config::default();
    let params = SignalParams::clean(config.core().detector(), 7);
    let breath = dir.join("breath.csv");
    let ms = session.samples.last().unwrap().0 as u32 + 2000;
    let mut out = std::io::BufWriter::new(std::fs::File::create(&breath).unwrap());
    write_csv(&mut out, SignalGenerator::new(params, &[rest(ms)])).unwrap();
    out.flush().unwrap();
    let breath_sensor = format!("csv:{}", breath.display());
    browser_test(|| {
        let browser = Browser::start();
        // The head alone.
        let port = free_port();
        let run = run_with(
            &[
                "--sensor",
                &imu_sensor,
                "--config",
                "fixtures/gesture-user/config.toml",
            ],
            port,
        );
        wait_for_page(port);
        browser.open(&format!("http://127.0.0.1:{port}/"));
        let shown = until_head(&browser, "the head panel", |s| {
            s["head_shown"] == true && s["pitch"].is_number()
        });
        assert_eq!(shown["pressure_shown"], false, "{shown}");
        assert_eq!(shown["entered_title"], "Your sequence");
        assert!(
            strings(&shown["glyphs"]).contains(&"↕nod".to_string()),
            "{shown}"
        );
        assert!(
            strings(&shown["glyphs"]).contains(&"↷tilt right".to_string()),
            "{shown}"
        );
        browser.screenshot("head-selecting");
        let shown = until_head(&browser, "the head pitched past the dead zone", |s| {
            s["state"] == "command" && s["pitch"].as_f64().is_some_and(|p| p > 15.0)
        });
        assert_eq!(shown["direction"], "forward", "{shown}");
        assert_eq!(
            shown["countdown"], "head tilted — staying in this mode",
            "{shown}"
        );
        assert!(
            shown["head_text"].as_str().unwrap().starts_with("pitch +"),
            "{shown}"
        );
        assert_eq!(
            browser.eval("return document.getElementById('head-title').textContent;"),
            "Head — pitch past ±12° moves"
        );
        browser.screenshot("head-command");
        let (status, _, stderr) = run.finish();
        assert_eq!(status.code(), Some(0), "{stderr}");

        // Breath and head: both panels.
        let port = free_port();
        let run = run_with(
            &[
                "--sensor",
                &breath_sensor,
                "--imu",
                &imu_sensor,
                "--config",
                "fixtures/gesture-user/config.toml",
            ],
            port,
        );
        wait_for_page(port);
        browser.open(&format!("http://127.0.0.1:{port}/"));
        let shown = until_head(&browser, "both panels", |s| {
            s["head_shown"] == true && s["pressure_shown"] == true && s["pitch"].is_number()
        });
        assert_eq!(shown["breath"], "yes");
        browser.screenshot("head-and-breath");
        let (status, _, stderr) = run.finish();
        assert_eq!(status.code(), Some(0), "{stderr}");
    });
}

/// What a live gesture recording's page shows.
const RECORDING_SHOWN: &str = r##"
const text = (id) => document.getElementById(id).textContent;
const f = window.sipnpuff.state.frame;
return {
  view: document.body.dataset.view,
  phase: document.body.dataset.gestPhase,
  headline: text("gest-headline"),
  gesture: text("gest-gesture"),
  count: text("gest-count"),
  message: text("gest-message"),
  progress: text("gest-progress-text"),
  summary: text("gest-summary"),
  head_shown: getComputedStyle(document.getElementById("head-panel")).display !== "none",
  pitch: f && f.head ? f.head.pitch_deg : null,
  ended: !!window.sipnpuff.ended,
  cues: window.sipnpuff.cues.map((c) => c.cue),
};
"##;

/// `gestures record --sensor synthetic:typical` on the page, in a real
/// browser: the prompt large with its gesture and count, the head's
/// trace, the news of each example seen, the ordinary minute counting
/// down, and at the end the set written — the page keeping it after the
/// command has exited. Every screenshot fits 1024 × 600.
#[test]
fn a_live_gesture_recording_is_guided_on_the_page() {
    browser_test(|| {
        let dir = Scratch::new();
        let set = dir.join("sam.toml");
        let browser = Browser::start();
        let port = free_port();
        let mut command = Command::new(env!("CARGO_BIN_EXE_sipnpuff"));
        command
            .args([
                "gestures",
                "record",
                "--sensor",
                "synthetic:typical",
                "--gestures",
                "nod",
                "--display",
                &format!("127.0.0.1:{port}"),
            ])
            .arg("--out")
            .arg(&set)
            .env_remove("SIPNPUFF_NO_DISPLAY");
        let run = Running::start(command);
        wait_for_page(port);
        browser.open(&format!("http://127.0.0.1:{port}/"));
        let until = |what: &str, limit: u64, check: &dyn Fn(&Value) -> bool| {
            let started = Instant::now();
            loop {
                let shown = browser.eval(RECORDING_SHOWN);
                if check(&shown) {
                    return shown;
                }
                assert!(
                    started.elapsed() < Duration::from_secs(limit),
                    "the page never showed {what}; it showed {shown:#}"
                );
                std::thread::sleep(Duration::from_millis(20));
            }
        };
        let shown = until("the first prompt", 15, &|s| s["headline"] == "nod — now");
        assert_eq!(shown["view"], "gestures");
        assert_eq!(shown["gesture"], "gesture 1 of 1: nod");
        assert_eq!(shown["count"], "1 of 5");
        assert_eq!(shown["head_shown"], true);
        browser.screenshot("gestures-1-prompt");
        let shown = until("an example seen", 10, &|s| {
            s["message"]
                .as_str()
                .unwrap_or_default()
                .starts_with("seen (")
        });
        assert_eq!(shown["headline"], "rest");
        assert!(shown["pitch"].is_number(), "{shown}");
        let shown = until("the ordinary minute", 40, &|s| s["phase"] == "ordinary");
        assert_eq!(shown["progress"], "5 of 5 examples");
        assert!(
            shown["count"].as_str().unwrap().ends_with(" s left"),
            "{shown}"
        );
        browser.screenshot("gestures-2-ordinary");
        let shown = until("the summary", 75, &|s| {
            s["phase"] == "summary" && s["ended"] == true
        });
        assert_eq!(shown["headline"], "");
        let summary = shown["summary"].as_str().unwrap();
        assert!(
            summary.starts_with(&format!(
                "written to {}: leave-one-out 5/5 right",
                set.display()
            )),
            "{shown}"
        );
        let cues = strings(&shown["cues"]);
        assert_eq!(
            cues.iter().filter(|c| *c == "prompt").count(),
            6,
            "{cues:?}"
        );
        assert_eq!(cues.last().map(String::as_str), Some("done"), "{cues:?}");
        browser.screenshot("gestures-3-summary");
        let (status, _, stderr) = run.finish();
        assert_eq!(status.code(), Some(0), "{stderr}");
        assert!(set.exists());
    });
}
