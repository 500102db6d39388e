//! The second tier of tests: what needs real seconds or an independent
//! peer running here — real runs of the binary (signals, stalls, sensors
//! through pseudo-terminals, recordings of real runs), live calibrations,
//! the arms against Cyclone DDS, a rosmaster and the Kinova SDK stand-in,
//! the home output against Mosquitto, the display in headless Chromium.
//! `cargo test --test live` (the peers need root and `.ci/run`'s
//! installs; without them a test prints `SKIPPED`, and fails instead with
//! `SIPNPUFF_REQUIRE_PEERS=1`). Every process a test starts is bounded by
//! the watchdog.

use sipnpuff::rt::alloc_counter::CountingAllocator;

/// Every test can count its allocations.
#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

// The helpers both tiers share; each binary uses part of them.
#[allow(dead_code)]
#[path = "../support/common.rs"]
mod common;
#[allow(dead_code)]
#[path = "../support/peers.rs"]
mod peers;
#[allow(dead_code)]
#[path = "../support/recordings.rs"]
mod recordings;
#[allow(dead_code)]
#[path = "../support/scratch.rs"]
mod scratch;
#[allow(dead_code)]
#[path = "../support/watchdog.rs"]
mod watchdog;

mod arm_kinova_sdk;
mod arm_ros1;
mod arm_ros2;
mod display_browser;
mod exits;
mod fit_from_use;
mod fit_live;
mod output_mqtt;
mod recorded_runs;
mod runtime;
mod sensors;
mod watchdog_bound;
