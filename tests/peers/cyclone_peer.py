#!/usr/bin/env python3
"""Eclipse Cyclone DDS (Python binding) peer of the capsule graph, as an rclpy/rmw_cyclonedds
node would see it: same topic names (rt/...), same DDS type names, same CDR layout, and the
rmw_cyclonedds request/reply mapping for the service.

Usage (inside a loopback-only network namespace, see tests/peers/netns_run.sh):
  cyclone_peer.py state     [--samples N]   read rt/capsule/state, check the values, print JSON
  cyclone_peer.py force     --force F       command the plant (no controller running) and check
                                            that it applies F, refuses NaN, and falls back to zero
  cyclone_peer.py status    [--periods N]   read the controller status once N periods are done
  cyclone_peer.py set-mode  MODE GAIN       call /capsule_controller/set_mode, print the answer

Only typed readers and writers are used (Cyclone's built-in DCPSSubscription reader crashed with
RustDDS participants present). Exit status 0 = the checks held; 1 = a check failed.
"""
import argparse
import json
import math
import os
import random
import sys
import time
from dataclasses import dataclass

from cyclonedds.core import Qos, Policy
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import int32, int64, uint8, uint32, uint64, float64
import cyclonedds.idl.annotations as annotate
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration


@dataclass
@annotate.final
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32
    nanosec: uint32


@dataclass
@annotate.final
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time
    frame_id: str


@dataclass
@annotate.final
class CapsuleState(IdlStruct, typename="capsule_msgs::msg::dds_::CapsuleState_"):
    header: Header
    seq: uint64
    mass_position: float64
    mass_velocity: float64
    capsule_position: float64
    capsule_velocity: float64
    in_contact: bool
    stuck: bool
    friction_force: float64
    contact_force: float64
    actuator_force: float64
    command_stale: bool
    rejected_commands: uint32


@dataclass
@annotate.final
class ActuatorForce(IdlStruct, typename="capsule_msgs::msg::dds_::ActuatorForce_"):
    header: Header
    state_seq: uint64
    force: float64


@dataclass
@annotate.final
class ControllerStatus(IdlStruct, typename="capsule_msgs::msg::dds_::ControllerStatus_"):
    header: Header
    mode: uint8
    mode_name: str
    gain: float64
    drive_amplitude: float64
    drive_frequency: float64
    drive_amplitude_si: float64
    drive_frequency_hz: float64
    commanding: bool
    commands_sent: uint64
    periods: uint32
    progression_per_period: float64
    progression_per_period_m: float64
    mean_speed: float64
    efficiency: float64


# rmw_cyclonedds puts a 16-byte header (client GUID half, sequence number) before the request
# and response fields; the type names stay those of the .srv halves.
@dataclass
@annotate.final
class SetModeRequest(IdlStruct, typename="capsule_msgs::srv::dds_::SetMode_Request_"):
    client_guid: uint64
    sequence: int64
    mode: uint8
    gain: float64
    effective_from: Time


@dataclass
@annotate.final
class SetModeResponse(IdlStruct, typename="capsule_msgs::srv::dds_::SetMode_Response_"):
    client_guid: uint64
    sequence: int64
    accepted: bool
    mode: uint8
    gain: float64
    reason: str


RELIABLE = Qos(
    Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
    Policy.Durability.Volatile,
    Policy.History.KeepLast(16),
)


def fail(msg):
    print(f"cyclone_peer: FAIL: {msg}", file=sys.stderr)
    sys.exit(1)


def participant():
    return DomainParticipant(int(os.environ.get("ROS_DOMAIN_ID", "0")))


def read_states(dp, n, timeout):
    reader = DataReader(dp, Topic(dp, "rt/capsule/state", CapsuleState), qos=RELIABLE)
    out = []
    deadline = time.time() + timeout
    while len(out) < n and time.time() < deadline:
        for s in reader.take(N=64):
            out.append(s)
        time.sleep(0.002)
    return reader, out


def check_state_sample(s):
    for name in ("mass_position", "mass_velocity", "capsule_position", "capsule_velocity",
                 "friction_force", "contact_force", "actuator_force"):
        v = getattr(s, name)
        if not math.isfinite(v):
            fail(f"{name} = {v} is not finite")
    if s.header.frame_id != "odom":
        fail(f"frame_id {s.header.frame_id!r}, expected 'odom'")
    if not 0 <= s.header.stamp.nanosec < 1_000_000_000:
        fail(f"stamp nanosec {s.header.stamp.nanosec} out of range")


def cmd_state(args):
    dp = participant()
    _, states = read_states(dp, args.samples, args.timeout)
    if len(states) < args.samples:
        fail(f"got {len(states)} of {args.samples} state samples")
    for s in states:
        check_state_sample(s)
    seqs = [s.seq for s in states]
    if any(b <= a for a, b in zip(seqs, seqs[1:])):
        fail(f"seq not increasing: {seqs[:20]}")
    stamps = [s.header.stamp.sec + 1e-9 * s.header.stamp.nanosec for s in states]
    if any(b <= a for a, b in zip(stamps, stamps[1:])):
        fail("stamps not increasing")
    # fixed rate: stamp = seq / rate
    rate = (seqs[-1] - seqs[0]) / (stamps[-1] - stamps[0])
    if not all(abs(st - sq / rate) < 1e-6 for st, sq in zip(stamps, seqs)):
        fail(f"stamps are not seq / {rate} Hz")
    moved = max(s.mass_position for s in states) - min(s.mass_position for s in states)
    print(json.dumps({"samples": len(states), "rate_hz": rate, "first_seq": seqs[0],
                      "mass_travel_m": moved, "last": {
                          "mass_position": states[-1].mass_position,
                          "capsule_position": states[-1].capsule_position,
                          "actuator_force": states[-1].actuator_force}}))


