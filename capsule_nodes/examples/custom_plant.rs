//! A custom plant source behind the plant node: the node (topics, command gate, watchdog,
//! real-time and lock-step pacing, parameters, lifecycle, diagnostics, summary) runs any capsule
//! that implements `capsule_hardware::CapsuleHardware`, in SI. Here a toy capsule of a
//! few lines stands in for the exact simulator or a serial device: the inner mass on its spring
//! and damper inside the shell, and a shell that sticks until the force on it passes a static
//! friction threshold, then slides at a speed proportional to the excess.
//!
//!   cargo build -p capsule_nodes --bins --examples
//!   target/debug/capsule_controller --scene scenes/control_point.toml --mode forward \
//!       --discovery-range localhost &
//!   target/debug/examples/custom_plant --scene scenes/control_point.toml --pacing lockstep \
//!       --until-s 2 --wait-subscribers 1 --discovery-range localhost
//!
//! It prints the plant's one-line JSON summary and how often the node read and wrote the toy.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::Result;
use capsule_args::plant_settings::{
    COMMAND_TIMEOUT_S, LOCKSTEP_GIVE_UP_S, PACING, RATE_HZ, SCENE, UNTIL_S, USE_SIM_TIME,
    WAIT_SUBSCRIBERS,
};
use capsule_args::{scale_settings, scene_file::SceneFile, settings::Setting};
use capsule_hardware::{CapsuleHardware, HardwareError, Reading, Sample};
use capsule_plant::scene::PhysicalScale;
use capsule_plant_node::node_settings::{SettingFlags, SettingsTable};
use capsule_plant_node::plant::{self, Pacing, PlantCore, PlantOptions};
use capsule_plant_node::plant_params;
use capsule_ros_base::{
    node_main,
    ros_options::{RosArgs, RosEnv, RosOptions},
};
use clap::Parser;

/// The toy capsule: state in SI, integrated in small steps over each sample period.
struct ToyCapsule {
    m1: f64,
    k1: f64,
    /// Damping of the mass on its spring [N s/m].
    c1: f64,
    /// Force the shell resists before it slides [N].
    static_friction: f64,
    /// Sliding: the shell's speed per newton above the threshold [m/(N s)].
    mobility: f64,
    dt: f64,
    /// x1, y1, x2, y2: mass and shell positions [m] and velocities [m/s].
    x: [f64; 4],
    force: f64,
    active: bool,
    configured: bool,
    first: bool,
    /// Reads and writes the node made, shared with `main` for the report.
    counts: Arc<[AtomicU64; 2]>,
}

impl ToyCapsule {
    /// The force the spring and damper put on the shell [N].
    fn on_shell(&self) -> f64 {
        let [x1, y1, x2, y2] = self.x;
        self.k1 * (x1 - x2) + self.c1 * (y1 - y2)
    }

    /// One small step of semi-implicit Euler.
    fn step(&mut self, h: f64) {
        let f = self.on_shell();
        let excess = f.abs() - self.static_friction;
        let y2 = if excess > 0.0 {
            f.signum() * excess * self.mobility
        } else {
            0.0
        };
        let y1 = self.x[1] + h * (self.force - f) / self.m1;
        self.x = [self.x[0] + h * y1, y1, self.x[2] + h * y2, y2];
    }

    fn sample(&self) -> Sample {
        let f = self.on_shell();
        Sample {
            mass_position: self.x[0],
            mass_velocity: self.x[1],
            capsule_position: self.x[2],
            capsule_velocity: self.x[3],
            in_contact: false,
            stuck: self.x[3] == 0.0,
            friction_force: if self.x[3] == 0.0 {
                f
            } else {
                f.signum() * self.static_friction
            },
            contact_force: 0.0,
            actuator_force: self.force,
        }
    }
}

impl CapsuleHardware for ToyCapsule {
    fn label(&self) -> String {
        "toy capsule (examples/custom_plant.rs)".into()
    }
    fn configure(&mut self) -> Result<(), HardwareError> {
        (self.x, self.force, self.configured, self.first) = ([0.0; 4], 0.0, true, true);
        Ok(())
    }
    fn activate(&mut self) -> Result<(), HardwareError> {
        self.active = true;
        Ok(())
    }
    fn deactivate(&mut self) -> Result<(), HardwareError> {
        (self.active, self.force) = (false, 0.0);
        Ok(())
    }
    fn cleanup(&mut self) -> Result<(), HardwareError> {
        self.configured = false;
        Ok(())
    }
    /// Paced by the node: each read integrates one sample period with the force held.
    fn read(&mut self, _deadline: Instant) -> Result<Reading, HardwareError> {
        if !self.configured {
            return Err(HardwareError::State("read before configure".into()));
        }
        self.counts[0].fetch_add(1, Ordering::Relaxed);
        if !std::mem::take(&mut self.first) {
            let n = 20;
            for _ in 0..n {
                self.step(self.dt / f64::from(n));
            }
        }
        Ok(Reading::Sample(self.sample()))
    }
    fn write(&mut self, force_n: f64) -> Result<(), HardwareError> {
        self.counts[1].fetch_add(1, Ordering::Relaxed);
        self.force = if self.active { force_n } else { 0.0 };
        Ok(())
    }
}

