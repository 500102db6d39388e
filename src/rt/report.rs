//! The run report: what a run did, for people (`to_text`) and as JSON
//! (`run --json`, derived from the struct through serde: nothing is left
//! out).

use std::path::{Path, PathBuf};

use hdrhistogram::Histogram;
use serde::Serialize;

use crate::arm::ArmState;
use crate::control::motion::stream::ArmCommand;
use crate::output::OutputReport;
use crate::rt::arm_thread::ArmReport;
use crate::rt::control_loop::{LoopResult, SensorFaults, StopReason};
use crate::rt::recorder::RecordingReport;
use crate::rt::scheduler::SchedulerStats;
use crate::rt::serving::ServingReport;
use crate::rt::setup::RtSetting;
use crate::rt::telemetry::{Drops, Latencies, Percentiles, as_percentiles, at, write_hgrm};
use crate::rt::telemetry_thread::TelemetryReport;
use crate::sensor::SensorError;

/// What a run did.
#[derive(Debug, Clone, Serialize)]
pub struct RunReport {
    /// The sensor, as it describes itself.
    pub sensor: String,
    /// The arm, as it describes itself.
    #[serde(rename = "arm_backend")]
    pub arm_name: String,
    /// Real-time settings, granted or denied.
    pub settings: Vec<RtSetting>,
    /// The kernel is PREEMPT_RT.
    pub preempt_rt: bool,
    /// Scheduler counts.
    pub stats: SchedulerStats,
    /// Periods elapsed by the clock minus ticks run and skipped.
    pub drift_ticks: i64,
    /// Full ticks (ns).
    pub full: Latencies,
    /// Reference ticks (`bench latency` only; ns).
    pub reference: Latencies,
    /// Ring drops.
    pub drops: Drops,
    /// Heap allocations on the control thread after start-up.
    pub control_thread_allocations: u64,
    /// Page faults the control thread took after start-up.
    pub control_thread_page_faults: u64,
    /// The threads the loop waits on (the arm's, the sensor's, an
    /// output's): how late they woke, and their page faults.
    pub serving: Vec<ServingReport>,
    /// Events logged.
    pub events: u64,
    /// Why the run ended.
    pub stop_reason: StopReason,
    /// The arm at the end, if it reports its state.
    pub arm: Option<ArmState>,
    /// Commands the arm received.
    pub arm_commands: u64,
    /// Time from one command sent to the arm to the next, ns (nominally
    /// 10 ms).
    #[serde(rename = "arm_command_gaps_ns", serialize_with = "as_percentiles")]
    pub arm_command_gaps: Histogram<u64>,
    /// The stream ended with a zero command and the arm was stopped.
    pub stream_ended_with_zero: bool,
    /// The last command the core sent to the arm.
    pub last_arm_command: ArmCommand,
    /// The last commanded twist `[v (3), ω (3), fingers]`.
    pub final_velocity: [f64; 7],
    /// The commanded twist when the stop began.
    pub velocity_at_stop: [f64; 7],
    /// Ticks (ms) the brake took from the start of the stop to still (0:
    /// the arm was still).
    pub braking_ticks: u64,
    /// The event output failed (stdout closed, a full disk), and why: the
    /// run was stopped safely (`stop_reason` "output failed", unless it
    /// was stopping already) and later events were not written.
    pub output_error: Option<String>,
    /// Wall time of the loop, s.
    pub wall_seconds: f64,
    /// Process CPU time over wall time, %.
    pub cpu_percent: f64,
    /// What went wrong at the edges during the run (a sensor that failed,
    /// an arm that refused a command): the run was stopped safely.
    pub errors: Vec<String>,
    /// `run --record`: what the recording holds (`null` otherwise).
    pub recording: Option<RecordingReport>,
    /// The display's figures (`null` with `--no-display`).
    pub display: Option<DisplaySummary>,
    /// The arm reports a measured pose, which the limits used.
    pub arm_measured: bool,
    /// Measured poses the core took in.
    pub measured_poses: u64,
    /// Measured poses dropped on their way to the control thread.
    pub measured_pose_drops: u64,
    /// The largest correction the measured poses made to the pose
    /// estimate, m.
    pub largest_correction_m: f64,
    /// Why the core stopped the arm, if the arm failed or its measured
    /// pose could not be trusted (also in `errors`).
    pub arm_fault: Option<String>,
    /// What each output beyond the arm did (`run --output`).
    pub outputs: Vec<OutputReport>,
    /// Sensor faults: each stopped the arm; any makes the run a failure.
    pub faults: SensorFaults,
    /// `detector.max_hold_ms` and where it came from, e.g. "1000 ms, set
    /// in anna.toml" (set by the command line; `None`: not known).
    pub max_hold: Option<String>,
}