def cmd_force(args):
    dp = participant()
    reader = DataReader(dp, Topic(dp, "rt/capsule/state", CapsuleState), qos=RELIABLE)
    writer = DataWriter(dp, Topic(dp, "rt/capsule/actuator_force", ActuatorForce), qos=RELIABLE)
    latest = [None]

    def pump(seconds, force=None):
        end = time.time() + seconds
        seen = []
        while time.time() < end:
            for s in reader.take(N=64):
                latest[0] = s
                seen.append(s)
            if force is not None and latest[0] is not None:
                s = latest[0]
                writer.write(ActuatorForce(header=Header(stamp=s.header.stamp, frame_id="odom"),
                                           state_seq=s.seq, force=force))
            time.sleep(0.005)
        return seen

    pump(1.0)
    if latest[0] is None:
        fail("no state from the plant")
    seen = pump(1.0, args.force)
    applied = [s for s in seen if not s.command_stale and abs(s.actuator_force - args.force) < 1e-9]
    if len(applied) < 5:
        fail(f"plant did not apply {args.force} N: last {[(s.actuator_force, s.command_stale) for s in seen[-5:]]}")
    # a late command (stamped before the last accepted one) must not take over
    last_ok = seen[-1].rejected_commands
    writer.write(ActuatorForce(header=Header(stamp=Time(sec=0, nanosec=1), frame_id="odom"),
                               state_seq=0, force=-args.force))
    seen = pump(0.3, args.force)
    if seen[-1].rejected_commands <= last_ok:
        fail("a late (old-stamped) command was not refused")
    if any(abs(s.actuator_force + args.force) < 1e-12 for s in seen):
        fail("a late command was applied (time rewound)")
    before = seen[-1].rejected_commands
    pump(0.3, float("nan"))
    seen = pump(0.3)
    after = seen[-1].rejected_commands if seen else before
    if after <= before:
        fail(f"NaN commands not counted as refused ({before} -> {after})")
    # stop commanding: the watchdog must fall back to zero force and say so
    seen = pump(args.stale_wait)
    tail = seen[-3:]
    if not tail or not all(s.command_stale and s.actuator_force == 0.0 for s in tail):
        fail(f"no zero-force fallback after silence: {[(s.actuator_force, s.command_stale) for s in tail]}")
    print(json.dumps({"applied_samples": len(applied), "refused_before": before, "refused_after": after,
                      "stale_fallback": True}))


def cmd_status(args):
    """Waits for a status with at least --periods complete periods and prints it."""
    dp = participant()
    reader = DataReader(dp, Topic(dp, "rt/capsule_controller/status", ControllerStatus), qos=RELIABLE)
    deadline = time.time() + args.timeout
    last = None
    while time.time() < deadline:
        for st in reader.take(N=16):
            last = st
        if last is not None and last.periods >= args.periods:
            print(json.dumps({k: getattr(last, k) for k in (
                "mode", "mode_name", "gain", "drive_amplitude", "drive_frequency", "commanding",
                "commands_sent", "periods", "progression_per_period", "progression_per_period_m",
                "mean_speed", "efficiency")} | {"stamp_s": last.header.stamp.sec + 1e-9 * last.header.stamp.nanosec}))
            return
        time.sleep(0.01)
    fail(f"no status with {args.periods} periods within {args.timeout} s (last: {last})")


def cmd_set_mode(args):
    dp = participant()
    svc = args.service.strip("/")
    writer = DataWriter(dp, Topic(dp, f"rq/{svc}Request", SetModeRequest), qos=RELIABLE)
    reader = DataReader(dp, Topic(dp, f"rr/{svc}Reply", SetModeResponse), qos=RELIABLE)
    guid = random.getrandbits(63)
    seq = 1
    deadline = time.time() + args.timeout
    while time.time() < deadline:
        writer.write(SetModeRequest(client_guid=guid, sequence=seq, mode=args.mode, gain=args.gain,
                                    effective_from=Time(sec=0, nanosec=0)))
        end = min(deadline, time.time() + 0.5)
        while time.time() < end:
            for r in reader.take(N=16):
                if r.client_guid == guid and r.sequence == seq:
                    print(json.dumps({"accepted": r.accepted, "mode": r.mode, "gain": r.gain,
                                      "reason": r.reason}))
                    return
            time.sleep(0.01)
        seq += 1
    fail(f"no set_mode reply within {args.timeout} s")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    a = sub.add_parser("state")
    a.add_argument("--samples", type=int, default=50)
    a.add_argument("--timeout", type=float, default=15.0)
    a = sub.add_parser("force")
    a.add_argument("--force", type=float, default=0.123)
    a.add_argument("--stale-wait", type=float, default=1.5)
    a = sub.add_parser("status")
    a.add_argument("--periods", type=int, default=10)
    a.add_argument("--timeout", type=float, default=60.0)
    a = sub.add_parser("set-mode")
    a.add_argument("mode", type=int)
    a.add_argument("gain", type=float)
    a.add_argument("--service", default="/capsule_controller/set_mode")
    a.add_argument("--timeout", type=float, default=15.0)
    args = p.parse_args()
    {"state": cmd_state, "force": cmd_force, "status": cmd_status, "set-mode": cmd_set_mode}[args.cmd](args)


if __name__ == "__main__":
    main()
