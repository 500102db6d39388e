//! `meta.json`: what a recording is and whether it is whole. Written at
//! the first tick recorded (`"status": "recording"`, incomplete) and again
//! when the run ends, so a recording whose process was killed says so.

use std::time::{SystemTime, UNIX_EPOCH};

use serde::{Deserialize, Serialize};

use crate::control::Tick;
use crate::rt::recorder::RecordingSummary;

/// What `format` holds in every `meta.json`.
pub const FORMAT_NAME: &str = "sipnpuff recording";

/// `meta.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Meta {
    /// Always [`FORMAT_NAME`].
    pub format: String,
    /// The version of the binary streams (`format::FORMAT_VERSION`).
    pub format_version: u8,
    /// The sipnpuff that recorded it.
    pub sipnpuff_version: String,
    /// `"recording"` while the run goes on (or if it never finished),
    /// `"finished"` once every file was ended.
    pub status: String,
    /// The start of the run, UTC, ISO 8601.
    pub start_time: String,
    /// The sensor, as it describes itself.
    pub sensor: String,
    /// The arm, as it describes itself.
    pub arm: String,
    /// A breath sensor and a head-worn IMU were read side by side (`run
    /// --imu`): a replay's core reads both. (Without it, a configuration
    /// naming a gesture set was run on the IMU alone.)
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub breath_and_imu: bool,
    /// The first tick recorded.
    pub first_tick: Option<Tick>,
    /// The last tick recorded.
    pub last_tick: Option<Tick>,
    /// What it holds and whether it is whole.
    #[serde(flatten)]
    pub summary: RecordingSummary,
}

impl Meta {
    /// The metadata of a recording that starts now.
    pub fn starting(sensor: &str, arm: &str, max_bytes: u64) -> Meta {
        Meta {
            format: FORMAT_NAME.into(),
            format_version: super::format::FORMAT_VERSION,
            sipnpuff_version: env!("CARGO_PKG_VERSION").into(),
            status: "recording".into(),
            start_time: utc_now(),
            sensor: sensor.into(),
            arm: arm.into(),
            breath_and_imu: false,
            first_tick: None,
            last_tick: None,
            summary: RecordingSummary {
                max_bytes,
                problems: vec!["the run has not finished".into()],
                ..RecordingSummary::default()
            },
        }
    }
}

/// Now, UTC, as `2025-01-31T12:34:56.789Z`.
pub fn utc_now() -> String {
    let ms = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_millis());
    utc(u64::try_from(ms).unwrap_or(u64::MAX))
}

/// Milliseconds since the Unix epoch as ISO 8601, UTC (proleptic
/// Gregorian; Howard Hinnant's `civil_from_days`).
pub fn utc(unix_ms: u64) -> String {
    let secs = unix_ms / 1000;
    let days = i64::try_from(secs / 86_400).unwrap_or(0);
    let rest = secs % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}.{:03}Z",
        rest / 3600,
        rest / 60 % 60,
        rest % 60,
        unix_ms % 1000
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rt::recorder::Lost;

    #[test]
    fn utc_dates() {
        assert_eq!(utc(0), "1970-01-01T00:00:00.000Z");
        // `date -u -d @951782400` (a leap day).
        assert_eq!(utc(951_782_400_000), "2000-02-29T00:00:00.000Z");
        assert_eq!(utc(1_735_689_599_999), "2024-12-31T23:59:59.999Z");
        assert_eq!(utc(4_107_542_400_000), "2100-03-01T00:00:00.000Z");
    }

    #[test]
    fn meta_round_trips_through_json() {
        let meta = Meta::starting("synthetic", "sim", 200_000_000);
        let text = serde_json::to_string_pretty(&meta).unwrap();
        assert!(text.contains("\"status\": \"recording\""), "{text}");
        let back: Meta = serde_json::from_str(&text).unwrap();
        assert_eq!(back, meta);
    }

    /// A `meta.json` as recordings hold it (`complete` after `status`)
    /// reads, its counts in the summary.
    #[test]
    fn a_recordings_meta_reads_with_its_counts_in_the_summary() {
        let text = r#"{
  "format": "sipnpuff recording",
  "format_version": 2,
  "sipnpuff_version": "0.1.0",
  "status": "finished",
  "complete": true,
  "start_time": "2026-12-03T09:49:31.626Z",
  "sensor": "synthetic",
  "arm": "sim",
  "first_tick": 0,
  "last_tick": 22729,
  "ticks": 22694,
  "arm_commands": 2269,
  "events": 24,
  "stop_tick": 22710,
  "bytes": 212214,
  "max_bytes": 200000000,
  "lost": { "ticks": 0, "arm_commands": 0, "events": 0 },
  "problems": []
}"#;
        let meta: Meta = serde_json::from_str(text).unwrap();
        assert_eq!(
            (meta.status.as_str(), meta.last_tick),
            ("finished", Some(22729))
        );
        assert_eq!(
            meta.summary,
            RecordingSummary {
                complete: true,
                ticks: 22694,
                arm_commands: 2269,
                events: 24,
                stop_tick: Some(22710),
                bytes: 212_214,
                max_bytes: 200_000_000,
                lost: Lost::default(),
                problems: Vec::new(),
            }
        );
    }
}
