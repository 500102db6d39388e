//! `sipnpuff fit`: fits a user's settings from a calibration session and
//! writes their profile.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::Context;

use crate::cli::args::ConfigArg;
use crate::cli::output;
use crate::fit::check::{COLUMNS, Confusion};
use crate::fit::drift;
use crate::fit::predict::{KindRates, Rates};
use crate::fit::profile::{self, Header};
use crate::fit::protocol::{DEFAULT_COUNT, DEFAULT_HOLDS, Protocol};
use crate::fit::signal::Signal;
use crate::tools::recording::read::Recording;

/// The file a guided session leaves in its recording: the protocol it
/// followed. A recording without it is ordinary use.
pub const CALIBRATION: &str = "calibration.json";
use crate::fit::{self as fitting, Fit};

/// `fit`'s options.
#[derive(clap::Args, Debug)]
pub struct FitArgs {
    /// The calibration to fit: a `tick,volts` CSV at 1 kHz or a `run
    /// --record` directory, breathed in the protocol's order (rest ≥ 5 s;
    /// short puffs, long puffs, short sips, long sips; then the holds).
    #[arg(long)]
    from: PathBuf,
    /// Where to write the profile (a configuration file).
    #[arg(long)]
    out: Option<PathBuf>,
    /// The settings in use, to compare with (default: built-in).
    #[command(flatten)]
    config: ConfigArg,
    /// Breaths per block.
    #[arg(long, default_value_t = DEFAULT_COUNT, value_parser = clap::value_parser!(u32).range(3..=50))]
    count: u32,
    /// The session ends with the longest comfortable puffs and sips
    /// (three of each).
    #[arg(long)]
    holds: bool,
    /// The user's label for the profile's header.
    #[arg(long, default_value = "user")]
    label: String,
    /// Write the profile even when short and long breaths overlap.
    #[arg(long)]
    force: bool,
    /// Print the fit as one JSON object instead of the report.
    #[arg(long)]
    json: bool,
}

/// Fits, reports, and writes the profile if it reads the user reliably
/// (or `--force`). Exit 0 with a profile; 1 with the reason and nothing
/// written.
pub fn fit(args: FitArgs) -> anyhow::Result<u8> {
    let protocol = Protocol::new(args.count, if args.holds { DEFAULT_HOLDS } else { 0 });
    let signal = Signal::read(&args.from).map_err(anyhow::Error::msg)?;
    let current = args.config.load()?;
    let as_protocol = fitting::fit(&signal, &protocol, &current);
    // A recording of a guided session says so; any other recording that
    // follows the protocol block for block is a calibration too; the
    // rest is ordinary use.
    let follows = as_protocol
        .as_ref()
        .is_ok_and(|f| f.answers.notes.is_empty());
    let ordinary_use = args.from.is_dir() && !args.from.join(CALIBRATION).exists() && !follows;
    let fitted = if ordinary_use {
        // The profile in use: `--config`, or what the session recorded.
        let in_use = match &args.config.config {
            Some(_) => current,
            None => Recording::open(&args.from)?.config,
        };
        note!(
            "{}: a session of ordinary use (it does not follow the protocol): its breaths split into short and long as you made them",
            args.from.display()
        );
        fitting::fit_use(&signal, &in_use)
    } else {
        as_protocol
    };
    let fit = match fitted {
        Ok(fit) => fit,
        Err(e) => {
            note!("error: cannot fit {}: {e}", args.from.display());
            return Ok(output::FAILED);
        }
    };
    if let Some(path) = &args.config.config {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        let then = drift::fitted(&text);
        if then.is_empty() {
            note!(
                "{} has no fitted measurements in its header: no drift to report",
                path.display()
            );
        }
        for line in drift::drift(&then, &fit.classes) {
            note!("drift: {line}");
        }
    }
    if args.json {
        output::stdout_line(&json(&fit)?).context("stdout")?;
    } else {
        output::stdout(&report(&fit)).context("stdout")?;
    }
    if let Some(overlap) = &fit.overlap
        && !args.force
    {
        note!("no profile written: {overlap} (--force writes it anyway)");
        return Ok(output::FAILED);
    }
    let Some(out) = &args.out else {
        return Ok(output::COMPLETED);
    };
    let header = Header {
        label: args.label.clone(),
        date: crate::tools::recording::meta::utc_now()[..10].to_string(),
        source: args.from.display().to_string(),
    };
    let text = profile::text(&fit, &header);
    std::fs::write(out, &text).with_context(|| format!("cannot write {}", out.display()))?;
    note!("wrote the profile to {}", out.display());
    Ok(output::COMPLETED)
}

