"""The capsule graph for a scene, for `ros2 launch` users: the ROS 2 twin of
launch_scripts/capsule_launch.sh (same nodes, same parameters, same discovery default).

    colcon build && . install/setup.sh
    ros2 launch capsule_nodes capsule.launch.py scene:=$PWD/scenes/control_point.toml \
        pacing:=lockstep until_s:=30 mode:=forward [record:=false] [record_dir:=./runs]

Starts capsule_controller, capsule_recorder (unless record:=false) and capsule_plant; the plant
waits for its subscribers, so the recording holds sample 0. When the plant ends (until_s) the
launch shuts the graph down. DDS stays on loopback unless ROS_AUTOMATIC_DISCOVERY_RANGE is set.

The graph itself is computed by `node_commands`, which needs no ROS installation (the test suite
runs every command it returns with --check against the built nodes).
"""

# the arguments a user can set, with their defaults (as capsule_launch.sh has them)
ARGUMENTS = {
    "scene": ("", "scene TOML file (required)"),
    "pacing": ("realtime", "realtime or lockstep"),
    "until_s": ("", "simulated seconds to run; empty runs until stopped"),
    "mode": ("", "controller mode at start: off, forward, backward, chaos_control; empty keeps the scene's"),
    "record": ("true", "record the run to MCAP with capsule_recorder"),
    "record_dir": ("./runs", "directory of the recording"),
}

PACINGS = ("realtime", "lockstep")


def node_commands(scene, pacing="realtime", until_s="", mode="", record="true", record_dir="./runs"):
    """The graph as (executable, arguments) pairs of package capsule_nodes, in start order.

    Raises ValueError naming the argument when a value is not one the launcher accepts."""
    if not scene:
        raise ValueError("scene:=FILE is required")
    if pacing not in PACINGS:
        raise ValueError(f"pacing:={pacing!r}: realtime or lockstep")
    if record not in ("true", "false"):
        raise ValueError(f"record:={record!r}: true or false")
    if until_s:
        try:
            if not float(until_s) > 0:
                raise ValueError
        except ValueError:
            raise ValueError(f"until_s:={until_s!r}: a positive number of seconds") from None
    controller = ["--scene", scene] + (["--mode", mode] if mode else [])
    plant = ["--scene", scene, "--pacing", pacing] + (["--until-s", until_s] if until_s else [])
    commands = [("capsule_controller", controller)]
    if record == "true":
        commands.append(("capsule_recorder", ["--scene", scene, "--record-dir", record_dir]))
        plant += ["--wait-subscribers", "2"]
    elif pacing == "lockstep":
        plant += ["--wait-subscribers", "1"]
    commands.append(("capsule_plant", plant))
    return commands


def _launch_setup(context):
    from launch.actions import EmitEvent, RegisterEventHandler
    from launch.event_handlers import OnProcessExit
    from launch.events import Shutdown
    from launch_ros.actions import Node

    values = {name: context.perform_substitution(_config(name)) for name in ARGUMENTS}
    actions = []
    for executable, arguments in node_commands(**values):
        node = Node(package="capsule_nodes", executable=executable, arguments=arguments, output="screen")
        actions.append(node)
        if executable == "capsule_plant":
            # the plant ending (until_s) ends the run, as in capsule_launch.sh
            actions.append(
                RegisterEventHandler(OnProcessExit(target_action=node, on_exit=[EmitEvent(event=Shutdown())]))
            )
    return actions


def _config(name):
    from launch.substitutions import LaunchConfiguration

    return LaunchConfiguration(name)


def generate_launch_description():
    """The launch description `ros2 launch` reads."""
    from launch import LaunchDescription
    from launch.actions import DeclareLaunchArgument, OpaqueFunction, SetEnvironmentVariable
    from launch.substitutions import EnvironmentVariable

    declared = [
        DeclareLaunchArgument(name, default_value=default, description=text)
        for name, (default, text) in ARGUMENTS.items()
    ]
    loopback = SetEnvironmentVariable(
        "ROS_AUTOMATIC_DISCOVERY_RANGE",
        EnvironmentVariable("ROS_AUTOMATIC_DISCOVERY_RANGE", default_value="LOCALHOST"),
    )
    return LaunchDescription(declared + [loopback, OpaqueFunction(function=_launch_setup)])
