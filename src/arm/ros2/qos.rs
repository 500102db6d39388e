//! The QoS of the command stream and of the pose, chosen for what the
//! receivers ask for.
//!
//! Commands: **reliable, volatile, keep-last 10** — rclcpp's default
//! (`rclcpp::QoS(10)`), which MoveIt Servo, ros2_controllers and the JACO2
//! ports subscribe with. Reliable because a reliable subscriber does not
//! match a best-effort publisher (DDS request/offer: the offer must be at
//! least as strong), and because the stop's zero command must be
//! acknowledged. **Volatile**, never transient-local: a late subscriber
//! must not be handed stale twists (an arm moving on a command from
//! before it joined). A subscriber that asks for transient-local does not
//! match (it would be told so by its RMW).
//!
//! A reliable writer keeps unacknowledged commands for repair: at most
//! [`ACK_WINDOW`] of them (0.5 s of the stream). A receiver that leaves
//! them all unacknowledged stopped answering (killed without a goodbye,
//! frozen, cut off): the next write fails at once instead of blocking
//! (`max_blocking_time` 0), and the backend reports the link lost — far
//! sooner than discovery's lease (Cyclone DDS's default 10 s).
//!
//! Pose: **best effort, volatile, keep-last 1**: matches a driver's
//! reliable or best-effort (sensor-data) publisher; only the newest pose
//! counts.

use rustdds::policy::{Durability, History, Reliability, ResourceLimits};
use rustdds::{Duration, QosPolicies, QosPolicyBuilder};

/// Unacknowledged commands a receiver may owe before it counts as gone:
/// 50, 0.5 s at 100 Hz (an answering receiver owes 10–20: the writer asks
/// every 100 ms).
pub const ACK_WINDOW: usize = 50;

/// The command writer's QoS.
pub fn commands() -> QosPolicies {
    QosPolicyBuilder::new()
        .reliability(Reliability::Reliable {
            max_blocking_time: Duration::ZERO,
        })
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 })
        .resource_limits(ResourceLimits {
            max_samples: ACK_WINDOW as i32,
            max_instances: 1,
            max_samples_per_instance: ACK_WINDOW as i32,
        })
        .build()
}

/// The pose reader's QoS.
pub fn pose() -> QosPolicies {
    QosPolicyBuilder::new()
        .reliability(Reliability::BestEffort)
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 1 })
        .build()
}
