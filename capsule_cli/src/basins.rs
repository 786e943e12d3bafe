//! `capsule basins`: basins of attraction on a plane of initial states, one map or a sweep of
//! maps over a parameter as one figure; prints a summary (with `--json` as JSON on stdout) and
//! with `--out` writes the picture (SVG, PNG) and the labels (CSV, JSON). Ctrl-C stops it and
//! writes the cells finished.

use crate::scene_args::SceneArgs;
use crate::svg;
use anyhow::{bail, Context, Result};
use capsule_analysis::attractor::SettleConfig;
use capsule_analysis::basin::{BasinMap, BasinRun, Cell, CellConfig, Grid, Method, Plane};
use capsule_analysis::basin_cells::basins_by;
use capsule_analysis::basin_summary::summary;
use capsule_analysis::Param;
use capsule_plant::scene::Scene;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

/// Basins of attraction.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    /// Grid size: columns and rows.
    #[arg(long, value_name = "NX,NY", default_value = "100,100")]
    grid: String,
    /// Horizontal range of initial values (cell centres at both ends).
    #[arg(
        long,
        value_name = "A,B",
        default_value = "-2,2",
        allow_hyphen_values = true
    )]
    x_range: String,
    /// Vertical range of initial values.
    #[arg(
        long,
        value_name = "C,D",
        default_value = "-2,2",
        allow_hyphen_values = true
    )]
    y_range: String,
    /// The plane: two of x1, y1, x2, y2, x1-x2, y1-y2; the rest of the state is the scene's
    /// initial state (default: the relative displacement and velocity, capsule at rest).
    #[arg(long, value_name = "A,B", default_value = "x1-x2,y1-y2")]
    plane: String,
    /// Sweep: one map per value of this parameter.
    #[arg(long, requires = "values", value_parser = crate::scene_args::param())]
    sweep: Option<Param>,
    /// The sweep's values, comma-separated.
    #[arg(
        long,
        value_name = "V1,V2,...",
        requires = "sweep",
        allow_hyphen_values = true
    )]
    values: Option<String>,
    /// Output prefix: writes PREFIX.svg, PREFIX.png, PREFIX.csv and PREFIX.json (no files
    /// without it).
    #[arg(long, value_name = "PREFIX")]
    out: Option<PathBuf>,
    /// Print the attractors, grid and work as JSON on stdout.
    #[arg(long)]
    json: bool,
    /// A run follows a known attractor when its section points stay this close (max norm) for
    /// three of its cycles; 0 lets every run settle on its own.
    #[arg(long, default_value_t = 1e-4)]
    known_tol: f64,
    /// How initial states are labelled: `known-cells` stops a run once it enters cells of the
    /// Poincaré section that earlier runs labelled (a few periods per state; a sample is rerun
    /// per state as a check), `per-state` runs each until it settles on its own or follows a
    /// known attractor (tens of periods per state).
    #[arg(long, value_enum, default_value = "known-cells")]
    basin_method: MethodArg,
    /// Known cells: edge of a cell on the section (x1 - x2, y1 - y2, y1), at most the grid's
    /// spacing [default: half the spacing, at most 0.05].
    #[arg(long, value_name = "SIZE")]
    cell: Option<f64>,
    /// Known cells: consecutive section points in cells of one attractor that stop a run.
    #[arg(long, value_name = "N", default_value_t = 2)]
    cell_hits: u32,
    /// Known cells: cell-labelled initial states rerun per state as a check.
    #[arg(long, value_name = "N", default_value_t = 200)]
    cell_check: usize,
    /// Worker threads [default: all cores].
    #[arg(long)]
    threads: Option<usize>,
}

/// `--basin-method`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MethodArg {
    /// Stop on cells of known basins.
    KnownCells,
    /// Each state on its own.
    PerState,
}

/// The method from the flags, checked against the grid.
pub fn method_of(
    arg: MethodArg,
    cell: Option<f64>,
    hits: u32,
    check: usize,
    grid: &Grid,
) -> Result<Method> {
    if arg == MethodArg::PerState {
        if cell.is_some() {
            bail!("--cell: only the known-cells method has cells (--basin-method known-cells)");
        }
        return Ok(Method::PerState);
    }
    let c = CellConfig {
        size: cell.unwrap_or(CellConfig::for_grid(grid).size),
        hits,
        check,
    };
    c.validate(grid)
        .map_err(|(k, r)| anyhow::anyhow!("--{k}: {r}"))?;
    Ok(Method::KnownCells(c))
}

