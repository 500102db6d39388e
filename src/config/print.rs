//! The effective configuration as TOML: every section and key, derived from
//! the typed settings through serde (so nothing can be left out), with the
//! sequence table as comments. `--config` reads it back to the same
//! configuration.

use crate::config::Config;
use crate::control::selection::SequenceEntry;

impl Config {
    /// The complete configuration as TOML that [`Config::from_toml_str`]
    /// reads back to an equal `Config`.
    pub fn to_toml(&self) -> Result<String, toml::ser::Error> {
        /// `[sensor]` as a table of its own, after the core's sections.
        #[derive(serde::Serialize)]
        struct SensorSection<'a> {
            sensor: &'a crate::sensor::settings::SensorSettings,
        }
        // The backends' settings go into the core's `[arm]` table.
        let mut core = toml::Table::try_from(self.core())?;
        let backends = toml::Table::try_from(self.arm())?;
        let feedback = toml::Value::try_from(self.core().feedback())?;
        if let Some(toml::Value::Table(arm)) = core.get_mut("arm") {
            arm.insert("feedback".into(), feedback);
            arm.extend(backends);
        }
        let mut text = toml::to_string(&core)?;
        text += "\n";
        text += &toml::to_string(&SensorSection {
            sensor: self.sensor(),
        })?;
        let mut entries = self.core().sequences().iter();
        let mut out = String::from(
            "# sipnpuff configuration: every setting in effect (defaults filled in).\n\n",
        );
        for line in text.lines() {
            out += line;
            if line == "[[sequence]]"
                && let Some(entry) = entries.next()
            {
                out += "  # ";
                out += &describe(entry);
            }
            out.push('\n');
        }
        Ok(out)
    }
}

/// A sequence for people: its bursts and what its mode does.
fn describe(entry: &SequenceEntry) -> String {
    let bursts: Vec<String> = entry
        .actions
        .as_slice()
        .iter()
        .map(|a| a.to_string())
        .collect();
    format!("{}: {}", bursts.join(", "), entry.mode.description())
}
