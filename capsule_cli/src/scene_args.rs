//! The scene flags shared by `simulate`, `sweep` and `bench`: a scene file and/or overrides
//! named after the paper's symbols; with `--param`, the parameter `sweep` and `continue` vary.

use crate::Refused;
use anyhow::{bail, Result};
use capsule_analysis::Param;
use capsule_args::{ranges, scene_file::SceneFile};
use capsule_plant::model::{K_S, MU_V, TAU_D, V_S};
use capsule_plant::scene::{key_rule, Scene};
use capsule_plant::{Friction, Method, SolverConfig, State};
use clap::builder::{PossibleValuesParser, TypedValueParser};
use clap::Args;

/// `--friction`: the choices are the names of [`Friction::LAWS`] (one table for scene files,
/// flags and docs), each with the paper's constants.
fn friction_law() -> impl TypedValueParser<Value = Friction> {
    PossibleValuesParser::new(Friction::LAWS.map(|l| l.name()))
        // every possible value is a law's name
        .map(|name| Friction::by_name(&name).unwrap_or(Friction::COULOMB))
}

/// A scene parameter to sweep or continue in: the names of [`Param::ALL`].
pub fn param() -> impl TypedValueParser<Value = Param> {
    PossibleValuesParser::new(Param::ALL.map(Param::name))
        // every possible value is a parameter's name
        .map(|name| Param::parse(&name).unwrap_or(Param::Alpha))
}

/// `--method`: the names of [`Method::ALL`].
fn method() -> impl TypedValueParser<Value = Method> {
    PossibleValuesParser::new(Method::ALL.map(Method::name))
        // every possible value is a method's name
        .map(|name| Method::by_name(&name).unwrap_or(Method::Adaptive))
}

/// A scene and overrides. Without --scene: the paper's section-3 set (gamma 5, omega 0.95,
/// beta 15, delta 0.02, xi 0.01, alpha 0.8), Coulomb friction, all-zero start, 300 periods with
/// 200 transient, the most accurate method for the law ([`Scene::default`], which also fills in
/// whatever a scene file leaves out). `--periods` without `--transient` scales the transient
/// with the periods (the scene's share, 2/3 by default), with or without a scene.
#[derive(Debug, Clone, Args)]
pub struct SceneArgs {
    /// Scene file (TOML); flags below override it.
    #[arg(long, value_name = "FILE")]
    pub scene: Option<std::path::PathBuf>,
    /// Friction law, with the paper's constants unless the flags below set them.
    #[arg(long, value_parser = friction_law())]
    pub friction: Option<Friction>,
    /// Drive amplitude alpha = P_d / P_f, [0, 100].
    #[arg(long, value_parser = ranges::obeying(const { key_rule("drive.alpha") }))]
    pub alpha: Option<f64>,
    /// Drive frequency omega = Omega / Omega_0, > 0.
    #[arg(long, value_parser = ranges::obeying(const { key_rule("drive.omega") }))]
    pub omega: Option<f64>,
    /// Mass ratio gamma = m2 / m1, > 0.
    #[arg(long, value_parser = ranges::obeying(const { key_rule("capsule.gamma") }))]
    pub gamma: Option<f64>,
    /// Stiffness ratio beta = k2 / k1 of the secondary spring, >= 0.
    #[arg(long, value_parser = ranges::obeying(const { key_rule("capsule.beta") }))]
    pub beta: Option<f64>,
    /// Gap delta before the secondary spring, >= 0.
    #[arg(long, value_parser = ranges::obeying(const { key_rule("capsule.delta") }))]
    pub delta: Option<f64>,
    /// Damping ratio xi, >= 0.
    #[arg(long, value_parser = ranges::obeying(const { key_rule("capsule.xi") }))]
    pub xi: Option<f64>,
    /// Position feedback gain k_p (u = k_p |x2 - x1|), any finite number.
    #[arg(long, value_parser = ranges::obeying(const { key_rule("control.kp") }))]
    pub kp: Option<f64>,
    /// Viscous friction coefficient (viscous, seven-parameter, gaussian-stribeck), [0, 1e12].
    #[arg(long, value_parser = ranges::non_negative(ranges::MAX_MAGNITUDE))]
    pub mu_v: Option<f64>,
    /// Stribeck velocity (stribeck, seven-parameter, gaussian-stribeck), (0, 1e12].
    #[arg(long, value_parser = ranges::positive(ranges::MAX_MAGNITUDE))]
    pub v_s: Option<f64>,
    /// Frictional-memory delay (seven-parameter), [0, 1e12].
    #[arg(long, value_parser = ranges::non_negative(ranges::MAX_MAGNITUDE))]
    pub tau_d: Option<f64>,
    /// Pre-sliding stiffness (seven-parameter), (0, 1e12].
    #[arg(long, value_parser = ranges::positive(ranges::MAX_MAGNITUDE))]
    pub k_s: Option<f64>,
    /// Initial state x1,y1,x2,y2 (four finite numbers).
    #[arg(long, value_name = "X1,Y1,X2,Y2", allow_hyphen_values = true)]
    pub x0: Option<String>,
    /// Drive periods simulated in all, 1 to 4294967295 (see --max-work).
    #[arg(long, value_parser = ranges::count_u32(1, u32::MAX))]
    pub periods: Option<u32>,
    /// Leading periods not measured, 0 to --periods - 1 [default: scaled with --periods].
    #[arg(long, value_parser = ranges::count_u32(0, u32::MAX))]
    pub transient: Option<u32>,
    /// Integration method [default: exact for coulomb/viscous, else adaptive]: exact piecewise
    /// solution, adaptive Dormand-Prince 5(4) with event location, or fixed-step RK4 without
    /// event location (baseline).
    #[arg(long, value_parser = method())]
    pub method: Option<Method>,
    /// Tolerance of the adaptive method, (0, 1) [default: 1e-10].
    #[arg(long, value_parser = ranges::open_unit())]
    pub tol: Option<f64>,
    /// Step of the fixed method, (0, 1e12] [default: 1e-3] (see --max-work).
    #[arg(long, value_parser = ranges::positive(ranges::MAX_MAGNITUDE))]
    pub step: Option<f64>,
}