/// The plant's settings this node takes (rows of the plant's own table, so the flags, their
/// ranges and the parameters are the plant node's): no source, recording or views here.
const TOY: [Setting; 11] = [
    SCENE,
    PACING,
    UNTIL_S,
    WAIT_SUBSCRIBERS,
    RATE_HZ,
    COMMAND_TIMEOUT_S,
    LOCKSTEP_GIVE_UP_S,
    USE_SIM_TIME,
    scale_settings::M1_KG,
    scale_settings::K1_N_PER_M,
    scale_settings::PF_N,
];

/// The toy plant's table.
#[derive(Debug, Clone)]
struct Toy;
impl SettingsTable for Toy {
    const SETTINGS: &'static [Setting] = &TOY;
}

/// The plant node with a toy capsule inside.
#[derive(Debug, Parser)]
struct Cli {
    /// The plant's settings this toy takes (--scene, --pacing, --until-s [2 s unless given],
    /// --wait-subscribers, --rate-hz, ...), as the plant node's
    #[command(flatten)]
    settings: SettingFlags<Toy>,
    #[command(flatten)]
    ros: RosArgs,
}

fn toy(scale: &PhysicalScale, rate_hz: f64, counts: Arc<[AtomicU64; 2]>) -> ToyCapsule {
    let (m1, k1) = (scale.m1_kg, scale.k1_n_per_m);
    ToyCapsule {
        m1,
        k1,
        c1: 0.1 * (k1 * m1).sqrt(),
        static_friction: 0.5 * scale.pf_n,
        mobility: 0.05,
        dt: 1.0 / rate_hz,
        x: [0.0; 4],
        force: 0.0,
        active: false,
        configured: false,
        first: true,
        counts,
    }
}

fn main() -> std::process::ExitCode {
    node_main::init_logging();
    let cli = Cli::parse();
    let result = (|| -> Result<()> {
        let flags = &cli.settings;
        let file = SceneFile::read(std::path::Path::new(
            &flags.text(&SCENE).unwrap_or_default(),
        ))?;
        let scale = file.scene.physical;
        // the ROS parameters the node serves (read-only here), by the plant's own precedence
        let fixed = plant_params::Fixed::of(flags, &file);
        let params = plant_params::start_table(flags, &file).map_err(anyhow::Error::msg)?;
        let run = plant_params::overridable(&params, &fixed).map_err(anyhow::Error::msg)?;
        let (rate, timeout) = (run.rate_hz, run.command_timeout_s);
        let settings = RosOptions::resolve(&cli.ros, &RosEnv::from_process(), "capsule_plant")?;
        let counts: Arc<[AtomicU64; 2]> = Arc::default();
        let core = PlantCore::new(toy(&scale, rate, counts.clone()), scale, rate, timeout);
        let opts = PlantOptions {
            pacing: flags
                .choice::<Pacing>(&PACING)
                .map_err(anyhow::Error::msg)?,
            until_s: Some(flags.number(&UNTIL_S).unwrap_or(2.0)),
            retransmit: Duration::from_millis(20),
            startup_timeout: Duration::from_secs(30),
            on_silence: plant::OnSilence::Wait,
            lockstep_give_up_s: run.lockstep_give_up_s,
            wait_subscribers: usize::try_from(flags.count(&WAIT_SUBSCRIBERS)).unwrap_or(usize::MAX),
            clock_every: 1,
            record: None,
            params,
            joint_commands: false,
            autostart: true,
            start_paused: false,
        };
        let started = Instant::now();
        let (stats, last) = node_main::block_on(None, plant::run(settings, core, opts))?;
        println!(
            "{}",
            plant::summary_json(&stats, &last, started.elapsed().as_secs_f64())
        );
        println!(
            "toy capsule: {} reads, {} writes",
            counts[0].load(Ordering::Relaxed),
            counts[1].load(Ordering::Relaxed)
        );
        Ok(())
    })();
    node_main::exit_code("custom_plant", result)
}
