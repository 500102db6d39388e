//! Opening a recording: each file is checked before anything is replayed,
//! and every problem names its file and the offset or line.

use std::fmt;
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

use crate::config::Config;
use crate::tools::recording::format::commands::{CommandDecoder, CommandItem};
use crate::tools::recording::format::samples::{SampleDecoder, SampleItem};
use crate::tools::recording::format::{FORMAT_VERSION, FormatError};
use crate::tools::recording::meta::{FORMAT_NAME, Meta};
use crate::tools::recording::{COMMANDS, CONFIG, EVENTS, META, SAMPLES};

/// What is wrong with a recording: the file, where in it, what.
#[derive(Debug)]
pub struct RecordingError {
    /// The file.
    pub path: PathBuf,
    /// Where in it: `offset N`, `line N`.
    pub place: Option<String>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for RecordingError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.place {
            Some(place) => write!(f, "{}: {place}: {}", self.path.display(), self.message),
            None => write!(f, "{}: {}", self.path.display(), self.message),
        }
    }
}

impl std::error::Error for RecordingError {}

impl RecordingError {
    fn new(path: PathBuf, message: impl Into<String>) -> Self {
        RecordingError {
            path,
            place: None,
            message: message.into(),
        }
    }

    /// A stream's format error, at its offset.
    pub fn format(path: PathBuf, e: FormatError) -> Self {
        RecordingError {
            path,
            place: Some(format!("offset {}", e.offset)),
            message: e.message,
        }
    }
}

/// A recording's directory, its metadata and configuration read.
#[derive(Debug, Clone)]
pub struct Recording {
    /// The directory.
    pub dir: PathBuf,
    /// `meta.json`.
    pub meta: Meta,
    /// `config.toml`, validated.
    pub config: Config,
}

/// What the streams hold (from [`Recording::check`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Contents {
    /// Ticks in `samples.bin`.
    pub ticks: u64,
    /// Arm commands in `commands.bin`.
    pub arm_commands: u64,
    /// Lines of `events.jsonl`.
    pub events: u64,
    /// Marks of lost ticks or commands in the streams.
    pub losses: u64,
}

/// `events.jsonl`, line by line, numbered.
pub struct EventLines {
    path: PathBuf,
    input: BufReader<File>,
    line: u64,
    text: String,
}

impl EventLines {
    /// The next line (without its newline) and its number, `None` at the
    /// end.
    pub fn next_line(&mut self) -> Result<Option<(u64, &str)>, RecordingError> {
        self.text.clear();
        let n = self
            .input
            .read_line(&mut self.text)
            .map_err(|e| RecordingError {
                path: self.path.clone(),
                place: Some(format!("line {}", self.line + 1)),
                message: format!("cannot read: {e}"),
            })?;
        if n == 0 {
            return Ok(None);
        }
        self.line += 1;
        if !self.text.ends_with('\n') {
            return Err(RecordingError {
                path: self.path.clone(),
                place: Some(format!("line {}", self.line)),
                message: "truncated: the last line has no newline (the writer did not finish)"
                    .into(),
            });
        }
        Ok(Some((self.line, self.text.trim_end_matches('\n'))))
    }
}

impl Recording {
    /// Reads `meta.json` and `config.toml` in `dir` and checks that the
    /// streams are there (regular files: a pipe would block).
    pub fn open(dir: &Path) -> Result<Recording, RecordingError> {
        let meta_path = dir.join(META);
        if !meta_path.exists() && !dir.is_dir() {
            return Err(RecordingError::new(
                dir.to_path_buf(),
                "not a directory (a recording is a directory written by `run --record`)",
            ));
        }
        let text = read_text(&meta_path, "not a recording, or its run never started")?;
        let meta: Meta = serde_json::from_str(&text).map_err(|e| RecordingError {
            path: meta_path.clone(),
            place: Some(format!("line {}, column {}", e.line(), e.column())),
            message: format!("not valid metadata: {e}"),
        })?;
        if meta.format != FORMAT_NAME {
            return Err(RecordingError::new(
                meta_path,
                format!("format {:?}, not {FORMAT_NAME:?}", meta.format),
            ));
        }
        if !(1..=FORMAT_VERSION).contains(&meta.format_version) {
            return Err(RecordingError::new(
                meta_path,
                format!(
                    "format version {}, this sipnpuff ({}) reads versions 1 to {FORMAT_VERSION}",
                    meta.format_version,
                    env!("CARGO_PKG_VERSION")
                ),
            ));
        }
        let config_path = dir.join(CONFIG);
        let config = Config::from_file(&config_path).map_err(|e| RecordingError {
            path: config_path.clone(),
            place: None,
            // The error names the file itself.
            message: e
                .to_string()
                .trim_start_matches(&format!("{}: ", config_path.display()))
                .to_string(),
        })?;
        for name in [SAMPLES, COMMANDS, EVENTS] {
            regular_file(&dir.join(name))?;
        }
        Ok(Recording {
            dir: dir.to_path_buf(),
            meta,
            config,
        })
    }

