//! `capsule identify`: a twin fitted to a recording (`capsule_analysis::identify`), checked
//! on a run it did not see (`capsule_analysis::twin_validation`), written as a scene that runs
//! as it is, and pictured.

use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result};
use capsule_analysis::identify::{
    identify_and_validate, IdentifyError, Outcome, Printed, Segment, Settings,
};
use capsule_analysis::twin::Recorded;
use capsule_analysis::twin_validation::Validation;
use capsule_args::scene_file::SceneFile;
use capsule_plant::scene::Scene;
use capsule_record::series::{series, ForceSource, Series};

use crate::svg::{self, Curve, Panel, Style};
use crate::{work, Refused};

/// `capsule identify`'s arguments.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The recording (an MCAP file, or a split recording's directory or metadata.yaml) with the
    /// plant's states and the force commands
    #[arg(long)]
    recording: PathBuf,
    /// The nominal scene: its values start the fit, its [device] is the actuator (coil lag,
    /// limits) between the commands and the capsule
    #[arg(long)]
    scene: PathBuf,
    /// Scene keys to fit, comma-separated, as written in the file (capsule.gamma,
    /// capsule.beta, capsule.delta, capsule.xi, friction.<constant>, physical.*)
    #[arg(long, value_delimiter = ',', required = true)]
    free: Vec<String>,
    /// Fit only the samples from T0 to T1 s after the first ("T0:T1"); the rest validates
    #[arg(long, value_name = "T0:T1", value_parser = parse_segment)]
    segment: Option<Segment>,
    /// Write the nominal scene with the fitted values to this file
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
    /// Print the report as JSON
    #[arg(long)]
    json: bool,
    /// Validate the twin on this recording (a run the fit did not see)
    #[arg(long, value_name = "OTHER")]
    validate: Option<PathBuf>,
    /// At most N x (fitted numbers + 1) evaluations of the windows before the fit gives up,
    /// 1 to 1000
    #[arg(long, value_name = "N", default_value_t = 30,
          value_parser = clap::value_parser!(u16).range(1..=1000))]
    patience: u16,
    /// Picture of the validation: PREFIX.svg and PREFIX.png (recorded against predicted)
    #[arg(long, value_name = "PREFIX")]
    plot: Option<PathBuf>,
}

/// `T0:T1` in seconds, `0 <= T0 < T1`.
fn parse_segment(s: &str) -> Result<Segment, String> {
    let (a, b) = s
        .split_once(':')
        .ok_or_else(|| format!("`{s}`: give T0:T1 in seconds"))?;
    let num = |v: &str| {
        v.trim()
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite() && *x >= 0.0)
            .ok_or_else(|| format!("`{v}`: not a time >= 0 in seconds"))
    };
    let (t0_s, t1_s) = (num(a)?, num(b)?);
    if t1_s <= t0_s {
        return Err(format!("`{s}`: T1 must be after T0"));
    }
    Ok(Segment { t0_s, t1_s })
}

/// A recording's series as the twin's input.
fn recorded(s: Series) -> Recorded {
    let acted = s.forces.acted();
    Recorded::new(s.h_s, s.rel_m, s.x2_m, s.command_n).with_acted(acted)
}

