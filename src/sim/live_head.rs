//! A simulated person's head in closed loop: the moves they decide are
//! added as they go, and the IMU they wear reads it on its own ticks.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::control::Tick;
use crate::control::imu::ImuInput;
use crate::sim::head_motion::{HeadMotion, MotionCursor, Step};
use crate::sim::imu_user::ImuUser;
use crate::sim::worn_imu::{WornImu, add_body};

/// The person's head in closed loop: the moves they decide are added to
/// it as they go.
pub struct LiveHead {
    cursor: MotionCursor,
    sensor: WornImu,
    rng: ChaCha8Rng,
    rate_hz: u64,
    next_sample: u64,
}

impl LiveHead {
    /// `user`'s head at rest, their body and sensor added, seeded.
    pub fn new(user: &ImuUser, seed: u64) -> LiveHead {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut motion = HeadMotion::default();
        add_body(user, &mut motion, &mut rng);
        motion.finish();
        let sensor = WornImu::new(user, &mut rng);
        LiveHead {
            cursor: motion.into_cursor(),
            sensor,
            rng,
            rate_hz: u64::from(user.rate_hz.clamp(1, 1000)),
            next_sample: 0,
        }
    }

    /// The IMU's input on `tick`: a sample on the sensor's own ticks.
    pub fn input(&mut self, tick: Tick) -> ImuInput {
        let due = (self.next_sample * 1000 + self.rate_hz / 2) / self.rate_hz;
        if tick < due {
            return ImuInput::Missing;
        }
        self.next_sample += 1;
        let t = tick as f64 / 1000.0;
        let state = self.cursor.at(t);
        ImuInput::Sample(self.sensor.read(t, &state, &mut self.rng))
    }

    /// Moves the head by `steps` (times from 0), starting at `at` ms.
    pub fn add(&mut self, at: Tick, steps: &[Step]) {
        let start = at as f64 / 1000.0;
        for step in steps {
            self.cursor.add(Step {
                start: step.start + start,
                ..*step
            });
        }
    }

    /// Adds `motion` (times from 0) as it is: its moves, oscillations
    /// and jolts.
    pub fn add_motion(&mut self, motion: HeadMotion) {
        self.cursor.add_motion(motion);
    }
}