/// The fit as JSON.
fn json(fit: &Fit) -> anyhow::Result<String> {
    let value = serde_json::json!({
        "rest": {
            "level_volts": fit.found.rest.level,
            "noise_sd_volts": fit.found.rest.sd,
            "excursion_up_volts": fit.found.rest.excursion_up,
            "excursion_down_volts": fit.found.rest.excursion_down,
            "spikes": fit.found.rest.spikes,
            "ms": fit.found.rest.ms,
        },
        "classes": fit.classes,
        "gaps_ms": fit.gaps,
        "notes": fit.answers.notes,
        "proposed": fit.proposal.settings,
        "predicted": { "current": fit.predicted[0], "proposed": fit.predicted[1] },
        "replayed": { "current": fit.replayed[0], "proposed": fit.replayed[1] },
        "overlap": fit.overlap,
        "worse": fit.worse,
    });
    Ok(serde_json::to_string(&value)?)
}

/// The report a clinician reads.
pub fn report(fit: &Fit) -> String {
    let mut out = String::new();
    let rest = &fit.found.rest;
    let _ = writeln!(
        out,
        "rest: {:.3} V over {:.1} s, noise sd {:.3} V, largest excursion +{:.3} / −{:.3} V, {} spikes",
        rest.level,
        rest.ms as f64 / 1000.0,
        rest.sd,
        rest.excursion_up,
        rest.excursion_down,
        rest.spikes
    );
    for note in &fit.answers.notes {
        let _ = writeln!(out, "note: {note}");
    }
    let _ = writeln!(out, "\nmeasured (durations at the proposed thresholds):");
    for c in &fit.classes {
        let _ = writeln!(
            out,
            "  {:<26} {:>2}  plateau {:.2} ± {:.2} V (weakest {:.2})  {:>5.0} ± {:>3.0} ms ({:.0}–{:.0})",
            c.ask.words(),
            c.breaths,
            c.plateau_volts.mean,
            c.plateau_volts.sd,
            c.plateau_volts.min,
            c.duration_ms.mean,
            c.duration_ms.sd,
            c.duration_ms.min,
            c.duration_ms.max
        );
    }
    let _ = writeln!(
        out,
        "  pauses between breaths: {:.0} ± {:.0} ms",
        fit.gaps.mean, fit.gaps.sd
    );
    let _ = writeln!(out, "\nproposed settings:");
    for s in &fit.proposal.settings {
        let _ = writeln!(out, "  {} = {}\n      {}", s.key, s.value, s.reason);
    }
    let _ = writeln!(out, "\npredicted misreadings        current  proposed");
    rates(&mut out, &fit.predicted[0], &fit.predicted[1]);
    let _ = writeln!(
        out,
        "\nthe session replayed through the detector (rows: asked or, in ordinary use, as you meant them; columns: read)"
    );
    for (name, c) in [
        ("current", &fit.replayed[0]),
        ("proposed", &fit.replayed[1]),
    ] {
        matrix(&mut out, name, c);
    }
    for w in &fit.worse {
        let _ = writeln!(out, "worse than the current settings: {w}");
    }
    if let Some(overlap) = &fit.overlap {
        let _ = writeln!(out, "\n{overlap}");
    }
    out
}

fn rates(out: &mut String, now: &Rates, new: &Rates) {
    let pct = |v: f64| format!("{:>6.1} %", 100.0 * v);
    type Rate = fn(&KindRates) -> f64;
    let rows: [(&str, Rate); 3] = [
        ("missed", |k| k.missed),
        ("short read as long", |k| k.short_as_long),
        ("long read as short", |k| k.long_as_short),
    ];
    for (kind, a, b) in [
        ("puffs", &now.puff, &new.puff),
        ("sips", &now.sip, &new.sip),
    ] {
        for (what, f) in rows {
            let _ = writeln!(
                out,
                "  {:<26} {} {}",
                format!("{kind} {what}"),
                pct(f(a)),
                pct(f(b))
            );
        }
    }
    let _ = writeln!(
        out,
        "  {:<26} {:>6.2}/h {:>6.2}/h",
        "false bursts at rest", now.false_per_hour, new.false_per_hour
    );
}

fn matrix(out: &mut String, name: &str, c: &Confusion) {
    let (right, asked) = c.right();
    let _ = writeln!(
        out,
        "  {name}: {right}/{asked} read right, {} bursts nobody was asked for, {} faults",
        c.unprompted, c.faults
    );
    let header: Vec<String> = COLUMNS.iter().map(|c| format!("{c:>10}")).collect();
    let _ = writeln!(out, "    {:<26}{}", "", header.join(""));
    for row in &c.rows {
        let cells: Vec<String> = row.counts.iter().map(|n| format!("{n:>10}")).collect();
        let _ = writeln!(out, "    {:<26}{}", row.ask.words(), cells.join(""));
    }
}