/// Runs `capsule identify`.
pub fn main(args: Args) -> Result<()> {
    let file = SceneFile::read(&args.scene)?;
    for p in args.out.iter().chain(&args.plot) {
        work::check_parent(p)?;
    }
    let free_check = capsule_analysis::identify::free_keys(&file.scene, &args.free);
    free_check.map_err(|e| Refused(e.to_string()))?;
    let rec = series(&args.recording).map_err(|e| Refused(e.to_string()))?;
    let other = match &args.validate {
        Some(p) => Some(recorded(series(p).map_err(|e| Refused(e.to_string()))?)),
        None => None,
    };
    let forces = rec.forces;
    let rec = recorded(rec);
    if let Some(s) = args.segment {
        let (a, b) = s.range(rec.h_s, rec.len());
        if b <= a {
            return Err(Refused(format!(
                "--segment {}:{}: outside the recording ({:.3} s long)",
                s.t0_s,
                s.t1_s,
                rec.len() as f64 * rec.h_s
            ))
            .into());
        }
    }
    let t0 = std::time::Instant::now();
    let (identified, outcome) = identify_and_validate(
        &file.scene,
        &rec,
        &args.free,
        args.segment,
        other.as_ref(),
        &Settings {
            patience: usize::from(args.patience),
            ..Settings::default()
        },
    )
    .map_err(|e| match e {
        IdentifyError::NoConvergence(_) | IdentifyError::Pinned { .. } => {
            anyhow::anyhow!("identifying {}: {e}", args.recording.display())
        }
        other => Refused(format!("{}: {other}", args.recording.display())).into(),
    })?;
    let wall = t0.elapsed().as_secs_f64();
    if let Some(out) = &args.out {
        write_scene(out, &file, &identified.scene, &args)?;
    }
    if let (Some(prefix), Some(v)) = (&args.plot, &outcome.validation) {
        plot(prefix, v, &outcome.validated_on)?;
    }
    if args.json {
        let o = Printed {
            recording: args.recording.display().to_string(),
            forces: forces.name().to_string(),
            outcome: &outcome,
            out: args.out.as_ref().map(|p| p.display().to_string()),
            wall_time_s: wall,
        };
        println!("{}", serde_json::to_string_pretty(&o)?);
    } else {
        print_report(&args, &outcome, forces, wall);
    }
    Ok(())
}

/// The nominal scene file with the fitted keys set (its other tables, `[node]` included, as
/// they were), read back as every binary reads a scene before it is written.
fn write_scene(out: &Path, file: &SceneFile, fitted: &Scene, args: &Args) -> Result<()> {
    let mut doc: toml::Table = file
        .text
        .parse()
        .with_context(|| format!("{}: re-reading the scene", args.scene.display()))?;
    for key in &args.free {
        let v = fitted.number(key)?;
        if let Some((table, name)) = key.split_once('.') {
            let t = doc
                .entry(table.to_string())
                .or_insert_with(|| toml::Value::Table(toml::Table::new()));
            if let toml::Value::Table(t) = t {
                t.insert(name.to_string(), toml::Value::Float(v));
            }
        }
    }
    let note = format!(
        "identified by capsule identify from {} (free: {})",
        args.recording.display(),
        args.free.join(", ")
    );
    doc.insert("description".into(), toml::Value::String(note));
    let text = toml::to_string(&doc)?;
    SceneFile::from_bytes(text.as_bytes(), &out.display().to_string(), String::new())
        .context("the fitted scene does not read back")?;
    std::fs::write(out, text).with_context(|| format!("writing {}", out.display()))?;
    Ok(())
}

/// The change from the nominal value in per cent, or `-` where there is no ratio (a nominal
/// zero: the delay of an ideal sensor).
fn change(v: f64, nominal: f64) -> String {
    let c = 100.0 * (v / nominal - 1.0);
    if nominal != 0.0 && c.is_finite() {
        format!("{c:>+8.1} %")
    } else {
        "-".into()
    }
}

/// The report as text.
fn print_report(args: &Args, o: &Outcome, forces: ForceSource, wall: f64) {
    let r = &o.report;
    println!(
        "recording      {}: {} samples at {:.0} Hz ({:.1} s), forces from the {}",
        args.recording.display(),
        o.samples,
        1.0 / o.h_s,
        o.samples as f64 * o.h_s,
        match forces {
            ForceSource::Commands => "commands",
            ForceSource::Acted => "force the states say acted over each period",
            ForceSource::Applied => "states' applied force",
        }
    );
    println!(
        "fitted         samples {}..{}: {} windows of {} samples (a drive period each)",
        o.fitted_samples[0], o.fitted_samples[1], r.windows, r.window_samples
    );
    println!(
        "{:<22} {:>12} {:>12} {:>12} {:>9}",
        "key", "nominal", "fitted", "+-1 s.e.", "change"
    );
    for e in r.parameters.iter().chain([&r.delay]) {
        match (e.value, e.std_error) {
            (Some(v), Some(sd)) => println!(
                "{:<22} {:>12.6} {:>12.6} {:>12.6} {:>9}",
                e.key,
                e.nominal,
                v,
                sd,
                change(v, e.nominal)
            ),
            _ => println!(
                "{:<22} {:>12.6} {:>12} {:>12} {:>9}",
                e.key, e.nominal, "-", "-", "-"
            ),
        }
    }
    println!(
        "residual RMS   {:.2} um (x1 - x2 {:.2} um, x2 {:.2} um) over {} positions",
        r.residual_rms_m * 1e6,
        r.residual_rms_displacement_m * 1e6,
        r.residual_rms_capsule_m * 1e6,
        r.residuals
    );
    println!("uncertainty    {}", r.uncertainty);
    if r.statements.is_empty() {
        let smallest = r.singular_values.last().copied().unwrap_or(f64::NAN);
        println!(
            "identifiable   every number (smallest relative singular value {smallest:.2e}, no pair correlated beyond {} with a standard error over {} % of its value)",
            capsule_analysis::identify::STRONG_CORRELATION,
            100.0 * capsule_analysis::identify::TOLD
        );
    }
    for s in &r.statements {
        println!("not identified {s}");
    }
    println!(
        "fit            {} evaluations ({}), {wall:.1} s",
        r.evaluations, r.termination
    );
    if let Some(v) = &o.validation {
        print_validation(v, &o.validated_on);
    }
    if let Some(out) = &args.out {
        println!("scene          {}", out.display());
    }
    if let Some(p) = &args.plot {
        println!("picture        {}.svg, .png", p.display());
    }
}

