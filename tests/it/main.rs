//! The integration tests, in one binary (one link of the crate): golden
//! replays, motion invariants, properties, stress, sessions, the runtime,
//! session recordings, the study, the Ruckig oracle, allocations and the
//! import rules.
//! RealtimeSanitizer's tests are their own binary (`tests/rtsan.rs`): CI
//! builds it again with the sanitizer's runtime.

use sipnpuff::rt::alloc_counter::CountingAllocator;

/// Every test can count its allocations.
#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

mod allocations;
mod architecture;
mod arm_feedback;
mod arm_kinova_sdk;
mod arm_ros1;
mod arm_ros2;
mod arm_sim;
mod breathers;
mod cli;
mod common;
mod design;
mod display;
mod display_browser;
mod fast_paths;
mod faults;
mod fit;
mod fit_live;
mod fit_prompter;
mod golden;
mod motion;
mod motion_safety;
mod output_mqtt;
mod outputs;
mod peers;
mod properties;
mod recording;
mod ruckig_oracle;
mod runtime;
mod scratch;
mod sensors;
mod sessions;
mod stress;
mod study;
mod uinput;
mod watchdog;
