//! The outputs beyond the arm `--output` names ([`OutputSpec`]), opened,
//! each with what it serves; the library's entries that would do nothing
//! without one are said first.

use crate::config::Config;
use crate::control::target::{HomeEvent, Target};
#[cfg(feature = "mqtt")]
use crate::output::mqtt::MqttOutput;
use crate::output::settings::MqttSettings;
use crate::output::uinput::UinputOutput;
use crate::output::{Output, OutputSpec};
use crate::rt::output_thread::Serves;

/// Opens the `--output` backends, each with what it serves; says (`say`)
/// which of the library's entries would do nothing without one.
pub fn open_outputs(
    specs: &[OutputSpec],
    config: &Config,
    say: &dyn Fn(&str),
) -> anyhow::Result<Vec<(Serves, Box<dyn Output>)>> {
    let library = config.core().sequences();
    let computer = library.iter().any(|e| match e.target {
        Target::Mode(mode) => mode.is_pointer(),
        Target::Home(_) => false,
        _ => true,
    });
    let events: Vec<HomeEvent> = library
        .iter()
        .filter_map(|e| match e.target {
            Target::Home(event) => Some(event),
            _ => None,
        })
        .collect();
    let given = |kind: &str| specs.iter().any(|s| s.kind() == kind);
    if computer && !given("uinput") {
        say(
            "sipnpuff: the library types keys, clicks or moves the pointer, but no `--output uinput` is given: those entries will do nothing",
        );
    }
    if !events.is_empty() && !given("mqtt") {
        say(
            "sipnpuff: the library sends home events, but no `--output mqtt` is given: they will go nowhere",
        );
    }
    let mut opened: Vec<(Serves, Box<dyn Output>)> = Vec::new();
    for (i, spec) in specs.iter().enumerate() {
        if specs[..i].iter().any(|s| s.kind() == spec.kind()) {
            anyhow::bail!("--output {}: given twice", spec.kind());
        }
        opened.push(match spec {
            OutputSpec::Uinput => (Serves::Computer, open_uinput(config)?),
            OutputSpec::Mqtt { address } => {
                let mut settings = config.output().mqtt.clone();
                if let Some((host, port)) = address {
                    settings.host = host.clone();
                    settings.port = *port;
                }
                (Serves::Home, open_mqtt(&settings, &events)?)
            }
        });
    }
    Ok(opened)
}

/// `--output uinput`.
fn open_uinput(config: &Config) -> anyhow::Result<Box<dyn Output>> {
    Ok(Box::new(UinputOutput::open(&config.output().uinput)?))
}

/// `--output mqtt`: connects now, so a wrong address, a broker that is
/// down or refused credentials stop the run before it starts.
#[cfg(feature = "mqtt")]
fn open_mqtt(settings: &MqttSettings, events: &[HomeEvent]) -> anyhow::Result<Box<dyn Output>> {
    Ok(Box::new(MqttOutput::open(settings, events)?))
}

/// `--output mqtt` in a build without it.
#[cfg(not(feature = "mqtt"))]
fn open_mqtt(_settings: &MqttSettings, _events: &[HomeEvent]) -> anyhow::Result<Box<dyn Output>> {
    anyhow::bail!("--output mqtt: this sipnpuff was built without the `mqtt` feature")
}
