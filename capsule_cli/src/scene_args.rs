//! The scene flags shared by `simulate`, `sweep` and `bench`: a scene file and/or overrides
//! named after the paper's symbols.

use anyhow::{bail, Context, Result};
use capsule_plant::scene::{Scene, PAPER_K_S, PAPER_MU_V, PAPER_TAU_D, PAPER_V_S};
use capsule_plant::{Friction, Method, SolverConfig, State};
use clap::{Args, ValueEnum};

/// Friction law names on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FrictionArg {
    /// Dry Coulomb friction.
    Coulomb,
    /// Coulomb plus viscous damping (mu_v).
    Viscous,
    /// Coulomb plus Stribeck (v_s).
    Stribeck,
    /// Stribeck with frictional memory (tau_d) and pre-sliding (k_s).
    SevenParameter,
}

/// Integration methods on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// Exact piecewise solution (coulomb, viscous).
    Exact,
    /// Adaptive Dormand-Prince 5(4) with event location.
    Adaptive,
    /// Fixed-step RK4 without event location (baseline).
    Fixed,
}

/// A scene and overrides. Without --scene: the paper's section-3 set (gamma 5, omega 0.95,
/// beta 15, delta 0.02, xi 0.01, alpha 0.8), Coulomb friction, all-zero start, 300 periods with
/// 200 transient, the most accurate method for the law.
#[derive(Debug, Clone, Args)]
pub struct SceneArgs {
    /// Scene file (TOML); flags below override it.
    #[arg(long, value_name = "FILE")]
    pub scene: Option<std::path::PathBuf>,
    /// Friction law.
    #[arg(long, value_enum)]
    pub friction: Option<FrictionArg>,
    /// Drive amplitude alpha = P_d / P_f.
    #[arg(long)]
    pub alpha: Option<f64>,
    /// Drive frequency omega = Omega / Omega_0.
    #[arg(long)]
    pub omega: Option<f64>,
    /// Mass ratio gamma = m2 / m1.
    #[arg(long)]
    pub gamma: Option<f64>,
    /// Stiffness ratio beta = k2 / k1 of the secondary spring.
    #[arg(long)]
    pub beta: Option<f64>,
    /// Gap delta before the secondary spring.
    #[arg(long)]
    pub delta: Option<f64>,
    /// Damping ratio xi.
    #[arg(long)]
    pub xi: Option<f64>,
    /// Position feedback gain k_p (u = k_p |x2 - x1|).
    #[arg(long)]
    pub kp: Option<f64>,
    /// Viscous friction coefficient (viscous, seven-parameter).
    #[arg(long)]
    pub mu_v: Option<f64>,
    /// Stribeck velocity (stribeck, seven-parameter).
    #[arg(long)]
    pub v_s: Option<f64>,
    /// Frictional-memory delay (seven-parameter).
    #[arg(long)]
    pub tau_d: Option<f64>,
    /// Pre-sliding stiffness (seven-parameter).
    #[arg(long)]
    pub k_s: Option<f64>,
    /// Initial state x1,y1,x2,y2.
    #[arg(long, value_name = "X1,Y1,X2,Y2", allow_hyphen_values = true)]
    pub x0: Option<String>,
    /// Drive periods simulated in all.
    #[arg(long)]
    pub periods: Option<u32>,
    /// Leading periods not measured.
    #[arg(long)]
    pub transient: Option<u32>,
    /// Integration method [default: exact for coulomb/viscous, else adaptive].
    #[arg(long, value_enum)]
    pub method: Option<MethodArg>,
    /// Tolerance of the adaptive method [default: 1e-10].
    #[arg(long)]
    pub tol: Option<f64>,
    /// Step of the fixed method [default: 1e-3].
    #[arg(long)]
    pub step: Option<f64>,
}

