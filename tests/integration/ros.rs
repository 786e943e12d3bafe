//! The ROS 2 layer end to end: the node binaries, the launcher and a Cyclone DDS Python peer.
//!
//! Every test that starts a DDS process runs it inside its own loopback-only network namespace
//! (`tests/peers/netns_run.sh`: bounded in time, namespace deleted and processes killed at the
//! end, also on failure), so nothing here can reach a real network. Needs root, iproute2, the
//! node binaries (`cargo build --workspace` first) and, for the Python peer, `cyclonedds`:
//! `.ci/ros-setup.sh` installs what is missing.

mod harness;

mod faults;
mod interop;
mod lockstep;

#[test]
fn controller_reads_the_same_default_scale_as_the_plant() {
    let plant = capsule_plant::scene::PhysicalScale::default();
    let ours = capsule_nodes::scale::Scale::SCENE_DEFAULT;
    assert_eq!(
        (ours.m1_kg, ours.k1_n_per_m, ours.pf_n),
        (plant.m1_kg, plant.k1_n_per_m, plant.pf_n)
    );
}
