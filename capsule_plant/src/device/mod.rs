//! A prototype's sensor and actuator as models (the scene's `[device]` table): what the device
//! emulator puts between the simulated capsule and the serial line, and what an offline closed
//! loop puts between the simulator and the control law. SI units throughout, as on the wire.
//!
//! - [`sensor`]: which quantities are measured, noise, quantisation, sample jitter, latency;
//! - [`actuator`]: dead band, saturation and the first-order lag of the coil current;
//! - [`prototype`]: the exact simulator behind both, stepped at the device's sample rate.

pub mod actuator;
pub mod prototype;
pub mod sensor;

use serde::Serialize;

use crate::physical::PhysicalScale;

/// Which quantities a device measures (the hello frame's `measured` bits).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Measured {
    /// The displacement of the mass in the shell, `x1 - x2` (a displacement sensor).
    pub displacement: bool,
    /// The shell's position `x2` (an encoder or a camera).
    pub capsule_position: bool,
    /// The mass's velocity.
    pub mass_velocity: bool,
    /// The shell's velocity.
    pub capsule_velocity: bool,
    /// Whether the mass touches the stop (a contact switch).
    pub contact: bool,
}

impl Measured {
    /// The scene-file names of the quantities, in bit order.
    pub const NAMES: [&'static str; 5] = [
        "displacement",
        "capsule_position",
        "mass_velocity",
        "capsule_velocity",
        "contact",
    ];

    /// Positions only: a displacement sensor and an encoder, the default.
    pub const POSITIONS: Measured = Measured {
        displacement: true,
        capsule_position: true,
        mass_velocity: false,
        capsule_velocity: false,
        contact: false,
    };

    /// Everything, as the simulator knows it.
    pub const ALL: Measured = Measured {
        displacement: true,
        capsule_position: true,
        mass_velocity: true,
        capsule_velocity: true,
        contact: true,
    };

    /// The quantities as bits (bit `i` is [`Measured::NAMES`]`[i]`).
    pub fn bits(self) -> u8 {
        [
            self.displacement,
            self.capsule_position,
            self.mass_velocity,
            self.capsule_velocity,
            self.contact,
        ]
        .iter()
        .enumerate()
        .fold(0, |b, (i, on)| b | (u8::from(*on) << i))
    }

    /// The quantities of `bits` (higher bits ignored).
    pub fn from_bits(bits: u8) -> Measured {
        let on = |i: u8| bits & (1 << i) != 0;
        Measured {
            displacement: on(0),
            capsule_position: on(1),
            mass_velocity: on(2),
            capsule_velocity: on(3),
            contact: on(4),
        }
    }

    /// The quantities named in `names` (each one of [`Measured::NAMES`]); the first unknown
    /// name is returned as the error.
    pub fn from_names<S: AsRef<str>>(names: &[S]) -> Result<Measured, String> {
        let mut bits = 0u8;
        for n in names {
            let i = Measured::NAMES
                .iter()
                .position(|k| *k == n.as_ref())
                .ok_or_else(|| n.as_ref().to_string())?;
            bits |= 1 << i;
        }
        Ok(Measured::from_bits(bits))
    }

    /// The names of the quantities measured.
    pub fn names(self) -> Vec<&'static str> {
        let bits = self.bits();
        Measured::NAMES
            .iter()
            .enumerate()
            .filter(|(i, _)| bits & (1 << i) != 0)
            .map(|(_, n)| *n)
            .collect()
    }
}

/// A prototype's sensor, actuator and limits (the scene's `[device]` table), SI.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DeviceModel {
    /// What is measured.
    pub measured: Measured,
    /// Standard deviation of the Gaussian noise on each measured position \[m\].
    pub noise_m: f64,
    /// Standard deviation of the Gaussian noise on each measured velocity \[m/s\].
    pub noise_m_per_s: f64,
    /// Resolution of the position sensors \[m\] (0: exact).
    pub quantum_m: f64,
    /// Age of a measurement when it leaves the device \[s\].
    pub latency_s: f64,
    /// Standard deviation of the instant a sample is taken around its nominal time \[s\].
    pub jitter_s: f64,
    /// Seed of the noise (a run is reproducible for a seed).
    pub seed: u32,
    /// The actuator's force limit \[N\] (announced in the hello frame and enforced).
    pub max_force_n: f64,
    /// Commands smaller than this in magnitude give no force \[N\].
    pub dead_band_n: f64,
    /// Time constant of the coil current: the force follows the command as a first-order lag
    /// \[s\] (0: at once).
    pub lag_s: f64,
    /// The mechanical travel of the mass in the shell, `|x1 - x2|` \[m\] (announced; the plant
    /// node zeroes the force beyond it).
    pub max_travel_m: f64,
    /// The device zeroes its force after this long without a force frame \[s\].
    pub command_timeout_s: f64,
}

impl DeviceModel {
    /// A plausible prototype at `scale`: positions only, noise 1 % of the length unit
    /// `P_f / k1`, a 1 um resolution, 2 ms latency, 0.1 ms jitter, a coil lag of 0.5 ms, force
    /// limited to 10 `P_f`, travel 20 length units, a 0.1 s command timeout. These are the
    /// emulator's defaults when a scene has no `[device]` table.
    pub fn typical(scale: &PhysicalScale) -> DeviceModel {
        DeviceModel {
            measured: Measured::POSITIONS,
            noise_m: 0.01 * scale.length_m(),
            noise_m_per_s: 0.01 * scale.velocity_m_per_s(),
            quantum_m: 1e-6,
            latency_s: 2e-3,
            jitter_s: 1e-4,
            seed: 1,
            max_force_n: 10.0 * scale.force_n(),
            dead_band_n: 0.0,
            lag_s: 5e-4,
            max_travel_m: 20.0 * scale.length_m(),
            command_timeout_s: 0.1,
        }
    }

    /// An ideal device at `scale`: every quantity, exact, at once; the typical limits.
    pub fn ideal(scale: &PhysicalScale) -> DeviceModel {
        DeviceModel {
            measured: Measured::ALL,
            noise_m: 0.0,
            noise_m_per_s: 0.0,
            quantum_m: 0.0,
            latency_s: 0.0,
            jitter_s: 0.0,
            dead_band_n: 0.0,
            lag_s: 0.0,
            ..DeviceModel::typical(scale)
        }
    }

    /// The numeric keys with their values and whether they must be > 0 (else >= 0), for
    /// validation and the scene file.
    pub fn numbers(&self) -> [(&'static str, f64, bool); 10] {
        [
            ("noise_m", self.noise_m, false),
            ("noise_m_per_s", self.noise_m_per_s, false),
            ("quantum_m", self.quantum_m, false),
            ("latency_s", self.latency_s, false),
            ("jitter_s", self.jitter_s, false),
            ("max_force_n", self.max_force_n, true),
            ("dead_band_n", self.dead_band_n, false),
            ("lag_s", self.lag_s, false),
            ("max_travel_m", self.max_travel_m, true),
            ("command_timeout_s", self.command_timeout_s, true),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn measured_bits_and_names_round_trip() {
        for bits in 0..32u8 {
            let m = Measured::from_bits(bits);
            assert_eq!(m.bits(), bits);
            assert_eq!(Measured::from_names(&m.names()), Ok(m));
        }
        assert_eq!(Measured::POSITIONS.bits(), 0b11);
        assert_eq!(
            Measured::from_names(&["displacement", "speed"]),
            Err("speed".to_string())
        );
    }
}
