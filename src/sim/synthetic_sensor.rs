//! The synthetic sensor: a scripted user played by the seeded sensor model
//! (`sim::sensor_model`), computed in the control loop itself (no thread,
//! no I/O, no allocation), so a run is repeatable sample for sample.

use crate::config::Config;
use crate::control::sample::Sample;
use crate::control::selection::Interface;
use crate::fit::protocol::Protocol;
use crate::sensor::{Producer, Reading, Samples, Sensor, SensorError, Started};
use crate::sim::breather::{Breather, practice_session};
use crate::sim::script::{prompted_script, protocol_script, run_script};
use crate::sim::sensor_model::{SignalGenerator, SignalParams, Step};
use crate::sim::user::{RUN_STEPS, scripted_session};

/// A script on the seeded sensor model.
#[derive(Debug, Clone)]
pub struct SyntheticSensor {
    params: SignalParams,
    script: Vec<Step>,
    repeat: bool,
}

impl SyntheticSensor {
    /// Plays `script` once; after it ends the sensor reads the resting
    /// level and says it has [ended](Samples::ended).
    pub fn new(params: SignalParams, script: Vec<Step>) -> SyntheticSensor {
        SyntheticSensor {
            params,
            script,
            repeat: false,
        }
    }

    /// The built-in user of `sipnpuff run` (about 22 s, light noise and
    /// hum): saves the home pose, moves forward, closes and opens the
    /// fingers, goes back to the saved pose. On the scanning interface the
    /// user reacts to the highlight (a closed-loop session with the same
    /// moves).
    pub fn built_in_user(config: &Config) -> SyntheticSensor {
        match config.core().interface() {
            Interface::Asp => {
                let params = SignalParams::clean(config.core().detector(), 1)
                    .with_noise(0.02)
                    .with_hum(0.03);
                SyntheticSensor::new(params, run_script(config).0)
            }
            Interface::Bsp => {
                let (params, script) = scripted_session(config, &RUN_STEPS, 1);
                SyntheticSensor::new(params, script)
            }
        }
    }

    /// The user of a live calibration (`sipnpuff fit` on the synthetic
    /// sensor): a typical user who breathes `protocol` in time with its
    /// prompts ([`protocol_script`]), resting at the configuration's
    /// neutral. The one place that chooses the calibration's simulated
    /// user.
    pub fn calibration_user(
        config: &Config,
        protocol: &Protocol,
        breather: Option<&Breather>,
    ) -> SyntheticSensor {
        match breather {
            None => {
                let (params, script) = protocol_script(config.core().detector(), protocol, 1);
                SyntheticSensor::new(params, script)
            }
            Some(b) => {
                let script = prompted_script(protocol, 1, |ask, rng| b.draw_ms(ask, rng));
                SyntheticSensor::new(b.signal_params(1), script)
            }
        }
    }

    /// The built-in breather `name`, and `config` with its neutral at their
    /// rest level (as a run measures a device's); the error lists the
    /// names.
    pub fn breather_named(config: &Config, name: &str) -> Result<(Config, Breather), String> {
        let breather = Breather::named(name).ok_or_else(|| {
            let names: Vec<&str> = Breather::all().iter().map(|b| b.name).collect();
            format!(
                "`synthetic:{name}`: no built-in breather has that name; one of {}",
                names.join(", ")
            )
        })?;
        let config = config
            .clone()
            .with_neutral_volts(breather.rest_volts)
            .map_err(|e| e.to_string())?;
        Ok((config, breather))
    }

    /// `breather` in ordinary use of `config`'s library for two minutes
    /// ([`practice_session`]): `sipnpuff run --sensor synthetic:NAME`.
    pub fn breather_user(config: &Config, breather: &Breather) -> SyntheticSensor {
        let session = practice_session(breather, config.core().sequences(), 120, 1);
        SyntheticSensor::new(session.params, session.script)
    }

    /// Starts the script again whenever it ends (never ends).
    pub fn repeating(mut self) -> SyntheticSensor {
        self.repeat = true;
        self
    }
}

impl Sensor for SyntheticSensor {
    type Samples = SyntheticSamples;

    fn describe(&self) -> String {
        let seconds = self
            .script
            .iter()
            .map(|s| match *s {
                Step::Breath { ms, .. } | Step::Rest { ms } | Step::Dropout { ms } => u64::from(ms),
            })
            .sum::<u64>() as f64
            / 1000.0;
        format!(
            "synthetic (a scripted user, {} steps, at least {seconds:.1} s{})",
            self.script.len(),
            if self.repeat { ", repeated" } else { "" }
        )
    }

    fn start(self) -> Result<Started<SyntheticSamples>, SensorError> {
        Ok(Started {
            samples: SyntheticSamples {
                rest_volts: self.params.neutral_volts,
                samples: SignalGenerator::owned(self.params, self.script),
                repeat: self.repeat,
                ended: false,
            },
            producer: Producer::none(),
        })
    }
}

/// The control thread's side: the generator itself.
pub struct SyntheticSamples {
    samples: SignalGenerator<'static>,
    repeat: bool,
    rest_volts: f64,
    ended: bool,
}

impl Samples for SyntheticSamples {
    /// A sample every tick; the samples of skipped ticks are played and
    /// thrown away, as a real sensor's would be.
    fn try_read(&mut self, skipped: u64) -> Reading {
        for _ in 0..skipped {
            self.samples.next();
        }
        let mut volts = self.samples.next();
        if volts.is_none() && self.repeat {
            self.samples.rewind();
            volts = self.samples.next();
        }
        self.ended |= volts.is_none();
        Reading {
            sample: Sample::Volts(volts.unwrap_or(self.rest_volts)),
            ..Reading::default()
        }
    }

    /// The samples of the gap are played (the scripted user went on
    /// breathing) and thrown away; nothing is queued.
    fn discard_backlog(&mut self, skipped: u64) -> u64 {
        for _ in 0..skipped {
            if self.samples.next().is_none() {
                if self.repeat {
                    self.samples.rewind();
                } else {
                    self.ended = true;
                }
            }
        }
        skipped
    }

    fn ended(&self) -> bool {
        self.ended
    }
}