/// A scene and one of its parameters to vary: the flags of `sweep` and `continue`.
#[derive(Debug, Clone, Args)]
pub struct ParamArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Parameter to vary.
    #[arg(long, value_parser = param())]
    pub param: Param,
}

impl SceneArgs {
    /// The scene: file (or defaults) with the flags applied, validated. A refused scene is a
    /// [`capsule_plant::scene::SceneError`] naming the file (or "defaults"), the key and why.
    pub fn scene(&self) -> Result<Scene> {
        let (mut scene, source) = match &self.scene {
            Some(path) => (SceneFile::read(path)?.scene, path.display().to_string()),
            None => (Scene::default(), "defaults".to_string()),
        };
        if let Some(f) = self.friction {
            scene.model.friction = f;
            if self.method.is_none() {
                scene.solver = SolverConfig {
                    method: SolverConfig::most_accurate_for(&scene.model).method,
                    ..scene.solver
                };
            }
        }
        self.apply_friction_constants(&mut scene.model.friction)?;
        let c = &mut scene.model.capsule;
        set(&mut scene.drive.alpha, self.alpha);
        set(&mut scene.drive.omega, self.omega);
        set(&mut c.gamma, self.gamma);
        set(&mut c.beta, self.beta);
        set(&mut c.delta, self.delta);
        set(&mut c.xi, self.xi);
        set(&mut scene.control.kp, self.kp);
        if let Some(x0) = &self.x0 {
            scene.initial = parse_x0(x0)?;
        }
        match (self.periods, self.transient) {
            // the one rule, as in a scene file: periods alone scale the transient with them
            (Some(p), None) => scene.horizon = scene.horizon.with_periods(p),
            (p, t) => {
                set(&mut scene.horizon.periods, p);
                set(&mut scene.horizon.transient, t);
            }
        }
        set(&mut scene.solver.method, self.method);
        set(&mut scene.solver.tol, self.tol);
        set(&mut scene.solver.step, self.step);
        scene
            .validate()
            .map_err(|e| e.in_file(&format!("{source} with command-line overrides")))?;
        Ok(scene)
    }

    /// The scene as a TOML text to store with a recording: the resolved scene, every key
    /// written out (reading it back gives the same scene), and the command line as a comment.
    pub fn scene_text(&self, scene: &Scene) -> String {
        let args: Vec<String> = std::env::args().skip(1).collect();
        format!("# capsule {}\n{}", args.join(" "), scene.to_toml())
    }

    /// The friction flags onto the law; a flag the law has no constant for is refused.
    fn apply_friction_constants(&self, f: &mut Friction) -> Result<()> {
        let flags = [
            (MU_V, self.mu_v),
            (V_S, self.v_s),
            (TAU_D, self.tau_d),
            (K_S, self.k_s),
        ];
        for (c, v) in flags {
            if let Some(v) = v {
                if !f.set_constant(c.key, v) {
                    bail!(Refused(format!(
                        "--{} does not apply to the {} friction law",
                        c.flag(),
                        f.name()
                    )));
                }
            }
        }
        Ok(())
    }
}

fn set<T: Copy>(slot: &mut T, v: Option<T>) {
    if let Some(v) = v {
        *slot = v;
    }
}

fn parse_x0(text: &str) -> Result<State> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != 4 {
        bail!(Refused(format!(
            "--x0 `{text}`: expected four comma-separated numbers x1,y1,x2,y2"
        )));
    }
    let mut a = [0.0; 4];
    for (slot, p) in a.iter_mut().zip(&parts) {
        *slot = p
            .parse()
            .map_err(|_| Refused(format!("--x0 `{text}`: `{p}` is not a number")))?;
    }
    Ok(State::from_array(a))
}
