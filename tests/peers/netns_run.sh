#!/usr/bin/env bash
# Run a command inside a fresh loopback-only network namespace, bounded in time, and always
# clean up: the namespace is deleted and every process in it killed, also on failure or signal.
#
#   tests/peers/netns_run.sh TIMEOUT_S COMMAND [ARGS...]
#
# Inside, lo is up with multicast on and 224.0.0.0/4 routed to it, so RustDDS and Cyclone DDS
# discover each other; nothing can reach any other interface. Needs root and iproute2.
set -u
[ $# -ge 2 ] || { echo "usage: $0 TIMEOUT_S COMMAND [ARGS...]" >&2; exit 2; }
timeout_s="$1"; shift
ns="capsule_$$_$RANDOM"
cleanup() {
  local pids
  pids=$(ip netns pids "$ns" 2>/dev/null || true)
  [ -n "$pids" ] && kill -TERM $pids 2>/dev/null && sleep 0.5
  pids=$(ip netns pids "$ns" 2>/dev/null || true)
  [ -n "$pids" ] && kill -KILL $pids 2>/dev/null
  ip netns delete "$ns" 2>/dev/null || true
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
ip netns add "$ns" || { echo "netns_run: cannot create network namespace (root? iproute2?)" >&2; exit 2; }
ip netns exec "$ns" ip link set lo up
ip netns exec "$ns" ip link set lo multicast on
ip netns exec "$ns" ip route add 224.0.0.0/4 dev lo
# ROS conventions on top of the namespace: loopback discovery, an isolated domain
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
timeout --signal=TERM --kill-after=5 "$timeout_s" ip netns exec "$ns" "$@"
