//! The arm `--arm` names ([`ArmSpec`]), opened.

use crate::arm::kinova_sdk::KinovaSdkArm;
use crate::arm::ros1::Ros1Arm;
#[cfg(feature = "ros2")]
use crate::arm::ros2::Ros2Arm;
use crate::arm::sim::SimArm;
use crate::arm::{Arm, ArmSpec};
use crate::config::Config;

/// Opens the `--arm` backend (not yet connected: the arm thread connects
/// it, with `[arm] connect_timeout_ms`).
pub fn open_arm(spec: &ArmSpec, config: &Config) -> anyhow::Result<Box<dyn Arm>> {
    Ok(match spec {
        ArmSpec::Sim => Box::new(SimArm::new(config.core())),
        #[cfg(feature = "ros2")]
        ArmSpec::Ros2 { topic } => {
            let settings = config.arm();
            Box::new(Ros2Arm::new(
                topic,
                &settings.ros2,
                settings.connect_timeout_ms,
            ))
        }
        #[cfg(not(feature = "ros2"))]
        ArmSpec::Ros2 { .. } => anyhow::bail!(
            "--arm {spec}: this sipnpuff was built without the `ros2` feature (it is on by default: build without --no-default-features)"
        ),
        ArmSpec::Ros1 { namespace } => Box::new(Ros1Arm::new(
            namespace,
            &config.arm().ros1,
            config.arm().connect_timeout_ms,
        )),
        ArmSpec::KinovaSdk { link } => Box::new(KinovaSdkArm::new(*link, config.arm())),
    })
}
