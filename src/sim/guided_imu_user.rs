//! A simulated person guided through a live gesture recording: they hear
//! each of the guide's prompts ([`Say`]) and, after their reaction, make
//! the gesture asked for as the protocol's simulated person makes it, or,
//! when asked, move as they ordinarily do; the head goes through the IMU
//! they wear ([`LiveHead`]). Played in real time by `gestures record
//! --sensor synthetic:NAME`, and on simulated ticks by the tests.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::control::Tick;
use crate::control::imu::ImuInput;
use crate::gestures::guided::Say;
use crate::sim::head_gesture::{GestureName, gesture_example};
use crate::sim::head_motion::HeadMotion;
use crate::sim::imu_user::ImuUser;
use crate::sim::live_head::LiveHead;
use crate::sim::ordinary_movement::{Gaze, ordinary_movement};
use crate::sim::user::{UserModel, reaction_ms};

/// A person who follows the guide's prompts.
pub struct GuidedImuUser {
    user: ImuUser,
    gestures: Vec<GestureName>,
    head: LiveHead,
    rng: ChaCha8Rng,
    gaze: Gaze,
    /// From hearing a prompt to moving, ms (mean, SD; log-normal), as the
    /// study's participants.
    reaction: (f64, f64),
    /// Until this tick they are still making the last move.
    busy_until: Tick,
}

impl GuidedImuUser {
    /// `user`, asked for `gestures` (in the guide's order), seeded.
    pub fn new(user: ImuUser, gestures: &[GestureName], seed: u64) -> GuidedImuUser {
        GuidedImuUser {
            user,
            gestures: gestures.to_vec(),
            head: LiveHead::new(&user, seed),
            rng: ChaCha8Rng::seed_from_u64(seed ^ 0x6775_6964_6564),
            gaze: Gaze::default(),
            reaction: UserModel::POPULATION.participant(seed).reaction_ms,
            busy_until: 0,
        }
    }

    /// They hear `say` at `now`: a prompt is answered after their
    /// reaction (once the last move is over), the ordinary stretch is
    /// moved through as asked; anything else they only take in.
    pub fn hear(&mut self, now: Tick, say: &Say) {
        let react = Tick::from(reaction_ms(self.reaction, &mut self.rng));
        let at = (now + react).max(self.busy_until);
        match *say {
            Say::Make { gesture, .. } => {
                let Some(&name) = self.gestures.get(gesture) else {
                    return;
                };
                let example = gesture_example(name, &self.user, &mut self.rng);
                self.head.add(at, &example.steps);
                self.busy_until = at + (example.duration * 1000.0).ceil() as Tick;
            }
            Say::Ordinary { ms } => {
                let mut motion = HeadMotion::default();
                let span = (at as f64 / 1000.0, (now + ms) as f64 / 1000.0);
                ordinary_movement(&mut motion, &self.user, &mut self.gaze, span, &mut self.rng);
                self.head.add_motion(motion);
                self.busy_until = now + ms;
            }
            Say::HoldStill { .. }
            | Say::Seen { .. }
            | Say::OutOfTurn
            | Say::TooLong { .. }
            | Say::Done
            | Say::Stopped(_) => {}
        }
    }

    /// The IMU's input on `tick` (ticks increasing).
    pub fn input(&mut self, tick: Tick) -> ImuInput {
        self.head.input(tick)
    }
}
