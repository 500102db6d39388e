//! Measure in the loop, aggregate elsewhere: the control thread pushes one
//! small `Copy` [`TickRecord`] per tick (and each event) through rtrb rings;
//! the telemetry side owns the HdrHistograms, logs events, builds the
//! report and, with `run --record`, hands each tick's [`TickInput`] to the
//! session recorder.

use std::io::Write;

use hdrhistogram::Histogram;

pub use crate::wakes::histogram;
use serde::ser::SerializeStruct;
use serde::{Serialize, Serializer};

use crate::control::Tick;
use crate::control::event::TimedEvent;
use crate::control::tick::TickInput;
use crate::control::view::CoreView;

/// Items dropped because a ring was full, cumulative. A full ring never
/// blocks the control thread: the item is dropped and counted here.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct Drops {
    /// Sensor samples discarded (the sensor ran ahead of the loop).
    pub samples: u64,
    /// Arm commands dropped (arm thread not keeping up).
    pub arm_commands: u64,
    /// Tick records dropped (telemetry not keeping up).
    pub records: u64,
    /// Events dropped.
    pub events: u64,
    /// Copies of arm commands for the session recorder dropped (`run
    /// --record` only: the recorder's command ring was full).
    pub recorded_commands: u64,
}

/// One tick, as the control thread saw it. `Copy`, 648 bytes.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TickRecord {
    /// The tick.
    pub tick: Tick,
    /// When the control thread woke for it, `CLOCK_MONOTONIC` ns (the
    /// display's event-to-screen latency starts here).
    pub woke_ns: u64,
    /// Wake-up minus deadline, ns.
    pub wake_latency_ns: u64,
    /// Wake-up to end of the tick's work, ns.
    pub compute_ns: u64,
    /// Since the previous wake-up, ns (0 for the first tick).
    pub period_ns: u64,
    /// Ticks skipped before this one.
    pub skipped: u32,
    /// Events this tick.
    pub events: u8,
    /// `bench latency`: a reference tick (bare deadline wait).
    pub reference: bool,
    /// Drops so far.
    pub drops: Drops,
    /// What the core was given (meaningless on a `reference` tick, where
    /// the core did not run).
    pub input: TickInput,
    /// Where the user is after the tick: what the display shows.
    pub view: CoreView,
}

/// Watches a run from the telemetry thread (the display): each record and
/// event as it is drained from the control thread's rings, then
/// [`TelemetryObserver::drained`] once per drain (about every 5 ms). Not
/// RT-safe, and must not block: the telemetry thread also empties the
/// rings, and a consumer slower than the loop drops and counts on its own
/// side.
pub trait TelemetryObserver {
    /// One tick's record (reference ticks of `bench latency` included).
    fn record(&mut self, record: &TickRecord);
    /// One event.
    fn event(&mut self, event: &TimedEvent);
    /// The rings are empty for now.
    fn drained(&mut self);
}

/// Histograms of one arm of a run (ns). Not RT-safe: telemetry side.
/// Serialized as their percentiles.
#[derive(Debug, Clone, Serialize)]
pub struct Latencies {
    /// Wake-up latency.
    #[serde(rename = "wake_latency_ns", serialize_with = "as_percentiles")]
    pub wake: Histogram<u64>,
    /// Compute time.
    #[serde(rename = "compute_ns", serialize_with = "as_percentiles")]
    pub compute: Histogram<u64>,
    /// Wake-to-wake period.
    #[serde(rename = "period_ns", serialize_with = "as_percentiles")]
    pub period: Histogram<u64>,
}

impl Default for Latencies {
    fn default() -> Self {
        Latencies {
            wake: histogram(),
            compute: histogram(),
            period: histogram(),
        }
    }
}

impl Latencies {
    /// Adds one record.
    pub fn record(&mut self, r: &TickRecord) {
        self.wake.saturating_record(r.wake_latency_ns.max(1));
        self.compute.saturating_record(r.compute_ns.max(1));
        if r.period_ns > 0 {
            self.period.saturating_record(r.period_ns);
        }
    }
}

pub(crate) fn as_percentiles<S: Serializer>(
    h: &Histogram<u64>,
    serializer: S,
) -> Result<S::Ok, S::Error> {
    Percentiles::of(h).serialize(serializer)
}

/// The percentiles every report gives, in order: (key in JSON, label in
/// text, quantile; `1.0` is the maximum).
pub const PERCENTILES: [(&str, &str, f64); 6] = [
    ("p50", "p50", 0.50),
    ("p90", "p90", 0.90),
    ("p99", "p99", 0.99),
    ("p999", "p99.9", 0.999),
    ("p9999", "p99.99", 0.9999),
    ("max", "max", 1.0),
];

/// A percentile of a histogram (`1.0` is the maximum).
pub fn at(h: &Histogram<u64>, quantile: f64) -> u64 {
    if h.is_empty() {
        0
    } else if quantile >= 1.0 {
        h.max()
    } else {
        h.value_at_quantile(quantile)
    }
}

/// A histogram's count and [`PERCENTILES`], in its unit: what the reports
/// show. Serialized as `count` then each percentile under its key.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Percentiles {
    /// Values recorded.
    pub count: u64,
    /// The values at [`PERCENTILES`], in that order.
    pub values: [u64; PERCENTILES.len()],
}

impl Percentiles {
    /// The percentiles of `h`.
    pub fn of(h: &Histogram<u64>) -> Percentiles {
        Percentiles {
            count: h.len(),
            values: PERCENTILES.map(|(_, _, quantile)| at(h, quantile)),
        }
    }