/// What the run itself saw, besides its threads' figures.
#[derive(Debug)]
pub struct RunFacts {
    /// The sensor, as it describes itself.
    pub sensor: String,
    /// The arm, as it describes itself.
    pub arm_name: String,
    /// The arm reports a measured pose.
    pub arm_measured: bool,
    /// Why the sensor's producer failed, if it did.
    pub sensor_error: Option<SensorError>,
    /// Process CPU time over the run's wall time, %.
    pub cpu_percent: f64,
}

impl RunReport {
    /// The report of a finished run, from what each part knows: the run
    /// itself, the control loop (with its work), the telemetry thread and
    /// the arm thread. What went wrong at the edges is gathered into
    /// `errors`: the sensor's failure, the arm's error, or else the core's
    /// own arm fault. No recording and no display yet: their owners add
    /// them.
    pub fn new(
        run: RunFacts,
        looped: LoopResult,
        telemetry: TelemetryReport,
        arm: ArmReport,
    ) -> RunReport {
        let work = looped.work;
        let arm_fault = work.arm_fault.map(|f| f.to_string());
        let mut errors = Vec::new();
        if let Some(e) = run.sensor_error {
            errors.push(format!("sensor: {e}"));
        }
        match (&arm.error, &arm_fault) {
            (Some(e), _) => errors.push(e.to_string()),
            (None, Some(fault)) => errors.push(format!("arm: {fault}")),
            (None, None) => {}
        }
        RunReport {
            sensor: run.sensor,
            arm_name: run.arm_name,
            settings: looped.settings,
            preempt_rt: looped.preempt_rt,
            stats: looped.stats,
            drift_ticks: looped.drift_ticks,
            full: telemetry.full,
            reference: telemetry.reference,
            drops: looped.drops,
            control_thread_allocations: looped.allocations,
            control_thread_page_faults: looped.page_faults,
            serving: vec![arm.serving],
            events: telemetry.events,
            stop_reason: work.stop_reason,
            arm: arm.state,
            arm_commands: arm.commands,
            arm_command_gaps: arm.send_gaps,
            stream_ended_with_zero: arm.ended_with_zero,
            last_arm_command: work.last_arm_command,
            final_velocity: work.final_velocity,
            velocity_at_stop: work.velocity_at_stop,
            braking_ticks: work.braking_ticks,
            output_error: telemetry.output_error,
            wall_seconds: looped.wall_seconds,
            cpu_percent: run.cpu_percent,
            errors,
            recording: None,
            display: None,
            arm_measured: run.arm_measured,
            measured_poses: work.measured_poses,
            measured_pose_drops: arm.feedback_drops,
            largest_correction_m: work.largest_correction_m,
            arm_fault,
            outputs: Vec::new(),
            faults: work.faults,
            max_hold: None,
        }
    }

    /// Full-tick over reference-tick wake-up latency at `quantile` (0 with
    /// no reference ticks).
    pub fn ratio(&self, quantile: f64) -> f64 {
        let reference = at(&self.reference.wake, quantile) as f64;
        let full = at(&self.full.wake, quantile) as f64;
        if reference > 0.0 {
            full / reference
        } else {
            0.0
        }
    }

    /// Whether the setting whose name starts with `prefix` was granted.
    pub fn granted(&self, prefix: &str) -> bool {
        self.settings
            .iter()
            .any(|s| s.name.starts_with(prefix) && s.granted)
    }