/// `PREFIX.ext` (`Path::with_extension` would cut a prefix like `basins_kp0.05` at its dot).
pub fn with_ext(prefix: &Path, ext: &str) -> PathBuf {
    let mut s = prefix.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// Two numbers `A,B`.
pub fn pair<T: std::str::FromStr>(flag: &str, text: &str) -> Result<(T, T)> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let [a, b] = parts[..] else {
        bail!("--{flag} `{text}`: expected two comma-separated numbers");
    };
    let num = |s: &str| {
        s.parse::<T>()
            .map_err(|_| anyhow::anyhow!("--{flag} `{text}`: `{s}` is not a valid number"))
    };
    Ok((num(a)?, num(b)?))
}

/// The grid from the flags, checked.
pub fn grid_of(grid: &str, x_range: &str, y_range: &str, plane: &str) -> Result<Grid> {
    let (nx, ny) = pair::<usize>("grid", grid)?;
    let g = Grid {
        plane: Plane::parse(plane).map_err(|e| anyhow::anyhow!("--plane {e}"))?,
        nx,
        ny,
        x_range: pair("x-range", x_range)?,
        y_range: pair("y-range", y_range)?,
    };
    g.validate()
        .map_err(|(k, r)| anyhow::anyhow!("--{k}: {r}"))?;
    Ok(g)
}

/// A computed map with its parameter value (for sweeps) and wall time.
pub struct Computed {
    /// The swept value, if any.
    pub value: Option<f64>,
    /// The scene the map is of.
    pub scene: Scene,
    /// When its runs counted as settled.
    pub config: SettleConfig,
    /// The map.
    pub map: BasinMap,
    /// Wall time in seconds.
    pub wall_s: f64,
}

