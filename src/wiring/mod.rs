//! The backends chosen from their specs: the sensor `--sensor` names
//! (started and, if analog, its neutral measured), the arm `--arm` names
//! and the outputs `--output` names, for whatever runs on them (`run`'s
//! session, the live calibration). The one place that maps a spec to its
//! backend: a new backend is a line here, beside its form in its spec.

pub mod arm;
pub mod outputs;
pub mod sensor;