/// The validation's part of the report.
fn print_validation(v: &Validation, on: &str) {
    println!("validation     on {} ({:.0} drive periods)", on, v.periods);
    for h in &v.horizons {
        if h.starts == 0 {
            println!(
                "  {:>2} period(s) no start: the run is shorter than the horizon",
                h.periods
            );
            continue;
        }
        println!(
            "  {:>2} period(s) x2 error {:.1} um at the end ({:.1} um RMS over), x1 - x2 {:.1} um ({:.1}), {} starts",
            h.periods,
            h.capsule_end_m * 1e6,
            h.capsule_rms_m * 1e6,
            h.displacement_end_m * 1e6,
            h.displacement_rms_m * 1e6,
            h.starts
        );
    }
    if v.progression_error.is_finite() {
        println!(
            "  progression  recorded {:+.4} mm per period, predicted {:+.4} mm ({:+.2} %)",
            v.recorded_progression_m * 1e3,
            v.predicted_progression_m * 1e3,
            100.0 * v.progression_error
        );
    } else {
        println!(
            "  progression  recorded {:+.4} mm per period, no prediction to compare",
            v.recorded_progression_m * 1e3
        );
    }
    for f in &v.findings {
        println!("  - {f}");
    }
}

/// Recorded against predicted: the capsule over the whole run, `x1 - x2` over the first periods.
fn plot(prefix: &Path, v: &Validation, on: &str) -> Result<()> {
    // a trace's rows are (time [s], recorded [m], twin [m]); drawn in mm
    let curves = |t: &[[f64; 3]], recorded: Style, twin: Style| -> Vec<Curve> {
        let col = |i: usize| t.iter().map(|r| (r[0], r[i] * 1e3)).collect();
        vec![
            Curve::new("recorded", "black", recorded, col(1)),
            Curve::new("twin", "#d62728", twin, col(2)),
        ]
    };
    let capsule = Panel::new(
        "capsule position, predicted from the first period's state",
        "time [s]",
        "x2 [mm]",
        curves(&v.trace_capsule, Style::Line, Style::Dashed),
    );
    let displacement = Panel::new(
        "x1 - x2, each period predicted from the one before",
        "time [s]",
        "x1 - x2 [mm]",
        curves(&v.trace_displacement, Style::Dots, Style::Line),
    );
    let caption: Vec<String> = std::iter::once(format!("validated on {on}"))
        .chain(v.findings.iter().cloned())
        .collect();
    let doc = svg::panels(
        "The twin against the recording",
        &caption,
        2,
        svg::PANEL,
        &[capsule, displacement],
    );
    let svg_path = PathBuf::from(format!("{}.svg", prefix.display()));
    let png_path = PathBuf::from(format!("{}.png", prefix.display()));
    std::fs::write(&svg_path, &doc).with_context(|| format!("writing {}", svg_path.display()))?;
    let png = svg::png(&doc, 1.5).map_err(|e| anyhow::anyhow!("rasterising the picture: {e}"))?;
    std::fs::write(&png_path, png).with_context(|| format!("writing {}", png_path.display()))?;
    Ok(())
}
