//! `[rt]`: priorities a scheduler takes, each deadline thread below the
//! control thread, and the control thread's CPU its own.

use crate::config::error::Problems;
use crate::config::realtime::{MAX_CPU, RtSettings};

/// Every check of `[rt]`.
pub(super) fn rt(p: &mut Problems, rt: &RtSettings) {
    let control = rt.control_priority;
    if !(0..=99).contains(&control) {
        p.add(
            "rt.control_priority",
            format!("{control}: SCHED_FIFO priorities are 1–99 (0: SCHED_OTHER)"),
        );
    }
    for (key, priority) in rt.serving_priorities() {
        let key = format!("rt.{key}");
        if !(0..=99).contains(&priority) {
            p.add(
                key,
                format!("{priority}: SCHED_FIFO priorities are 1–99 (0: SCHED_OTHER)"),
            );
        } else if priority > 0 && control == 0 {
            p.add(
                key,
                format!(
                    "{priority} with the control thread at SCHED_OTHER (control_priority = 0): it would take the control thread's time; set 0 or give the control thread a priority above it"
                ),
            );
        } else if priority >= control && control > 0 {
            p.add(
                key,
                format!(
                    "{priority} is not below control_priority = {control}: the control thread must preempt every thread it waits on"
                ),
            );
        }
    }
    if let Some(cpu) = rt.control_cpu
        && cpu > MAX_CPU
    {
        p.add("rt.control_cpu", format!("CPU {cpu}: at most {MAX_CPU}"));
    }
    for &cpu in &rt.serving_cpus {
        if cpu > MAX_CPU {
            p.add("rt.serving_cpus", format!("CPU {cpu}: at most {MAX_CPU}"));
        } else if Some(cpu) == rt.control_cpu {
            p.add(
                "rt.serving_cpus",
                format!(
                    "CPU {cpu} is the control thread's (control_cpu): it keeps its CPU to itself"
                ),
            );
        }
    }
}
