//! The report of a thread the control loop waits on: its name, how late
//! it woke and the page faults it took ([`crate::wakes`]).

use hdrhistogram::Histogram;
use serde::Serialize;

use crate::rt::telemetry::as_percentiles;
use crate::wakes::Wakes;

/// One serving thread's timeliness, for the run report.
#[derive(Debug, Clone, Serialize)]
pub struct ServingReport {
    /// The thread's name.
    pub thread: String,
    /// What its wake-ups were due on (the latency is measured from it);
    /// `None`: it blocks on a device with no due time to measure from.
    pub due: Option<&'static str>,
    /// How late each wake-up came, ns.
    #[serde(rename = "wake_latency_ns", serialize_with = "as_percentiles")]
    pub wake: Histogram<u64>,
    /// Page faults (minor and major) taken while serving.
    pub page_faults: u64,
}

impl ServingReport {
    /// The report of thread `thread` from what it logged.
    pub fn new(thread: &str, wakes: Wakes) -> ServingReport {
        ServingReport {
            thread: thread.into(),
            due: wakes.due,
            wake: wakes.late,
            page_faults: wakes.page_faults,
        }
    }
}