    /// A file of the recording.
    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }

    fn open_file(&self, name: &str) -> Result<BufReader<File>, RecordingError> {
        let path = self.path(name);
        let file = File::open(&path)
            .map_err(|e| RecordingError::new(path, format!("cannot open: {e}")))?;
        Ok(BufReader::with_capacity(1 << 16, file))
    }

    /// `samples.bin`, its header checked.
    pub fn samples(&self) -> Result<SampleDecoder<BufReader<File>>, RecordingError> {
        SampleDecoder::new(self.open_file(SAMPLES)?)
            .map_err(|e| RecordingError::format(self.path(SAMPLES), e))
    }

    /// `commands.bin`, its header checked.
    pub fn commands(&self) -> Result<CommandDecoder<BufReader<File>>, RecordingError> {
        CommandDecoder::new(self.open_file(COMMANDS)?)
            .map_err(|e| RecordingError::format(self.path(COMMANDS), e))
    }

    /// `events.jsonl`.
    pub fn events(&self) -> Result<EventLines, RecordingError> {
        Ok(EventLines {
            path: self.path(EVENTS),
            input: self.open_file(EVENTS)?,
            line: 0,
            text: String::new(),
        })
    }

    /// Reads every stream to its end: the binary streams to their end
    /// markers and checksums, every event line as a JSON object. The first
    /// problem is an error naming its file and offset or line.
    pub fn check(&self) -> Result<Contents, RecordingError> {
        let mut contents = Contents::default();
        let mut samples = self.samples()?;
        while let Some(item) = samples
            .next_item()
            .map_err(|e| RecordingError::format(self.path(SAMPLES), e))?
        {
            match item {
                SampleItem::Input(_) => contents.ticks += 1,
                SampleItem::Lost(_) => contents.losses += 1,
            }
        }
        let mut commands = self.commands()?;
        while let Some(item) = commands
            .next_item()
            .map_err(|e| RecordingError::format(self.path(COMMANDS), e))?
        {
            match item {
                CommandItem::Command(_) => contents.arm_commands += 1,
                CommandItem::Lost(_) => contents.losses += 1,
            }
        }
        let mut events = self.events()?;
        while let Some((line, text)) = events.next_line()? {
            let value: Result<serde_json::Value, _> = serde_json::from_str(text);
            if !value.is_ok_and(|v| v.is_object() && v["tick"].is_u64()) {
                return Err(RecordingError {
                    path: self.path(EVENTS),
                    place: Some(format!("line {line}")),
                    message: "not an event (a JSON object with a tick)".into(),
                });
            }
            contents.events += 1;
        }
        Ok(contents)
    }
}

fn read_text(path: &Path, missing: &str) -> Result<String, RecordingError> {
    regular_file(path).map_err(|e| {
        if path.exists() {
            e
        } else {
            RecordingError::new(path.to_path_buf(), format!("missing ({missing})"))
        }
    })?;
    std::fs::read_to_string(path)
        .map_err(|e| RecordingError::new(path.to_path_buf(), format!("cannot read: {e}")))
}

fn regular_file(path: &Path) -> Result<(), RecordingError> {
    match std::fs::metadata(path) {
        Ok(m) if m.is_file() => Ok(()),
        Ok(_) => Err(RecordingError::new(
            path.to_path_buf(),
            "not a regular file",
        )),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Err(RecordingError::new(
            path.to_path_buf(),
            "missing (the recording's writer did not finish, or the file was removed)",
        )),
        Err(e) => Err(RecordingError::new(
            path.to_path_buf(),
            format!("cannot read: {e}"),
        )),
    }
}