    /// The final report of `run`, for people.
    pub fn to_text(&self) -> String {
        let mut s = String::from("\n== sipnpuff run report\n");
        s += &format!("sensor: {}; arm: {}\n", self.sensor, self.arm_name);
        s += "real-time settings:\n";
        for setting in &self.settings {
            let state = if setting.granted { "granted" } else { "DENIED" };
            let detail = if setting.detail.is_empty() {
                String::new()
            } else {
                format!(" ({})", setting.detail)
            };
            s += &format!("  {:<36} {state}{detail}\n", setting.name);
        }
        let st = &self.stats;
        s += &format!(
            "ticks: {} run, {} skipped after {} missed deadlines, drift {} ticks, {:.2} s, stopped by: {}\n",
            st.ticks_run,
            st.skipped_ticks,
            st.missed_deadlines,
            self.drift_ticks,
            self.wall_seconds,
            self.stop_reason
        );
        s += "per tick, µs:\n";
        s += &(Percentiles::of(&self.full.wake).line("wake-up latency") + "\n");
        s += &(Percentiles::of(&self.full.compute).line("compute") + "\n");
        s += &(Percentiles::of(&self.full.period).line("period") + "\n");
        s += "each thread's wake-ups, µs late; its page faults while running:\n";
        s += &format!(
            "{}  {} page faults; late after its deadline\n",
            Percentiles::of(&self.full.wake).line("control"),
            self.control_thread_page_faults
        );
        for thread in &self.serving {
            s += &match thread.due {
                Some(due) => format!(
                    "{}  {} page faults; late after {due}\n",
                    Percentiles::of(&thread.wake).line(&thread.thread),
                    thread.page_faults,
                ),
                None => format!(
                    "  {:<22} waits on its device (no due time to measure from)  {} page faults\n",
                    thread.thread, thread.page_faults
                ),
            };
        }
        let d = &self.drops;
        s += &format!(
            "rings: dropped {} samples, {} arm commands, {} tick records, {} events\n",
            d.samples, d.arm_commands, d.records, d.events
        );
        s += &format!(
            "control thread heap allocations after start: {}\nevents: {}; process CPU: {:.1} %\n",
            self.control_thread_allocations, self.events, self.cpu_percent
        );
        match &self.arm {
            Some(arm) => {
                let p = arm.pose.translation.vector;
                let r = arm.pose.rotation.scaled_axis();
                s += &format!(
                    "arm: {} commands at 100 Hz; final {}position ({:.4}, {:.4}, {:.4}) m, rotation vector ({:.4}, {:.4}, {:.4}) rad, fingers {}\n",
                    self.arm_commands,
                    if self.arm_measured { "measured " } else { "" },
                    p.x,
                    p.y,
                    p.z,
                    r.x,
                    r.y,
                    r.z,
                    arm.fingers
                        .map_or("not reported".into(), |f| format!("{f:.0}"))
                );
            }
            None => {
                s += &format!(
                    "arm: {} commands at 100 Hz; it reports no state\n",
                    self.arm_commands
                );
            }
        }
        s += &format!(
            "{}\n",
            Percentiles::of(&self.arm_command_gaps).line("arm command gaps, µs")
        );
        if self.arm_measured {
            s += &format!(
                "arm feedback: {} measured poses taken in ({} dropped), largest correction of the estimate {:.1} mm\n",
                self.measured_poses,
                self.measured_pose_drops,
                self.largest_correction_m * 1000.0
            );
        }
        let v = self.velocity_at_stop;
        if v == [0.0; 7] {
            s += "safe stop: the arm was still when it began\n";
        } else {
            s += &format!(
                "safe stop: braked from linear ({}, {}, {}) m/s, angular ({}, {}, {}) rad/s, fingers {} units/s to still in {} ticks\n",
                v[0], v[1], v[2], v[3], v[4], v[5], v[6], self.braking_ticks
            );
        }
        let v = self.final_velocity;
        s += &format!(
            "final commanded velocity: linear ({}, {}, {}) m/s, angular ({}, {}, {}) rad/s, fingers {} units/s; last arm command zero: {}\n",
            v[0],
            v[1],
            v[2],
            v[3],
            v[4],
            v[5],
            v[6],
            self.last_arm_command.is_zero()
        );
        s += &format!(
            "stream ended with a zero command and the arm stopped: {}\n",
            self.stream_ended_with_zero
        );
        for output in &self.outputs {
            s += &format!(
                "output {}: {} commands carried out, {} dropped (ring full), {} lost\n",
                output.output, output.applied, output.dropped, output.lost
            );
            for note in &output.notes {
                s += &format!("  {note}\n");
            }
        }
        if let Some(recording) = &self.recording {
            s += &recording.to_line();
        }
        if let Some(display) = &self.display {
            s += &display.to_line();
        }
        if let Some(error) = &self.output_error {
            s += &format!("OUTPUT FAILED: {error}; later events were not written\n");
        }
        if let Some(line) = self.faults_line() {
            s += &line;
        }
        for error in &self.errors {
            s += &format!("ERROR: {error}\n");
        }
        s
    }

