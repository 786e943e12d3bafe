#!/usr/bin/env bash
# What the ROS 2 tests need besides Rust, installed if missing (idempotent, quiet when present):
#   - iproute2 (ip netns: every DDS test runs in its own loopback-only network namespace)
#   - procps (pgrep, used by the launcher test)
#   - python3 + the Eclipse Cyclone DDS binding (PyPI `cyclonedds`, ships its C library): the
#     interop peer tests/peers/cyclone_peer.py
#   - ROS 2's interface tools (Debian: python3-rosidl, rosidl-core, librcutils-dev, the
#     rosidl runtime/introspection headers, a C compiler): tests/peers/rosidl_check.py
#   - eProsima Fast DDS 2.9 (Debian libfastrtps-dev) and a C++ compiler: the Fast DDS peer
#     tests/peers/fastdds/, as an rclcpp node on rmw_fastrtps_cpp (the ROS 2 default)
#   - tcpdump: the security test captures the namespace's loopback and searches it for plaintext
#   - PyPI `websockets`: a WebSocket client that is not ours, for the Foxglove live-view peer
#     tests/peers/foxglove_ws_client.py
#   - colcon (PyPI colcon-core, colcon-cargo, colcon-ros-cargo, colcon-package-information; the
#     last pulls in PyPI's cargo-ament-build, the crates.io tool as a prebuilt wheel): `colcon
#     build` of capsule_nodes, tests/integration/ros/colcon.rs
# Needs root (network namespaces). Run before `cargo test --workspace`, after
# `cargo build --workspace` (the tests start the node binaries from target/debug).
set -euo pipefail

need_apt=()
command -v ip >/dev/null 2>&1 || need_apt+=(iproute2)
command -v pgrep >/dev/null 2>&1 || need_apt+=(procps)
command -v python3 >/dev/null 2>&1 || need_apt+=(python3 python3-pip)
/usr/bin/python3 -c "import rosidl_adapter, rosidl_parser, rosidl_generator_c" >/dev/null 2>&1 \
  || need_apt+=(python3-rosidl rosidl-core)
[ -f /usr/include/rcutils/rcutils/allocator.h ] || need_apt+=(librcutils-dev)
[ -d /usr/include/rosidl_typesupport_introspection_c ] \
  || need_apt+=(librosidl-typesupport-introspection-c-cpp-dev)
command -v cc >/dev/null 2>&1 || need_apt+=(gcc libc6-dev)
[ -f /usr/include/fastdds/dds/domain/DomainParticipant.hpp ] || need_apt+=(libfastrtps-dev)
command -v c++ >/dev/null 2>&1 || need_apt+=(g++)
command -v tcpdump >/dev/null 2>&1 || need_apt+=(tcpdump)
if [ "${#need_apt[@]}" -gt 0 ]; then
  echo "ros-setup: apt-get install ${need_apt[*]}"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need_apt[@]}" >/dev/null
fi

if ! python3 -c "import cyclonedds" >/dev/null 2>&1; then
  echo "ros-setup: pip install cyclonedds"
  python3 -m pip install --quiet --disable-pip-version-check cyclonedds==11.0.1 \
    || python3 -m pip install --quiet --disable-pip-version-check --break-system-packages cyclonedds==11.0.1
fi

if ! python3 -c "import websockets" >/dev/null 2>&1; then
  echo "ros-setup: pip install websockets"
  python3 -m pip install --quiet --disable-pip-version-check websockets==15.0.1 \
    || python3 -m pip install --quiet --disable-pip-version-check --break-system-packages websockets==15.0.1
fi

if ! command -v colcon >/dev/null 2>&1 || ! python3 -c "import colcon_ros_cargo" >/dev/null 2>&1; then
  echo "ros-setup: pip install colcon-core colcon-cargo colcon-ros-cargo"
  pkgs=(colcon-core==0.21.3 colcon-cargo==0.2.0 colcon-ros-cargo==0.2.0 colcon-package-information==0.4.1 colcon-package-selection==0.2.10 colcon-recursive-crawl==0.2.3)
  python3 -m pip install --quiet --disable-pip-version-check "${pkgs[@]}" \
    || python3 -m pip install --quiet --disable-pip-version-check --break-system-packages "${pkgs[@]}"
  hash -r
fi

# the namespace recipe must work here (root, kernel support); fail early with the reason
probe="capsule_probe_$$"
if ! ip netns add "$probe" 2>/dev/null; then
  echo "ros-setup: cannot create a network namespace (need root and netns support)" >&2
  exit 1
fi
ip netns delete "$probe"
echo "ros-setup: ok (iproute2, python3 $(python3 -c 'import cyclonedds, importlib.metadata as m; print("cyclonedds", m.version("cyclonedds"), "websockets", m.version("websockets"))'))"