/// Compute one map per scene in order (each in parallel over its cells) under one progress bar;
/// after a Ctrl-C the remaining maps come back all pending.
pub fn compute(
    scenes: &[(Option<f64>, Scene)],
    grid: &Grid,
    known_tol: f64,
    method: &Method,
    cancel: &AtomicBool,
) -> Vec<Computed> {
    let bar = ProgressBar::new((grid.nx * grid.ny * scenes.len()) as u64);
    bar.set_style(
        ProgressStyle::with_template(
            "{bar:40} {pos}/{len} initial states, {elapsed} elapsed, eta {eta}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let out = compute_with(scenes, grid, known_tol, method, cancel, &|| bar.inc(1));
    bar.finish_and_clear();
    out
}

/// [`compute`] calling `progress` once per initial state instead of drawing a bar.
pub fn compute_with(
    scenes: &[(Option<f64>, Scene)],
    grid: &Grid,
    known_tol: f64,
    method: &Method,
    cancel: &AtomicBool,
    progress: &(dyn Fn() + Sync),
) -> Vec<Computed> {
    scenes
        .iter()
        .map(|(value, scene)| {
            let mut run = BasinRun::new(scene, *grid);
            run.config.known_tol = known_tol;
            let t0 = std::time::Instant::now();
            let map = basins_by(method, &run, progress, cancel);
            Computed {
                value: *value,
                scene: scene.clone(),
                config: run.config,
                map,
                wall_s: t0.elapsed().as_secs_f64(),
            }
        })
        .collect()
}

/// The scenes to map: `scene`, or one per value of `--sweep PARAM --values A,B,...` (at most
/// the 12 one figure holds), each checked.
fn scenes_of(
    scene: Scene,
    sweep: Option<Param>,
    values: Option<&str>,
) -> Result<Vec<(Option<f64>, Scene)>> {
    let (Some(param), Some(values)) = (sweep, values) else {
        return Ok(vec![(None, scene)]);
    };
    let name = param.name();
    let mut out = Vec::new();
    for v in values.split(',').map(str::trim) {
        let v: f64 = v
            .parse()
            .map_err(|_| anyhow::anyhow!("--values `{values}`: `{v}` is not a number"))?;
        let s = param.apply(&scene, v);
        s.validate()
            .map_err(|e| anyhow::anyhow!("--sweep {name} = {v}: {e}"))?;
        out.push((Some(v), s));
    }
    if out.len() > 12 {
        bail!(
            "--values: {} maps is more than the 12 one figure holds",
            out.len()
        );
    }
    Ok(out)
}

pub fn main(args: Args) -> Result<()> {
    let grid = grid_of(&args.grid, &args.x_range, &args.y_range, &args.plane)?;
    if !(args.known_tol >= 0.0 && args.known_tol.is_finite()) {
        bail!(
            "--known-tol {}: must be a finite number >= 0",
            args.known_tol
        );
    }
    let method = method_of(
        args.basin_method,
        args.cell,
        args.cell_hits,
        args.cell_check,
        &grid,
    )?;
    let scenes = scenes_of(args.scene.scene()?, args.sweep, args.values.as_deref())?;
    if let Some(n) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .context("setting up the worker threads")?;
    }
    // Ctrl-C: initial states not started afterwards are skipped (a second one ends the process)
    crate::work::catch_ctrl_c();
    let maps = compute(
        &scenes,
        &grid,
        args.known_tol,
        &method,
        crate::work::interrupt_flag(),
    );
    crate::work::release_ctrl_c();
    let name = args.sweep.map_or("", Param::name);
    let written = match &args.out {
        Some(prefix) => Some(write_all(prefix, name, &maps)?),
        None => None,
    };
    if args.json {
        let out: Vec<serde_json::Value> = maps
            .iter()
            .map(|m| {
                let mut v = serde_json::to_value(summary(&m.map, m.wall_s, &m.config))?;
                if let (Some(x), Some(obj)) = (m.value, v.as_object_mut()) {
                    obj.insert(name.to_string(), x.into());
                }
                Ok(v)
            })
            .collect::<Result<_>>()?;
        let doc = if args.sweep.is_some() {
            serde_json::json!({ "sweep": name, "maps": out })
        } else {
            out.into_iter().next().unwrap_or_default()
        };
        println!("{}", serde_json::to_string_pretty(&doc)?);
    } else {
        for m in &maps {
            print_summary(m, name);
        }
        if let Some(w) = &written {
            println!("wrote {w}");
        }
    }
    for m in &maps {
        if let Some(w) = summary(&m.map, m.wall_s, &m.config).warning {
            eprintln!("warning: {w}");
        }
    }
    let pending: usize = maps.iter().map(|m| m.map.pending()).sum();
    if crate::work::interrupted() || pending > 0 {
        let kept = written.map_or("not written (no --out)".to_string(), |w| format!("in {w}"));
        bail!("interrupted: {pending} initial states not computed; the finished ones are {kept}");
    }
    Ok(())
}

fn print_summary(m: &Computed, name: &str) {
    let s = summary(&m.map, m.wall_s, &m.config);
    if let Some(v) = m.value {
        println!("{name} = {v}:");
    }
    for a in &s.attractors {
        println!(
            "  {:<6} period {:<5} {:.2} impacts/period, progression {:+.5}, {:5.1} % of the grid",
            a.label,
            a.period.map_or("none".to_string(), |p| p.to_string()),
            a.impacts_per_period,
            a.avg_progression,
            100.0 * a.fraction
        );
    }
    let w = &s.work;
    println!(
        "  {} initial states in {:.2} s by {}: {:.3} ms and {:.1} periods per state; {} settled, {} on a known attractor, {} on known cells, {} at the {}-period horizon, {} failed",
        w.totals.runs,
        w.wall_s,
        s.basin_method.name(),
        w.ms_per_state,
        w.periods_per_state,
        w.totals.settled,
        w.totals.recognised,
        w.totals.known_cell,
        w.totals.horizon,
        w.max_periods,
        w.totals.failed,
    );
    if let (Method::KnownCells(c), Some(k)) = (s.basin_method, s.check) {
        println!(
            "  cells of {}, {} hits to stop; check: {} of {} sampled cell-labelled states differ per state (estimated {:.3} % of the map mislabelled)",
            c.size,
            c.hits,
            k.differ,
            k.sampled,
            100.0 * k.estimated_mislabelled
        );
    }
}

/// The map's title: scene parameters that matter for the basins.
pub fn title_of(scene: &Scene) -> String {
    format!(
        "{} friction, alpha {}, omega {}, k_p {}",
        scene.model.friction.name(),
        scene.drive.alpha,
        scene.drive.omega,
        scene.control.kp
    )
}

/// Write PREFIX.svg, .png, .csv, .json for the maps; returns the list of files written.
pub fn write_all(prefix: &Path, param: &str, maps: &[Computed]) -> Result<String> {
    let panels: Vec<svg::BasinPanel> = maps
        .iter()
        .map(|m| svg::BasinPanel {
            title: match m.value {
                Some(v) => format!("{param} = {v}"),
                None => title_of(&m.scene),
            },
            map: &m.map,
            labels: m.map.catalogue.ordered(),
        })
        .collect();
    let first = maps.first().map(|m| &m.scene);
    let g = maps.first().map(|m| m.map.grid);
    let title = match (first, param.is_empty()) {
        (Some(s), false) => format!("Basins of attraction over {param}: {}", title_of(s)),
        (Some(s), true) => format!("Basins of attraction: {}", title_of(s)),
        _ => "Basins of attraction".to_string(),
    };
    let caption = match (first, g) {
        (Some(s), Some(g)) => {
            let [x1, y1, x2, y2] = s.initial.to_array();
            vec![
                format!(
                    "{}; {} x {} initial states; dots: the attractors' Poincaré points.",
                    s.model.capsule,
                    g.nx,
                    g.ny,
                ),
                format!(
                    "Coordinates off the plane from (x1, y1, x2, y2) = ({x1}, {y1}, {x2}, {y2}); white: not computed, black: run failed."
                ),
            ]
        }
        _ => vec![],
    };
    let doc = svg::basins(&title, &caption, &panels);
    let svg_path = with_ext(prefix, "svg");
    let png_path = with_ext(prefix, "png");
    let csv_path = with_ext(prefix, "csv");
    let json_path = with_ext(prefix, "json");
    if let Some(dir) = prefix.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    std::fs::write(&svg_path, &doc).with_context(|| format!("writing {}", svg_path.display()))?;
    let png = svg::png(&doc, 1.5).map_err(|e| anyhow::anyhow!("rasterising the picture: {e}"))?;
    std::fs::write(&png_path, png).with_context(|| format!("writing {}", png_path.display()))?;
    write_csv(&csv_path, param, maps).with_context(|| format!("writing {}", csv_path.display()))?;
    let full: Vec<serde_json::Value> = maps
        .iter()
        .map(|m| {
            let labels = m.map.catalogue.ordered();
            let name = |i: usize| labels.iter().find(|l| l.0 == i).map(|l| l.1.clone());
            let rows: Vec<Vec<Option<String>>> = m
                .map
                .cells
                .chunks(m.map.grid.nx)
                .map(|row| {
                    row.iter()
                        .map(|c| match c {
                            Cell::Attractor { index, .. } => name(*index),
                            Cell::Failed(_) => Some("failed".into()),
                            Cell::Pending => None,
                        })
                        .collect()
                })
                .collect();
            let mut v = serde_json::to_value(summary(&m.map, m.wall_s, &m.config))?;
            if let Some(obj) = v.as_object_mut() {
                obj.insert("scene".into(), serde_json::to_value(&m.scene)?);
                obj.insert("labels".into(), serde_json::to_value(rows)?);
                if let Some(x) = m.value {
                    obj.insert(param.into(), x.into());
                }
            }
            Ok(v)
        })
        .collect::<Result<_>>()?;
    std::fs::write(&json_path, serde_json::to_string(&full)?)
        .with_context(|| format!("writing {}", json_path.display()))?;
    Ok(format!(
        "{}, {}, {}, {}",
        svg_path.display(),
        png_path.display(),
        csv_path.display(),
        json_path.display()
    ))
}

fn write_csv(path: &Path, param: &str, maps: &[Computed]) -> Result<()> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    let lead = if param.is_empty() { "" } else { "," };
    writeln!(w, "{param}{lead}i,j,x,y,label,period,stop,periods_run")?;
    for m in maps {
        let labels = m.map.catalogue.ordered();
        let g = &m.map.grid;
        let value = m.value.map_or(String::new(), |v| format!("{v},"));
        for (c, cell) in m.map.cells.iter().enumerate() {
            let (i, j) = (c % g.nx, c / g.nx);
            let (x, y) = g.point(i, j);
            let (label, period, stop, periods) = match cell {
                Cell::Pending => continue,
                Cell::Failed(e) => ("failed".to_string(), String::new(), e.clone(), 0),
                Cell::Attractor {
                    index,
                    stop,
                    periods_run,
                } => {
                    let label = labels
                        .iter()
                        .find(|l| l.0 == *index)
                        .map_or(String::new(), |l| l.1.clone());
                    let a = &m.map.catalogue.attractors[*index];
                    let stop = match stop {
                        capsule_analysis::attractor::Stop::Settled => "settled",
                        capsule_analysis::attractor::Stop::Recognised(_) => "recognised",
                        capsule_analysis::attractor::Stop::Horizon => "horizon",
                        capsule_analysis::attractor::Stop::KnownCell(_) => "known-cell",
                    };
                    (
                        label,
                        a.period.map_or(String::new(), |p| p.to_string()),
                        stop.to_string(),
                        *periods_run,
                    )
                }
            };
            writeln!(
                w,
                "{value}{i},{j},{x},{y},{label},{period},\"{}\",{periods}",
                stop.replace('"', "'")
            )?;
        }
    }
    w.flush()?;
    Ok(())
}