    /// The report's line on sensor faults, if there were any: how many,
    /// how many were breaths held past `max_hold_ms` (and where that
    /// setting came from), and how many disconnections the sensor came
    /// back from.
    pub fn faults_line(&self) -> Option<String> {
        let f = &self.faults;
        if f.total() == 0 {
            return None;
        }
        let plural = |n: u64| if n == 1 { "" } else { "s" };
        let mut line = format!(
            "FAULTS: {} sensor fault{}, each stopped the arm",
            f.total(),
            plural(f.total())
        );
        if f.held_too_long > 0 {
            line += &format!(
                "; {} {} a breath held past detector.max_hold_ms{}: if the person meant {}, raise max_hold_ms",
                f.held_too_long,
                if f.held_too_long == 1 { "was" } else { "were" },
                self.max_hold
                    .as_ref()
                    .map_or(String::new(), |m| format!(" ({m})")),
                if f.held_too_long == 1 { "it" } else { "them" },
            );
        }
        if f.disconnected > 0 {
            line += &format!(
                "; {} {} the sensor disconnected, {} of them reconnected (detection resumed)",
                f.disconnected,
                if f.disconnected == 1 { "was" } else { "were" },
                f.reconnected,
            );
        }
        Some(line + "\n")
    }

    /// Writes each histogram as `.hgrm` (µs) into `dir`.
    pub fn write_histograms(&self, dir: &Path) -> std::io::Result<Vec<PathBuf>> {
        std::fs::create_dir_all(dir)?;
        let mut written = Vec::new();
        for (name, h) in [
            ("wake_latency", &self.full.wake),
            ("compute", &self.full.compute),
            ("period", &self.full.period),
            ("reference_wake_latency", &self.reference.wake),
        ] {
            if h.is_empty() {
                continue;
            }
            let path = dir.join(format!("{name}.hgrm"));
            let mut file = std::io::BufWriter::new(std::fs::File::create(&path)?);
            write_hgrm(&mut file, h)?;
            std::io::Write::flush(&mut file)?;
            written.push(path);
        }
        Ok(written)
    }
}

/// What the display did during a run (the telemetry side's figures: a
/// slow page skips frames and loses sounds there, never in the loop).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct DisplaySummary {
    /// Where the page was served (`None`: the terminal view only).
    pub address: Option<String>,
    /// What the pages were sent and missed.
    #[serde(flatten)]
    pub counts: DisplayCounts,
}

/// The display's counters: the feed keeps them live as atomics
/// (`DisplayCounts<AtomicU64>`), the report reads them once as numbers.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct DisplayCounts<C = u64> {
    /// Pages that connected (connections to the event stream).
    pub pages_opened: C,
    /// Frames published.
    pub frames_published: C,
    /// Frames sent, all pages together.
    pub frames_sent: C,
    /// Frames a slow page skipped (newer ones replaced them).
    pub frames_skipped: C,
    /// Sounds a page fell too far behind to get.
    pub cues_dropped: C,
}

impl DisplaySummary {
    /// The report's line.
    pub fn to_line(&self) -> String {
        let place = match &self.address {
            Some(address) => format!("http://{address}/"),
            None => "the terminal".into(),
        };
        let c = &self.counts;
        format!(
            "display: {place}, {} pages opened; {} frames published, {} sent, {} skipped by slow pages, {} sounds dropped\n",
            c.pages_opened, c.frames_published, c.frames_sent, c.frames_skipped, c.cues_dropped
        )
    }
}