    /// The median (the first of [`PERCENTILES`]).
    pub fn median(&self) -> u64 {
        self.values[0]
    }

    /// One line of text: `name`, then each percentile (ns) in µs.
    pub fn line(&self, name: &str) -> String {
        let mut s = format!("  {name:<22}");
        for ((_, label, _), value) in PERCENTILES.iter().zip(self.values) {
            s += &format!(" {label} {:>9.1}", value as f64 / 1000.0);
        }
        s
    }
}

impl Serialize for Percentiles {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut s = serializer.serialize_struct("Percentiles", 1 + PERCENTILES.len())?;
        s.serialize_field("count", &self.count)?;
        for ((key, _, _), value) in PERCENTILES.iter().zip(&self.values) {
            s.serialize_field(key, value)?;
        }
        s.end()
    }
}

/// Writes a histogram in HdrHistogram's percentile-distribution text format
/// (`.hgrm`, as `outputPercentileDistribution` prints it; the HdrHistogram
/// plotter reads it), values in µs.
pub fn write_hgrm(out: &mut impl Write, h: &Histogram<u64>) -> std::io::Result<()> {
    let scale = 1000.0;
    writeln!(
        out,
        "{:>12} {:>14} {:>10} {:>14}\n",
        "Value", "Percentile", "TotalCount", "1/(1-Percentile)"
    )?;
    let mut total = 0u64;
    for v in h.iter_quantiles(5) {
        total += v.count_since_last_iteration();
        let value = v.value_iterated_to() as f64 / scale;
        let q = v.quantile_iterated_to();
        if q < 1.0 {
            writeln!(
                out,
                "{value:12.3} {q:2.12} {total:10} {:14.2}",
                1.0 / (1.0 - q)
            )?;
        } else {
            writeln!(out, "{value:12.3} {q:2.12} {total:10}")?;
        }
    }
    writeln!(
        out,
        "#[Mean    = {:12.3}, StdDeviation   = {:12.3}]",
        h.mean() / scale,
        h.stdev() / scale
    )?;
    writeln!(
        out,
        "#[Max     = {:12.3}, Total count    = {:12}]",
        h.max() as f64 / scale,
        h.len()
    )?;
    writeln!(
        out,
        "#[Buckets = {:12}, SubBuckets     = {:12}]",
        h.buckets(),
        2048
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hgrm_has_the_plotters_columns() {
        let mut h = histogram();
        for v in 1..=1000u64 {
            h.record(v * 1000).unwrap(); // 1 µs … 1 ms
        }
        let mut out = Vec::new();
        write_hgrm(&mut out, &h).unwrap();
        let text = String::from_utf8(out).unwrap();
        let mut lines = text.lines();
        assert!(
            lines
                .next()
                .unwrap()
                .contains("Value     Percentile TotalCount 1/(1-Percentile)")
        );
        assert_eq!(lines.next(), Some(""));
        let rows: Vec<Vec<f64>> = text
            .lines()
            .skip(2)
            .take_while(|l| !l.starts_with('#'))
            .map(|l| l.split_whitespace().map(|f| f.parse().unwrap()).collect())
            .collect();
        assert!((rows[0][0] - 1.0).abs() < 0.01, "{:?}", rows[0]);
        let last = rows.last().unwrap();
        assert_eq!((last[1], last[2]), (1.0, 1000.0));
        assert!((last[0] - 1000.0).abs() < 1.0);
        assert!(
            rows.windows(2)
                .all(|w| w[0][1] <= w[1][1] && w[0][2] <= w[1][2])
        );
        assert!(text.contains("#[Max     =     1000."), "{text}");
    }

    #[test]
    fn a_tick_record_stays_small() {
        // One per tick through a 16 384-record ring: 10.6 MB (the arm's
        // pose and the IMU's sample are in the core's input, the display's
        // view of the core in the record, its sequence of up to 16 tokens
        // inline). A change here should update the doc comments and
        // docs/runtime.md.
        assert_eq!(std::mem::size_of::<TickInput>(), 160);
        assert_eq!(std::mem::size_of::<CoreView>(), 400);
        assert_eq!(std::mem::size_of::<TickRecord>(), 648);
    }

    #[test]
    fn percentiles_read_alike_in_text_and_json() {
        let p = Percentiles {
            count: 7,
            values: [1_000, 2_000, 3_000, 4_500, 5_000, 60_000],
        };
        assert_eq!(
            p.line("compute"),
            "  compute                p50       1.0 p90       2.0 p99       3.0 p99.9       4.5 p99.99       5.0 max      60.0"
        );
        assert_eq!(
            serde_json::to_string(&p).unwrap(),
            r#"{"count":7,"p50":1000,"p90":2000,"p99":3000,"p999":4500,"p9999":5000,"max":60000}"#
        );
        assert_eq!(p.median(), 1_000);
    }

    #[test]
    fn records_land_in_their_histograms() {
        let mut l = Latencies::default();
        l.record(&TickRecord {
            wake_latency_ns: 25_000,
            compute_ns: 600,
            period_ns: 1_000_000,
            ..TickRecord::default()
        });
        assert_eq!(l.wake.len(), 1);
        assert!((at(&l.wake, 0.5) as f64 - 25_000.0).abs() < 25.0);
        assert_eq!(l.period.len(), 1);
    }
}
