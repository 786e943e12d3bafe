#!/usr/bin/env bash
# What the ROS 2 tests use besides Rust, installed where missing (idempotent, quiet when present):
#   - ip (iproute2): every DDS test runs in its own loopback-only network namespace; pgrep (procps)
#   - tests/peers/rosidl_check.py (ROS 2's interface tools, Debian bookworm's rosidl 3.3.1): the
#     Python modules rosidl_adapter, rosidl_parser, rosidl_generator_c, rosidl_pycommon,
#     rosidl_typesupport_introspection_c, em, lark under /usr/bin/python3; the generators'
#     templates under /usr/share; the rosidl runtime, type-support and rcutils headers and
#     libraries; cc
#   - tests/peers/fastdds/ (eProsima Fast DDS 2.9, as an rclcpp node on rmw_fastrtps_cpp, the ROS 2
#     default): c++, the Fast DDS and Fast CDR headers and libraries
#   - tests/peers/cyclone_peer.py: PyPI `cyclonedds` (ships its C library)
#   - tests/peers/foxglove_ws_client.py: PyPI `websockets`, a WebSocket client that is not ours
#   - tests/peers/zenoh_peer.py: PyPI `eclipse-zenoh` (an rmw_zenoh speaker; the version of the
#     zenoh crate the nodes use on Zenoh)
#   - tests/integration/ros/faults.rs: iptables (loss, duplicates, delay through NFQUEUE to
#     tests/peers/nfqueue_delay.py, partitions: inside each test's own namespace)
#   - tests/integration/ros/security.rs: tcpdump (captures the namespace's loopback, searched for
#     plaintext); the keystore's openssl command comes with .ci/build-setup.sh;
#     tests/peers/sros2_keystore.py (a keystore by sros2's method): PyPI `cryptography`
#   - tests/integration/ros/colcon.rs: colcon with colcon-cargo, colcon-ros-cargo and the crawl and
#     selection extensions, and cargo-ament-build (PyPI ships the Rust tool as a wheel)
# Needs root (network namespaces). Run before `cargo test --workspace`, after
# `cargo build --workspace` (the tests start the node binaries from target/debug).
set -euo pipefail
export PIP_ROOT_USER_ACTION=ignore

# Each check looks for the thing a test uses (a binary, a header, a library the linker finds, a
# generator template, a Python module), never for a package that usually brings it: a machine
# with Debian's python3-rosidl but not rosidl-core has the generators' Python code but not their
# templates (`Could not find template: idl.h.em`). Missing things are printed with the package
# that ships them, installed, and checked again: what is still missing fails the set-up here.
missing=()    # "what|package|kind" (kind: apt or pip)
have_cmd() { command -v "$1" >/dev/null 2>&1; }
have_file() { [ -e "$1" ]; }
# a library the C toolchain links against (`cc -print-file-name` echoes the bare name if not found)
have_lib() { have_cmd cc && [ "$(cc -print-file-name="$1")" != "$1" ]; }
have_py() { "$1" -c "import $2" >/dev/null 2>&1; }

