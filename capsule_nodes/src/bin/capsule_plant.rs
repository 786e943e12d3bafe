//! `capsule_plant`: the ROS 2 plant node, a simulated vibro-impact capsule or a real one on a
//! serial line.

#[path = "cli/plant.rs"]
mod plant_cli;

use anyhow::Context as _;
use capsule_msgs::names::nodes;
use capsule_plant_node::plant::{self, PlantOptions};
use capsule_ros_base::{node_main, ros_args};
use plant_cli::{build, Cli, Plant};

fn main() -> std::process::ExitCode {
    node_main::init_logging();
    let (cli, overrides) = match ros_args::parse_node_cli::<Cli>(nodes::PLANT, |c| &mut c.ros) {
        Ok(parsed) => parsed,
        Err(e) => return node_main::exit_code("capsule_plant", Err(e)),
    };
    let built = build(&cli, &overrides).map(|(settings, core, opts)| (settings, (core, opts)));
    let would = |(core, opts): &(Plant, PlantOptions)| {
        format!(
            ", {}, {:?}, force limit {} N{}",
            cli.source_label(),
            opts.pacing,
            core.max_force_n(),
            opts.record
                .as_ref()
                .map(|r| format!(", would record to {}", r.output.display()))
                .unwrap_or_default()
        )
    };
    node_main::node_main(
        "capsule_plant",
        cli.check(),
        built,
        would,
        |settings, (core, opts)| {
            let started = std::time::Instant::now();
            let (stats, last) = node_main::block_on_with(
                settings.cpu_affinity.clone().as_ref(),
                &settings.middleware.clone(),
                plant::run(settings, core, opts),
            )?;
            if let Some(path) = &cli.summary_json() {
                let json = plant::summary_json(&stats, &last, started.elapsed().as_secs_f64());
                std::fs::write(path, json + "\n")
                    .with_context(|| format!("cannot write {path}"))?;
            }
            Ok(())
        },
    )
}
