//! `[rt]`: the real-time priorities and CPUs of the threads with
//! deadlines, on the controller that runs them. The defaults suit a
//! 2-core controller: the control thread alone on the last CPU at
//! SCHED_FIFO 80; the sensor's reader (70), the arm thread (60) and a
//! uinput output's thread (50) on the other CPUs. `run --priority` and
//! `--cpu` override them for one run.

use serde::{Deserialize, Serialize};

/// Highest CPU number `[rt]` accepts (a 64-bit affinity mask).
pub const MAX_CPU: usize = 63;

/// `[rt]`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RtSettings {
    /// SCHED_FIFO priority of the control thread (1–99; 0: SCHED_OTHER,
    /// and then every thread stays SCHED_OTHER).
    pub control_priority: i32,
    /// The sensor's reader threads (below the control thread: a sample
    /// late by `stale_ms` is a fault; 0: SCHED_OTHER).
    pub sensor_priority: i32,
    /// The arm thread (an arm stops about 0.1 s after its last command).
    pub arm_priority: i32,
    /// The thread of an output a person waits on (uinput: a key held for a
    /// breath).
    pub output_priority: i32,
    /// The control thread's CPU; absent: the last one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub control_cpu: Option<usize>,
    /// The other deadline threads' CPUs; empty: every CPU but the control
    /// thread's.
    pub serving_cpus: Vec<usize>,
}

impl Default for RtSettings {
    fn default() -> Self {
        RtSettings {
            control_priority: 80,
            sensor_priority: 70,
            arm_priority: 60,
            output_priority: 50,
            control_cpu: None,
            serving_cpus: Vec::new(),
        }
    }
}

impl RtSettings {
    /// The serving threads' keys and priorities, in the order they are
    /// checked and applied.
    pub fn serving_priorities(&self) -> [(&'static str, i32); 3] {
        [
            ("sensor_priority", self.sensor_priority),
            ("arm_priority", self.arm_priority),
            ("output_priority", self.output_priority),
        ]
    }
}
