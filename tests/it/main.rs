//! The first tier of tests: the whole logic on simulated clocks and
//! in-process fakes, in one binary (one link of the crate) — golden
//! replays, motion invariants, properties, stress, sessions, recordings,
//! the study, the fit, the designer, the Ruckig oracle, allocations and
//! the import rules. The second tier, which needs real seconds or an
//! independent peer, is `tests/live`; RealtimeSanitizer's tests are their
//! own binary (`tests/rtsan.rs`): CI builds it again with the sanitizer's
//! runtime.

use sipnpuff::rt::alloc_counter::CountingAllocator;

/// Every test can count its allocations.
#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

// The helpers both tiers share; each binary uses part of them.
#[allow(dead_code)]
#[path = "../support/common.rs"]
mod common;
#[allow(dead_code)]
#[path = "../support/recordings.rs"]
mod recordings;
#[allow(dead_code)]
#[path = "../support/scratch.rs"]
mod scratch;
#[allow(dead_code)]
#[path = "../support/watchdog.rs"]
mod watchdog;

mod allocations;
mod architecture;
mod arm_feedback;
mod arm_sim;
mod breathers;
mod cli;
mod clinician_flow;
mod design;
mod display;
mod doctor;
mod fast_paths;
mod faults;
mod fit;
mod fit_inputs;
mod fit_prompter;
mod gesture;
mod gesture_sets;
mod gesture_use;
mod golden;
mod guided_recording;
mod motion;
mod motion_safety;
mod outputs;
mod properties;
mod recording;
mod refit;
mod ruckig_oracle;
mod runtime;
mod scratch_folders;
mod sessions;
mod setup;
mod stress;
mod study;
mod uinput;
