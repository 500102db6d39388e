//! Simulation: the seeded sensor model, the scripts and simulated users
//! that breathe into it (played live by the synthetic sensor), simulated people with known breathing for
//! calibration, and the paper's study run with them through the
//! production core; and simulated people wearing a head IMU (their head
//! motion, gestures, ordinary movement and sessions, with the truth).
//! Set-up and tooling code: it may allocate, and neither
//! the core nor the runtime imports it.

pub mod breather;
pub mod guided_imu_user;
pub mod head;
pub mod head_gesture;
pub mod head_motion;
pub mod head_user;
pub mod imu_session;
pub mod imu_user;
pub mod live_head;
pub mod ordinary_movement;
pub mod script;
pub mod sensor_model;
pub mod study;
pub mod synthetic_sensor;
pub mod user;
pub mod worn_imu;
