//! The physical scale between the paper's non-dimensional units and SI, and the few scene
//! values the controller needs, read without the simulator.
//!
//! With `Omega0 = sqrt(k1/m1)` (paper section 2): `t = tau / Omega0`, `X = x P_f / k1`,
//! `V = y Omega0 P_f / k1`, `F = f P_f`.

use anyhow::{bail, Context as _, Result};

/// `m1`, `k1` and the friction threshold `P_f`, which fix every SI conversion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scale {
    /// Inner mass [kg].
    pub m1_kg: f64,
    /// Primary spring stiffness [N/m].
    pub k1_n_per_m: f64,
    /// Coulomb friction threshold [N].
    pub pf_n: f64,
}

impl Scale {
    /// The scale a scene without a `[physical]` table has (capsule_plant's default; a test in
    /// tests/integration/ros.rs keeps the two equal).
    pub const SCENE_DEFAULT: Scale = Scale {
        m1_kg: 0.05,
        k1_n_per_m: 200.0,
        pf_n: 0.1,
    };

    /// Checks that every value is finite and positive; the error names the value.
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [
            ("m1_kg", self.m1_kg),
            ("k1_n_per_m", self.k1_n_per_m),
            ("pf_n", self.pf_n),
        ] {
            if !(v.is_finite() && v > 0.0) {
                bail!("physical scale `{name}` = {v}: must be finite and > 0");
            }
        }
        Ok(())
    }
    /// `Omega0 = sqrt(k1/m1)` [rad/s].
    pub fn omega0(&self) -> f64 {
        (self.k1_n_per_m / self.m1_kg).sqrt()
    }
    /// Seconds per unit of non-dimensional time.
    pub fn time_s(&self) -> f64 {
        1.0 / self.omega0()
    }
    /// Metres per unit of non-dimensional length.
    pub fn length_m(&self) -> f64 {
        self.pf_n / self.k1_n_per_m
    }
    /// Metres per second per unit of non-dimensional velocity.
    pub fn velocity_m_per_s(&self) -> f64 {
        self.length_m() * self.omega0()
    }
    /// Newtons per unit of non-dimensional force.
    pub fn force_n(&self) -> f64 {
        self.pf_n
    }
}

/// What the controller takes from a scene: scale, drive, gain, and the plant's rate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlScene {
    /// The physical scale.
    pub scale: Scale,
    /// Drive amplitude alpha.
    pub alpha: f64,
    /// Drive frequency omega.
    pub omega: f64,
    /// Feedback gain k_p of the scene.
    pub kp: f64,
}

fn number(root: &toml::Value, file: &str, table: &str, key: &str) -> Result<Option<f64>> {
    let Some(t) = root.get(table) else {
        return Ok(None);
    };
    match t.get(key) {
        None => Ok(None),
        Some(toml::Value::Float(f)) => Ok(Some(*f)),
        Some(toml::Value::Integer(i)) => Ok(Some(*i as f64)),
        Some(other) => bail!("{file}: `{table}.{key}` = {other}: expected a number"),
    }
}

impl ControlScene {
    /// Reads `[physical] m1_kg k1_n_per_m pf_n` (all three, or the table left out for
    /// [`Scale::SCENE_DEFAULT`]), `[drive] alpha omega` and `[control] kp` (default 0) from a
    /// scene's TOML text (other keys are the simulator's business and are ignored here).
    pub fn from_toml_str(text: &str, file: &str) -> Result<ControlScene> {
        let root: toml::Value = text
            .parse()
            .with_context(|| format!("{file}: not valid TOML"))?;
        let need = |table: &str, key: &str| -> Result<f64> {
            number(&root, file, table, key)?
                .with_context(|| format!("{file}: missing `{table}.{key}`"))
        };
        let scale = if root.get("physical").is_some() {
            Scale {
                m1_kg: need("physical", "m1_kg")?,
                k1_n_per_m: need("physical", "k1_n_per_m")?,
                pf_n: need("physical", "pf_n")?,
            }
        } else {
            Scale::SCENE_DEFAULT
        };
        let scene = ControlScene {
            scale,
            alpha: need("drive", "alpha")?,
            omega: need("drive", "omega")?,
            kp: number(&root, file, "control", "kp")?.unwrap_or(0.0),
        };
        scene.scale.validate().with_context(|| file.to_string())?;
        for (k, v) in [
            ("drive.alpha", scene.alpha),
            ("drive.omega", scene.omega),
            ("control.kp", scene.kp),
        ] {
            if !v.is_finite() {
                bail!("{file}: `{k}` = {v}: not finite");
            }
        }
        if scene.omega <= 0.0 {
            bail!("{file}: `drive.omega` = {}: must be > 0", scene.omega);
        }
        Ok(scene)
    }

    /// Reads a scene file.
    pub fn from_file(path: &str) -> Result<ControlScene> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("cannot read scene {path}"))?;
        ControlScene::from_toml_str(&text, path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversions_follow_the_papers_nondimensionalisation() {
        let s = Scale {
            m1_kg: 0.04,
            k1_n_per_m: 100.0,
            pf_n: 2.0,
        };
        assert!((s.omega0() - 50.0).abs() < 1e-12);
        assert!((s.length_m() - 0.02).abs() < 1e-15);
        assert!((s.velocity_m_per_s() - 1.0).abs() < 1e-12);
        assert!((s.time_s() - 0.02).abs() < 1e-15);
        assert!(Scale { m1_kg: -1.0, ..s }.validate().is_err());
        assert!(Scale {
            pf_n: f64::NAN,
            ..s
        }
        .validate()
        .is_err());
    }

    #[test]
    fn scene_values_are_read_and_bad_ones_named() -> Result<()> {
        let ok = "[physical]\nm1_kg = 0.04\nk1_n_per_m = 100\npf_n = 2.0\n[drive]\nalpha = 1.6\nomega = 1.1\n[control]\nkp = 0.1\n[friction]\nmodel = \"coulomb\"\n";
        let s = ControlScene::from_toml_str(ok, "x.toml")?;
        assert_eq!(
            (s.alpha, s.omega, s.kp, s.scale.k1_n_per_m),
            (1.6, 1.1, 0.1, 100.0)
        );
        let e =
            ControlScene::from_toml_str(&ok.replace("alpha = 1.6\n", ""), "x.toml").unwrap_err();
        assert!(format!("{e:#}").contains("drive.alpha"), "{e:#}");
        let e = ControlScene::from_toml_str(&ok.replace("pf_n = 2.0", "pf_n = -2.0"), "x.toml")
            .unwrap_err();
        assert!(format!("{e:#}").contains("pf_n"), "{e:#}");
        let e =
            ControlScene::from_toml_str(&ok.replace("omega = 1.1", "omega = \"fast\""), "x.toml")
                .unwrap_err();
        assert!(format!("{e:#}").contains("drive.omega"), "{e:#}");
        Ok(())
    }
}