check_all() {
  missing=()
  # network namespaces (every DDS test), pgrep (the launcher test)
  have_cmd ip || missing+=("command ip|iproute2|apt")
  have_cmd pgrep || missing+=("command pgrep|procps|apt")
  have_cmd python3 || missing+=("command python3|python3|apt")
  python3 -m pip --version >/dev/null 2>&1 || missing+=("python3 -m pip|python3-pip|apt")
  # tests/peers/rosidl_check.py, run by Debian's /usr/bin/python3 (where python3-rosidl lives)
  local py=/usr/bin/python3
  have_cmd "$py" || missing+=("command $py|python3|apt")
  for m in rosidl_adapter rosidl_parser rosidl_generator_c rosidl_pycommon rosidl_typesupport_introspection_c; do
    have_py "$py" "$m" || missing+=("module $m (/usr/bin/python3)|python3-rosidl|apt")
  done
  have_py "$py" em || missing+=("module em, the template engine (/usr/bin/python3)|python3-empy|apt")
  have_py "$py" lark || missing+=("module lark (/usr/bin/python3)|python3-lark|apt")
  have_file /usr/share/rosidl_generator_c/resource/idl.h.em \
    || missing+=("template /usr/share/rosidl_generator_c/resource/idl.h.em|rosidl-generator-c-cpp|apt")
  have_file /usr/share/rosidl_typesupport_introspection_c/resource/idl__type_support.c.em \
    || missing+=("template /usr/share/rosidl_typesupport_introspection_c/resource/idl__type_support.c.em|librosidl-typesupport-introspection-c-cpp-dev|apt")
  have_file /usr/include/rosidl_runtime_c/rosidl_runtime_c/message_initialization.h \
    || missing+=("header rosidl_runtime_c/message_initialization.h|librosidl-runtime-c-cpp-dev|apt")
  have_file /usr/include/rosidl_typesupport_interface/rosidl_typesupport_interface/macros.h \
    || missing+=("header rosidl_typesupport_interface/macros.h|librosidl-typesupport-interface-dev|apt")
  have_file /usr/include/rosidl_typesupport_introspection_c/rosidl_typesupport_introspection_c/message_introspection.h \
    || missing+=("header rosidl_typesupport_introspection_c/message_introspection.h|librosidl-typesupport-introspection-c-cpp-dev|apt")
  have_file /usr/include/rcutils/rcutils/allocator.h \
    || missing+=("header rcutils/allocator.h|librcutils-dev|apt")
  have_cmd cc || missing+=("command cc|gcc libc6-dev|apt")
  have_lib librosidl_runtime_c.so || missing+=("library librosidl_runtime_c.so|librosidl-runtime-c-cpp-dev|apt")
  have_lib librosidl_typesupport_introspection_c.a \
    || missing+=("library librosidl_typesupport_introspection_c.a|librosidl-typesupport-introspection-c-cpp-dev|apt")
  have_lib librcutils.so || missing+=("library librcutils.so|librcutils-dev|apt")
  # the Fast DDS peer (tests/peers/fastdds/), compiled by the test with c++ -lfastrtps -lfastcdr
  have_cmd c++ || missing+=("command c++|g++|apt")
  have_file /usr/include/fastdds/dds/domain/DomainParticipant.hpp \
    || missing+=("header fastdds/dds/domain/DomainParticipant.hpp|libfastrtps-dev|apt")
  have_file /usr/include/fastcdr/Cdr.h || missing+=("header fastcdr/Cdr.h|libfastcdr-dev|apt")
  have_lib libfastrtps.so || missing+=("library libfastrtps.so|libfastrtps-dev|apt")
  have_lib libfastcdr.so || missing+=("library libfastcdr.so|libfastcdr-dev|apt")
  # the security test's capture of the loopback
  have_cmd tcpdump || missing+=("command tcpdump|tcpdump|apt")
  have_cmd iptables || missing+=("command iptables|iptables|apt")
  # Python peers, run by the python3 on PATH
  if have_cmd python3; then
    have_py python3 cyclonedds || missing+=("module cyclonedds|cyclonedds==11.0.1|pip")
    have_py python3 websockets || missing+=("module websockets|websockets==15.0.1|pip")
    have_py python3 zenoh || missing+=("module zenoh|eclipse-zenoh==1.10.2|pip")
    # the keystore made as `ros2 security` makes one (tests/peers/sros2_keystore.py)
    have_py python3 cryptography.hazmat.primitives.serialization.pkcs7 \
      || missing+=("module cryptography|cryptography==48.0.0|pip")
    # colcon and its cargo extensions (tests/integration/ros/colcon.rs)
    local colcon_pkgs="colcon-core==0.21.3 colcon-cargo==0.2.0 colcon-ros-cargo==0.2.0 colcon-package-information==0.4.1 colcon-package-selection==0.2.10 colcon-recursive-crawl==0.2.3"
    for m in colcon_core colcon_cargo colcon_ros_cargo colcon_package_information colcon_package_selection colcon_recursive_crawl; do
      have_py python3 "$m" || missing+=("module $m|$colcon_pkgs|pip")
    done
    have_cmd colcon || missing+=("command colcon|$colcon_pkgs|pip")
    have_cmd cargo-ament-build || missing+=("command cargo-ament-build|$colcon_pkgs|pip")
  fi
}

install_missing() {
  local apt=() pip=() line what pkg kind
  for line in "${missing[@]}"; do
    IFS='|' read -r what pkg kind <<<"$line"
    if [ "$kind" = apt ]; then echo "ros-setup: missing $what (apt: $pkg)"; else echo "ros-setup: missing $what (pip)"; fi
    # shellcheck disable=SC2206 # a package field may name several packages
    if [ "$kind" = apt ]; then apt+=($pkg); else pip+=($pkg); fi
  done
  if [ "${#apt[@]}" -gt 0 ]; then
    mapfile -t apt < <(printf '%s\n' "${apt[@]}" | sort -u)
    echo "ros-setup: apt-get install ${apt[*]}"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${apt[@]}" >/dev/null
    hash -r
  fi
  if [ "${#pip[@]}" -gt 0 ]; then
    mapfile -t pip < <(printf '%s\n' "${pip[@]}" | sort -u)
    echo "ros-setup: pip install ${pip[*]}"
    python3 -m pip install --quiet --disable-pip-version-check "${pip[@]}" \
      || python3 -m pip install --quiet --disable-pip-version-check --break-system-packages "${pip[@]}"
    hash -r
  fi
}

check_all
if [ "${#missing[@]}" -gt 0 ]; then
  install_missing
  check_all
  # pip needs python3 and pip from apt first: a second round for what only then could install
  if [ "${#missing[@]}" -gt 0 ]; then install_missing; check_all; fi
  if [ "${#missing[@]}" -gt 0 ]; then
    for line in "${missing[@]}"; do echo "ros-setup: still missing ${line%%|*} (${line#*|})" >&2; done
    exit 1
  fi
fi

# the namespace recipe must work here (root, kernel support); fail early with the reason
probe="capsule_probe_$$"
if ! ip netns add "$probe" 2>/dev/null; then
  echo "ros-setup: cannot create a network namespace (need root and netns support)" >&2
  exit 1
fi
ip netns delete "$probe"
echo "ros-setup: ok (iproute2, python3 $(python3 -c 'import cyclonedds, importlib.metadata as m; print("cyclonedds", m.version("cyclonedds"), "websockets", m.version("websockets"))'))"
