//! The effective configuration as TOML: every section and key, written
//! through the file's serde layout (`File`) that reading uses too (so
//! nothing can be left out or named twice), with the sequence table as
//! comments. `--config` reads it back to the same configuration.

use crate::config::Config;
use crate::config::file::File;
use crate::control::selection::SequenceEntry;

impl Config {
    /// The complete configuration as TOML that [`Config::from_toml_str`]
    /// reads back to an equal `Config`.
    pub fn to_toml(&self) -> Result<String, toml::ser::Error> {
        let file = File::new(
            self.core.clone(),
            self.sensor.clone(),
            self.arm.clone(),
            self.output.clone(),
            self.rt.clone(),
        );
        let text = toml::to_string(&file)?;
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
    format!("{}: {}", bursts.join(", "), entry.target.description())
}

/// One library entry as a `[[sequence]]` table a file holds.
pub fn entry_toml(entry: &SequenceEntry) -> Result<String, toml::ser::Error> {
    #[derive(serde::Serialize)]
    struct One {
        sequence: [crate::config::library::LibraryEntry; 1],
    }
    toml::to_string(&One {
        sequence: [crate::config::library::LibraryEntry(*entry)],
    })
}