impl SceneArgs {
    /// The scene: file (or defaults) with the flags applied, validated.
    pub fn scene(&self) -> Result<Scene> {
        let (mut scene, source) = match &self.scene {
            Some(path) => {
                let text = std::fs::read_to_string(path)
                    .with_context(|| format!("cannot read scene file {}", path.display()))?;
                let name = path.display().to_string();
                (Scene::from_toml_str(&text, &name)?, name)
            }
            None => {
                let mut s = Scene::default();
                s.drive.alpha = 0.8;
                (s, "defaults".to_string())
            }
        };
        if let Some(f) = self.friction {
            let (mu_v, v_s, tau_d, k_s) = (PAPER_MU_V, PAPER_V_S, PAPER_TAU_D, PAPER_K_S);
            scene.model.friction = match f {
                FrictionArg::Coulomb => Friction::Coulomb,
                FrictionArg::Viscous => Friction::Viscous { mu_v },
                FrictionArg::Stribeck => Friction::Stribeck { v_s },
                FrictionArg::SevenParameter => Friction::SevenParameter {
                    mu_v,
                    v_s,
                    tau_d,
                    k_s,
                },
            };
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
        set(&mut scene.horizon.periods, self.periods);
        set(&mut scene.horizon.transient, self.transient);
        if let Some(m) = self.method {
            scene.solver.method = match m {
                MethodArg::Exact => Method::Exact,
                MethodArg::Adaptive => Method::Adaptive,
                MethodArg::Fixed => Method::Fixed,
            };
        }
        set(&mut scene.solver.tol, self.tol);
        set(&mut scene.solver.step, self.step);
        if self.periods.is_some() && self.transient.is_none() && self.scene.is_none() {
            // keep the paper's 2:1 split of transient and measured periods
            scene.horizon.transient = scene.horizon.periods * 2 / 3;
        }
        scene.validate().map_err(|(key, reason)| {
            anyhow::anyhow!("{source} with command-line overrides: {key}: {reason}")
        })?;
        Ok(scene)
    }

    /// The scene as a TOML text to store with a recording: the file as read, followed by the
    /// command-line overrides as given (or only those, for the defaults).
    pub fn scene_text(&self) -> Result<String> {
        let mut text = match &self.scene {
            Some(path) => std::fs::read_to_string(path)
                .with_context(|| format!("cannot read scene file {}", path.display()))?,
            None => "# the paper's section-3 defaults of `capsule simulate`\n".to_string(),
        };
        let overrides: Vec<String> = std::env::args().skip(2).collect();
        text.push_str(&format!("\n# command line: {}\n", overrides.join(" ")));
        Ok(text)
    }

    fn apply_friction_constants(&self, f: &mut Friction) -> Result<()> {
        let name = f.name();
        let use_flag = |flag: &str, v: Option<f64>, slot: Option<&mut f64>| -> Result<()> {
            match (v, slot) {
                (Some(v), Some(s)) => {
                    *s = v;
                    Ok(())
                }
                (Some(_), None) => bail!("--{flag} does not apply to the {name} friction law"),
                (None, _) => Ok(()),
            }
        };
        match f {
            Friction::Coulomb => {
                use_flag("mu-v", self.mu_v, None)?;
                use_flag("v-s", self.v_s, None)?;
                use_flag("tau-d", self.tau_d, None)?;
                use_flag("k-s", self.k_s, None)?;
            }
            Friction::Viscous { mu_v } => {
                use_flag("mu-v", self.mu_v, Some(mu_v))?;
                use_flag("v-s", self.v_s, None)?;
                use_flag("tau-d", self.tau_d, None)?;
                use_flag("k-s", self.k_s, None)?;
            }
            Friction::Stribeck { v_s } => {
                use_flag("mu-v", self.mu_v, None)?;
                use_flag("v-s", self.v_s, Some(v_s))?;
                use_flag("tau-d", self.tau_d, None)?;
                use_flag("k-s", self.k_s, None)?;
            }
            Friction::SevenParameter {
                mu_v,
                v_s,
                tau_d,
                k_s,
            } => {
                use_flag("mu-v", self.mu_v, Some(mu_v))?;
                use_flag("v-s", self.v_s, Some(v_s))?;
                use_flag("tau-d", self.tau_d, Some(tau_d))?;
                use_flag("k-s", self.k_s, Some(k_s))?;
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
        bail!("--x0 `{text}`: expected four comma-separated numbers x1,y1,x2,y2");
    }
    let mut a = [0.0; 4];
    for (slot, p) in a.iter_mut().zip(&parts) {
        *slot = p
            .parse()
            .with_context(|| format!("--x0 `{text}`: `{p}` is not a number"))?;
    }
    Ok(State::from_array(a))
}
