//! Differential test: the `rsruckig` build the control path uses (no `std`,
//! `libm`) against the official Ruckig (C++ through cxx, a dev-dependency
//! only), on seeded step sequences in the velocity interface
//! (`Synchronization::None`, as the motion layer uses it) and the position
//! interface (`Synchronization::Time`, as go-to-point uses it). Each runs
//! closed loop on its own output; the states must agree within 1e-9 on
//! every tick.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rsruckig::prelude as rs;

const DOF: usize = 6;
const DT: f64 = 0.001;
const TOLERANCE: f64 = 1e-9;

/// Limits within the JACO2 caps: three linear axes, three angular.
fn limits(rng: &mut ChaCha8Rng) -> ([f64; DOF], [f64; DOF], [f64; DOF]) {
    let mut v = [0.0; DOF];
    let mut a = [0.0; DOF];
    let mut j = [0.0; DOF];
    for i in 0..DOF {
        let (vmax, amax, jmax) = if i < 3 {
            (0.2, 0.64, 10.0)
        } else {
            (1.07, 2.75, 50.0)
        };
        v[i] = rng.random_range(0.2..=1.0) * vmax;
        a[i] = rng.random_range(0.2..=1.0) * amax;
        j[i] = rng.random_range(0.1..=1.0) * jmax;
    }
    (v, a, j)
}

struct Pair {
    rs_otg: rs::Ruckig<DOF, rs::ThrowErrorHandler>,
    rs_in: rs::InputParameter<DOF>,
    rs_out: rs::OutputParameter<DOF>,
    c_otg: ruckig::Ruckig,
    c_in: ruckig::InputParameter,
    c_out: ruckig::OutputParameter,
}

impl Pair {
    fn new(velocity: bool, limits: ([f64; DOF], [f64; DOF], [f64; DOF])) -> Pair {
        let mut rs_in = rs::InputParameter::new(None);
        let mut c_in = ruckig::InputParameter::new(DOF);
        if velocity {
            rs_in.control_interface = rs::ControlInterface::Velocity;
            rs_in.synchronization = rs::Synchronization::None;
            c_in.control_interface = ruckig::ControlInterface::Velocity;
            c_in.synchronization = ruckig::Synchronization::None;
        } else {
            rs_in.control_interface = rs::ControlInterface::Position;
            rs_in.synchronization = rs::Synchronization::Time;
            c_in.control_interface = ruckig::ControlInterface::Position;
            c_in.synchronization = ruckig::Synchronization::Time;
        }
        for i in 0..DOF {
            rs_in.max_velocity[i] = limits.0[i];
            rs_in.max_acceleration[i] = limits.1[i];
            rs_in.max_jerk[i] = limits.2[i];
        }
        c_in.max_velocity = limits.0.to_vec();
        c_in.max_acceleration = limits.1.to_vec();
        c_in.max_jerk = limits.2.to_vec();
        for v in [
            &mut c_in.current_position,
            &mut c_in.current_velocity,
            &mut c_in.current_acceleration,
            &mut c_in.target_position,
            &mut c_in.target_velocity,
            &mut c_in.target_acceleration,
        ] {
            *v = vec![0.0; DOF];
        }
        Pair {
            rs_otg: rs::Ruckig::new(None, DT),
            rs_in,
            rs_out: rs::OutputParameter::new(None),
            c_otg: ruckig::Ruckig::new_direct(DOF, DT),
            c_in,
            c_out: ruckig::OutputParameter::new_direct(DOF),
        }
    }

    fn set_target(&mut self, position: &[f64; DOF], velocity: &[f64; DOF]) {
        for i in 0..DOF {
            self.rs_in.target_position[i] = position[i];
            self.rs_in.target_velocity[i] = velocity[i];
        }
        self.c_in.target_position = position.to_vec();
        self.c_in.target_velocity = velocity.to_vec();
    }

    /// One cycle of both; returns the largest state difference.
    fn step(&mut self) -> f64 {
        let rs_result = self.rs_otg.update(&self.rs_in, &mut self.rs_out).unwrap();
        let c_result = self.c_otg.update(&mut self.c_in, &mut self.c_out);
        assert!(
            matches!(
                (&rs_result, &c_result),
                (rs::RuckigResult::Working, ruckig::Result::Working)
                    | (rs::RuckigResult::Finished, ruckig::Result::Finished)
            ),
            "{rs_result:?} vs {c_result:?}"
        );
        let mut worst = 0.0f64;
        for i in 0..DOF {
            worst = worst
                .max((self.rs_out.new_position[i] - self.c_out.new_position[i]).abs())
                .max((self.rs_out.new_velocity[i] - self.c_out.new_velocity[i]).abs())
                .max((self.rs_out.new_acceleration[i] - self.c_out.new_acceleration[i]).abs());
        }
        self.rs_out.pass_to_input(&mut self.rs_in);
        self.c_out.pass_to_input(&mut self.c_in);
        worst
    }
}

/// Velocity steps: every 20–800 ms each axis gets a new target velocity
/// (zero, or up to ± its limit, as puffs and sips do), 20 s per seed.
#[test]
fn velocity_interface_matches_the_official_ruckig() {
    let mut worst = 0.0f64;
    for seed in 0..20 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let limits = limits(&mut rng);
        let mut pair = Pair::new(true, limits);
        let mut next_change = 0;
        for tick in 0..20_000 {
            if tick == next_change {
                let mut velocity = [0.0; DOF];
                for (v, limit) in velocity.iter_mut().zip(limits.0) {
                    if rng.random_bool(0.6) {
                        *v = rng.random_range(-1.0..=1.0) * limit;
                    }
                }
                pair.set_target(&[0.0; DOF], &velocity);
                next_change += rng.random_range(20..=800);
            }
            worst = worst.max(pair.step());
        }
    }
    eprintln!("largest difference over 20 seeds × 20 s: {worst:e}");
    assert!(worst <= TOLERANCE, "largest difference {worst:e}");
}

/// Position steps: new targets within ±0.5 m / ±π rad every 50 ms – 4 s,
/// often before the last one was reached (moving starts).
#[test]
fn position_interface_matches_the_official_ruckig() {
    let mut worst = 0.0f64;
    for seed in 0..20 {
        let mut rng = ChaCha8Rng::seed_from_u64(1000 + seed);
        let limits = limits(&mut rng);
        let mut pair = Pair::new(false, limits);
        let mut next_change = 0;
        let mut tick = 0;
        while tick < 20_000 {
            if tick == next_change {
                let mut position = [0.0; DOF];
                for (i, p) in position.iter_mut().enumerate() {
                    let span = if i < 3 { 0.5 } else { std::f64::consts::PI };
                    *p = rng.random_range(-1.0..=1.0) * span;
                }
                pair.set_target(&position, &[0.0; DOF]);
                next_change += rng.random_range(50..=4000);
            }
            worst = worst.max(pair.step());
            tick += 1;
        }
    }
    eprintln!("largest difference over 20 seeds × 20 s: {worst:e}");
    assert!(worst <= TOLERANCE, "largest difference {worst:e}");
}
