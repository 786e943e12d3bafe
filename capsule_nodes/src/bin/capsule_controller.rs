//! `capsule_controller`: the ROS 2 controller node of the vibro-impact capsule.

#[path = "cli/controller.rs"]
mod controller_cli;

use capsule_controller_node::controller::{self, ControllerOptions};
use capsule_msgs::names::nodes;
use capsule_ros_base::{node_main, ros_args};
use controller_cli::{build, Cli};

fn main() -> std::process::ExitCode {
    node_main::init_logging();
    let (cli, overrides) = match ros_args::parse_node_cli::<Cli>(nodes::CONTROLLER, |c| &mut c.ros)
    {
        Ok(parsed) => parsed,
        Err(e) => return node_main::exit_code("capsule_controller", Err(e)),
    };
    let would =
        |opts: &ControllerOptions| format!(", {} k_p = {}", opts.core.mode(), opts.core.law().kp);
    node_main::async_node_main(
        "capsule_controller",
        cli.check(),
        build(&cli, &overrides),
        would,
        controller::run,
    )
}
