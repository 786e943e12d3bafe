#!/usr/bin/env python3
"""Eclipse Cyclone DDS (Python binding) peer of the capsule graph, as an rclpy/rmw_cyclonedds
node would see it: same topic names (rt/...), same DDS type names, same CDR layout, and the
rmw_cyclonedds request/reply mapping for the service.

Usage (inside a loopback-only network namespace, see tests/peers/netns_run.sh):
  cyclone_peer.py state     [--samples N]   read rt/capsule/state, check the values, print JSON
  cyclone_peer.py force     --force F       command the plant (no controller running) and check
                                            that it applies F, refuses NaN, and falls back to zero
  cyclone_peer.py status    [--periods N]   read the controller status once N periods are done
  cyclone_peer.py set-mode  MODE GAIN [--pulse-periods N --target-period P --max-tries T]
                                           call /capsule_controller/set_mode, print the answer
  cyclone_peer.py inject    --force F[,F..] fault injection: answer the newest state with force F
                            [--seconds S] [--hz R] [--stamp-sec SEC]   for S seconds at R Hz
                                            (default 1 kHz), stamped SEC if given; per force a
                                            JSON line: rate reached, states received and missed
                                            (gaps), largest |actuator_force| they showed, all
                                            finite, the last state
  cyclone_peer.py foreign   --kind K        publish on rt/capsule/actuator_force what the plant
                            [--seconds S]   cannot take: K = type (another type name) or layout
                                            (the ActuatorForce name with another layout)
  cyclone_peer.py joint-command --effort F   command the plant (--joint-commands, no controller)
                                            as topic_based_ros2_control does: JointState on
                                            rt/capsule/joint_commands, stamped with the wall clock;
                                            checks the state and joint_states show F applied, NaN
                                            refused, another joint's command ignored, zero force
                                            after silence
  cyclone_peer.py views     [--absent NAME...] joint_states, /tf, robot_description, /diagnostics
                                            checked against the state samples
  cyclone_peer.py diagnostics --name N... [--seconds S]
                                            read /diagnostics, print each named status's last
                                            message (level, message, values) as JSON
  cyclone_peer.py params    [--node N] [--set NAME=V]... [--refuse NAME=V]...
                                            the rcl_interfaces parameter services and
                                            /parameter_events, as `ros2 param` uses them

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
import types
from dataclasses import dataclass

from cyclonedds.core import Qos, Policy
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import int32, int64, uint8, uint32, uint64, float64, sequence
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
    switch_state: uint8
    switch_target_period: int32
    switch_tries: int32
    switch_max_tries: int32
    switch_pulse_gain: float64
    switch_pulse_periods: int32
    switch_pulse_start: Time
    switch_pulse_end: Time
    orbit_period: int32


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
    pulse_periods: int32
    target_period: int32
    max_tries: int32


@dataclass
@annotate.final
class SetModeResponse(IdlStruct, typename="capsule_msgs::srv::dds_::SetMode_Response_"):
    client_guid: uint64
    sequence: int64
    accepted: bool
    mode: uint8
    gain: float64
    reason: str


# standard types of the plant's views
@dataclass
@annotate.final
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    header: Header
    name: sequence[str]
    position: sequence[float64]
    velocity: sequence[float64]
    effort: sequence[float64]


@dataclass
@annotate.final
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64
    y: float64
    z: float64


@dataclass
@annotate.final
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64
    y: float64
    z: float64
    w: float64


@dataclass
@annotate.final
class Transform(IdlStruct, typename="geometry_msgs::msg::dds_::Transform_"):
    translation: Vector3
    rotation: Quaternion


@dataclass
@annotate.final
class TransformStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TransformStamped_"):
    header: Header
    child_frame_id: str
    transform: Transform


@dataclass
@annotate.final
class TFMessage(IdlStruct, typename="tf2_msgs::msg::dds_::TFMessage_"):
    transforms: sequence[TransformStamped]


@dataclass
@annotate.final
class String(IdlStruct, typename="std_msgs::msg::dds_::String_"):
    data: str


@dataclass
@annotate.final
class KeyValue(IdlStruct, typename="diagnostic_msgs::msg::dds_::KeyValue_"):
    key: str
    value: str


@dataclass
@annotate.final
class DiagnosticStatus(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticStatus_"):
    level: uint8
    name: str
    message: str
    hardware_id: str
    values: sequence[KeyValue]


@dataclass
@annotate.final
class DiagnosticArray(IdlStruct, typename="diagnostic_msgs::msg::dds_::DiagnosticArray_"):
    header: Header
    status: sequence[DiagnosticStatus]


# rcl_interfaces, as rmw_cyclonedds maps them (the request/reply halves with the same 16-byte
# header as SetMode above)
@dataclass
@annotate.final
class ParameterValue(IdlStruct, typename="rcl_interfaces::msg::dds_::ParameterValue_"):
    type: uint8
    bool_value: bool
    integer_value: int64
    double_value: float64
    string_value: str
    byte_array_value: sequence[uint8]
    bool_array_value: sequence[bool]
    integer_array_value: sequence[int64]
    double_array_value: sequence[float64]
    string_array_value: sequence[str]


def pvalue(v):
    """A ParameterValue of a Python value (bool, int, float, str)."""
    base = dict(type=0, bool_value=False, integer_value=0, double_value=0.0, string_value="",
                byte_array_value=[], bool_array_value=[], integer_array_value=[],
                double_array_value=[], string_array_value=[])
    if isinstance(v, bool):
        base.update(type=1, bool_value=v)
    elif isinstance(v, int):
        base.update(type=2, integer_value=v)
    elif isinstance(v, float):
        base.update(type=3, double_value=v)
    elif isinstance(v, str):
        base.update(type=4, string_value=v)
    return ParameterValue(**base)


def pyvalue(pv):
    return {0: None, 1: pv.bool_value, 2: pv.integer_value, 3: pv.double_value,
            4: pv.string_value}.get(pv.type, f"type {pv.type}")


@dataclass
@annotate.final
class Parameter(IdlStruct, typename="rcl_interfaces::msg::dds_::Parameter_"):
    name: str
    value: ParameterValue


@dataclass
@annotate.final
class SetParametersResult(IdlStruct, typename="rcl_interfaces::msg::dds_::SetParametersResult_"):
    successful: bool
    reason: str


@dataclass
@annotate.final
class FloatingPointRange(IdlStruct, typename="rcl_interfaces::msg::dds_::FloatingPointRange_"):
    from_value: float64
    to_value: float64
    step: float64


@dataclass
@annotate.final
class IntegerRange(IdlStruct, typename="rcl_interfaces::msg::dds_::IntegerRange_"):
    from_value: int64
    to_value: int64
    step: uint64


@dataclass
@annotate.final
class ParameterDescriptor(IdlStruct, typename="rcl_interfaces::msg::dds_::ParameterDescriptor_"):
    name: str
    type: uint8
    description: str
    additional_constraints: str
    read_only: bool
    dynamic_typing: bool
    floating_point_range: sequence[FloatingPointRange, 1]
    integer_range: sequence[IntegerRange, 1]


@dataclass
@annotate.final
class ListParametersResult(IdlStruct, typename="rcl_interfaces::msg::dds_::ListParametersResult_"):
    names: sequence[str]
    prefixes: sequence[str]


@dataclass
@annotate.final
class ParameterEvent(IdlStruct, typename="rcl_interfaces::msg::dds_::ParameterEvent_"):
    stamp: Time
    node: str
    new_parameters: sequence[Parameter]
    changed_parameters: sequence[Parameter]
    deleted_parameters: sequence[Parameter]


def _srv(name, req_fields, resp_fields):
    """Request and response classes of rcl_interfaces/srv/NAME in the rmw_cyclonedds mapping."""
    def make(kind, fields):
        ann = {"client_guid": uint64, "sequence": int64} | fields
        cls = types.new_class(f"{name}_{kind}", (IdlStruct,),
                              {"typename": f"rcl_interfaces::srv::dds_::{name}_{kind}_"},
                              lambda ns: ns.update({"__annotations__": ann}))
        return annotate.final(dataclass(cls))
    return make("Request", req_fields), make("Response", resp_fields)


PARAM_SRV = {
    "list_parameters": _srv("ListParameters", {"prefixes": sequence[str], "depth": uint64},
                            {"result": ListParametersResult}),
    "describe_parameters": _srv("DescribeParameters", {"names": sequence[str]},
                                {"descriptors": sequence[ParameterDescriptor]}),
    "get_parameters": _srv("GetParameters", {"names": sequence[str]},
                           {"values": sequence[ParameterValue]}),
    "get_parameter_types": _srv("GetParameterTypes", {"names": sequence[str]},
                                {"types": sequence[uint8]}),
    "set_parameters": _srv("SetParameters", {"parameters": sequence[Parameter]},
                           {"results": sequence[SetParametersResult]}),
    "set_parameters_atomically": _srv("SetParametersAtomically",
                                      {"parameters": sequence[Parameter]},
                                      {"result": SetParametersResult}),
}


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


def cmd_joint_command(args):
    dp = participant()
    reader = DataReader(dp, Topic(dp, "rt/capsule/state", CapsuleState), qos=RELIABLE)
    js_reader = DataReader(dp, Topic(dp, "rt/joint_states", JointState), qos=RELIABLE)
    writer = DataWriter(dp, Topic(dp, "rt/capsule/joint_commands", JointState), qos=RELIABLE)
    latest = [None]
    joint_states = []

    def command(names, efforts):
        now = time.time()
        writer.write(JointState(header=Header(stamp=Time(sec=int(now), nanosec=int((now % 1) * 1e9)), frame_id=""),
                                name=names, position=[], velocity=[], effort=efforts))

    def pump(seconds, names=None, efforts=None):
        end = time.time() + seconds
        seen = []
        while time.time() < end:
            for s in reader.take(N=64):
                latest[0] = s
                seen.append(s)
            joint_states.extend(js_reader.take(N=64))
            if names is not None:
                command(names, efforts)
            time.sleep(0.005)
        return seen

    pump(1.0)
    if latest[0] is None:
        fail("no state from the plant")
    f = args.effort
    # both joints named, as topic_based_ros2_control sends them when both have an effort
    # interface: the plant must pick inner_mass_joint's by name
    seen = pump(1.0, ["capsule_joint", "inner_mass_joint"], [9.0, f])
    applied = [s for s in seen if not s.command_stale and abs(s.actuator_force - f) < 1e-9]
    if len(applied) < 5:
        fail(f"plant did not apply the effort {f} N: last {[(s.actuator_force, s.command_stale) for s in seen[-5:]]}")
    efforts = [js.effort[list(js.name).index("inner_mass_joint")] for js in joint_states
               if "inner_mass_joint" in js.name and len(js.effort) == len(js.name)]
    if not any(abs(e - f) < 1e-9 for e in efforts):
        fail(f"joint_states never showed inner_mass_joint's effort {f} ({len(joint_states)} joint states, last efforts {efforts[-3:]})")
    before = seen[-1].rejected_commands
    seen = pump(0.3, ["inner_mass_joint"], [float("nan")]) + pump(0.3)
    after = seen[-1].rejected_commands if seen else before
    if after <= before:
        fail(f"NaN efforts not counted as refused ({before} -> {after})")
    if any(not math.isfinite(s.actuator_force) for s in seen):
        fail("a NaN effort reached the simulation")
    seen = pump(0.5, ["wheel_joint"], [-f])
    if any(abs(s.actuator_force + f) < 1e-12 for s in seen):
        fail("a command for another joint was applied")
    seen = pump(args.stale_wait)
    tail = seen[-3:]
    if not tail or not all(s.command_stale and s.actuator_force == 0.0 for s in tail):
        fail(f"no zero-force fallback after silence: {[(s.actuator_force, s.command_stale) for s in tail]}")
    print(json.dumps({"applied_samples": len(applied), "joint_states_effort_seen": True,
                      "refused_before": before, "refused_after": after, "stale_fallback": True}))


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
                "mean_speed", "efficiency", "switch_state", "switch_tries", "orbit_period")} | {"stamp_s": last.header.stamp.sec + 1e-9 * last.header.stamp.nanosec}))
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
                                    effective_from=Time(sec=0, nanosec=0),
                                    pulse_periods=args.pulse_periods, target_period=args.target_period,
                                    max_tries=args.max_tries))
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


@dataclass
@annotate.final
class ForeignType(IdlStruct, typename="std_msgs::msg::dds_::String_"):
    data: str


@dataclass
@annotate.final
class ForeignLayout(IdlStruct, typename="capsule_msgs::msg::dds_::ActuatorForce_"):
    x: uint8


def cmd_inject(args):
    dp = participant()
    reader = DataReader(dp, Topic(dp, "rt/capsule/state", CapsuleState), qos=RELIABLE)
    writer = DataWriter(dp, Topic(dp, "rt/capsule/actuator_force", ActuatorForce), qos=RELIABLE)
    latest = None
    deadline = time.time() + args.timeout
    while latest is None and time.time() < deadline:
        for s in reader.take(N=64):
            latest = s
        time.sleep(0.002)
    if latest is None:
        fail("no state from the plant")
    # the state came through, but our writer may not have matched the plant's reader yet: a
    # volatile write before that is lost (on a loaded host the single future-stamped command was)
    while writer.get_publication_matched_status().current_count < 1:
        if time.time() > deadline:
            fail("the plant's force reader never matched")
        time.sleep(0.01)
    for force in [float(f) for f in args.force.split(",")]:
        sent = received = gaps = 0
        max_applied = 0.0
        finite = True
        period = 1.0 / args.hz
        start = last_take = time.time()
        end = start + args.seconds
        next_at = start
        cmd = None
        start_refused = latest.rejected_commands
        # a phase lasts --seconds and, on a loaded host, until --min-states states have come back
        # (bounded by --timeout): what it reports must be answers to its own commands
        while sent == 0 or time.time() < end or (
                received < args.min_states and time.time() < start + args.timeout):
            if cmd is None or time.time() - last_take >= 0.0005:  # a take costs more than a write
                last_take = time.time()
                for s in reader.take(N=64):
                    gaps += max(0, s.seq - latest.seq - 1)
                    received += 1
                    max_applied = max(max_applied, abs(s.actuator_force))
                    finite = finite and all(math.isfinite(getattr(s, k)) for k in (
                        "mass_position", "mass_velocity", "capsule_position", "capsule_velocity"))
                    latest = s
                stamp = latest.header.stamp if args.stamp_sec is None else Time(sec=args.stamp_sec, nanosec=0)
                cmd = ActuatorForce(header=Header(stamp=stamp, frame_id="odom"), state_seq=latest.seq,
                                    force=force)
            writer.write(cmd)
            sent += 1
            next_at += period
            # pace: sleep when ahead (Python's sleep is too coarse for 20 kHz: spin then)
            ahead = next_at - time.time()
            if ahead > 0.002:
                time.sleep(ahead)
            elif ahead > 0:
                while time.time() < next_at:
                    pass
        # --until-refused: a single write can still be lost on a loaded host (the plant's reader
        # may not know our writer yet when we exit); resend every 0.5 s until a state shows it
        # refused, so the plant counts one refusal per delivered command, usually one in all
        if args.until_refused:
            refused_before = start_refused
            resend_at = time.time() + 0.5
            while latest.rejected_commands <= refused_before and time.time() < start + args.timeout:
                for s in reader.take(N=64):
                    received += 1
                    latest = s
                if time.time() >= resend_at:
                    writer.write(cmd)
                    sent += 1
                    resend_at = time.time() + 0.5
                time.sleep(0.002)
            if latest.rejected_commands <= refused_before:
                fail("the plant never reported the command refused")
        took = time.time() - start
        print(json.dumps({"force": force if math.isfinite(force) else str(force), "sent": sent,
                          "rate_hz": sent / took, "received": received, "gaps": gaps,
                          "max_abs_applied": max_applied, "finite": finite, "last": {
                              "seq": latest.seq, "actuator_force": latest.actuator_force,
                              "command_stale": latest.command_stale,
                              "rejected_commands": latest.rejected_commands}}), flush=True)


def cmd_foreign(args):
    dp = participant()
    ty, make = {"type": (ForeignType, lambda i: ForeignType(data=f"not a force {i}")),
                "layout": (ForeignLayout, lambda i: ForeignLayout(x=i % 256))}[args.kind]
    writer = DataWriter(dp, Topic(dp, "rt/capsule/actuator_force", ty), qos=RELIABLE)
    end = time.time() + args.seconds
    sent = 0
    while time.time() < end:
        writer.write(make(sent))
        sent += 1
        time.sleep(0.001)
    print(json.dumps({"kind": args.kind, "sent": sent}))
class ParamClient:
    """Calls a node's rcl_interfaces parameter services (rmw_cyclonedds mapping)."""

    def __init__(self, dp, node, timeout):
        self.node = "/" + node.strip("/")
        self.timeout = timeout
        self.guid = random.getrandbits(63)
        self.seq = 0
        self.ends = {}
        for svc, (req, resp) in PARAM_SRV.items():
            base = f"{self.node.strip('/')}/{svc}"
            self.ends[svc] = (req, DataWriter(dp, Topic(dp, f"rq/{base}Request", req), qos=RELIABLE),
                              DataReader(dp, Topic(dp, f"rr/{base}Reply", resp), qos=RELIABLE))

    def call(self, svc, **fields):
        req, writer, reader = self.ends[svc]
        deadline = time.time() + self.timeout
        while time.time() < deadline:
            self.seq += 1
            writer.write(req(client_guid=self.guid, sequence=self.seq, **fields))
            end = min(deadline, time.time() + 0.5)
            while time.time() < end:
                for r in reader.take(N=16):
                    if r.client_guid == self.guid and r.sequence == self.seq:
                        return r
                time.sleep(0.005)
        fail(f"no {svc} reply from {self.node} within {self.timeout} s")

    def get(self, *names):
        return [pyvalue(v) for v in self.call("get_parameters", names=list(names)).values]

    def set(self, name, value):
        r = self.call("set_parameters", parameters=[Parameter(name=name, value=pvalue(value))])
        return r.results[0]


def take_events(reader, node, wait):
    end = time.time() + wait
    out = []
    while time.time() < end:
        for e in reader.take(N=64):
            if e.node == node:
                out.append({p.name: pyvalue(p.value) for p in e.changed_parameters})
        time.sleep(0.01)
    return out


def cmd_params(args):
    """Lists, gets, describes, sets and refuses parameters of --node; checks /parameter_events.

    --set NAME=VALUE (a value that must be accepted; JSON-typed, e.g. 0.5, true, "FORWARD")
    --refuse NAME=VALUE (must be refused with a reason, nothing changed, no event)
    Prints one JSON line with what it saw."""
    dp = participant()
    events = DataReader(dp, Topic(dp, "rt/parameter_events", ParameterEvent),
                        qos=Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
                                Policy.Durability.Volatile, Policy.History.KeepLast(1000)))
    c = ParamClient(dp, args.node, args.timeout)
    names = list(c.call("list_parameters", prefixes=[], depth=0).result.names)
    out = {"names": names}
    out["values"] = dict(zip(names, c.get(*names)))
    types = list(c.call("get_parameter_types", names=names + ["no_such"]).types)
    out["types"] = dict(zip(names + ["no_such"], types))
    descs = c.call("describe_parameters", names=names).descriptors
    out["read_only"] = {d.name: d.read_only for d in descs}
    out["ranges"] = {d.name: [d.floating_point_range[0].from_value, d.floating_point_range[0].to_value]
                     for d in descs if d.floating_point_range}
    take_events(events, c.node, 0.3)  # the reader has matched; drop what came before
    out["set"] = []
    for item in args.set:
        name, value = item.split("=", 1)
        value = json.loads(value)
        r = c.set(name, value)
        if not r.successful:
            fail(f"set {name}={value!r} refused: {r.reason}")
        after = c.get(name)[0]
        evs = take_events(events, c.node, 0.5)
        if not any(name in e for e in evs):
            fail(f"no /parameter_events for {name} after setting it: {evs}")
        out["set"].append({"name": name, "value": value, "now": after, "events": evs})
    out["refused"] = []
    for item in args.refuse:
        name, value = item.split("=", 1)
        value = float("nan") if value == "nan" else json.loads(value)
        before = c.get(*names)
        r = c.set(name, value)
        if r.successful or not r.reason:
            fail(f"set {name}={value!r} was not refused with a reason: {r}")
        after = c.get(*names)
        if before != after:
            fail(f"refused set {name}={value!r} changed something: {before} -> {after}")
        evs = take_events(events, c.node, 0.3)
        if evs:
            fail(f"refused set {name}={value!r} published events {evs}")
        out["refused"].append({"name": name, "reason": r.reason})
    # set_parameters_atomically: one bad parameter spoils the set
    if args.set:
        name, value = args.set[0].split("=", 1)
        r = c.call("set_parameters_atomically",
                   parameters=[Parameter(name=name, value=pvalue(json.loads(value))),
                               Parameter(name="no_such", value=pvalue(1.0))]).result
        if r.successful:
            fail("set_parameters_atomically with an unknown name succeeded")
        out["atomic_refused"] = r.reason
    print(json.dumps(out))


def cmd_views(args):
    """Reads the plant's standard-type views beside rt/capsule/state and checks each against
    the state sample with the same stamp; --absent NAME... must stay silent. Prints JSON."""
    dp = participant()
    latched = Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
                  Policy.Durability.TransientLocal, Policy.History.KeepLast(1))
    readers = {
        "state": DataReader(dp, Topic(dp, "rt/capsule/state", CapsuleState), qos=RELIABLE),
        "joint_states": DataReader(dp, Topic(dp, "rt/joint_states", JointState), qos=RELIABLE),
        "tf": DataReader(dp, Topic(dp, "rt/tf", TFMessage), qos=RELIABLE),
        "diagnostics": DataReader(dp, Topic(dp, "rt/diagnostics", DiagnosticArray), qos=RELIABLE),
        "robot_description": DataReader(dp, Topic(dp, "rt/robot_description", String), qos=latched),
    }
    got = {k: [] for k in readers}
    # discovery can take seconds on a loaded host: count from the first state sample
    start = time.time()
    deadline = start + args.timeout
    while time.time() < deadline:
        for k, r in readers.items():
            got[k].extend(r.take(N=256))
        if got["state"] and deadline - start > args.seconds:
            start = time.time()
            deadline = start + args.seconds
        time.sleep(0.005)
    if not got["state"]:
        fail(f"no state sample within {args.timeout} s")
    stamp = lambda h: (h.stamp.sec, h.stamp.nanosec)
    states = {stamp(s.header): s for s in got["state"]}
    out = {k: len(v) for k, v in got.items()}
    for name in args.absent:
        if got[name]:
            fail(f"{name} is switched off but {len(got[name])} messages came")
    if "joint_states" not in args.absent:
        matched = 0
        for js in got["joint_states"]:
            if list(js.name) != ["capsule_joint", "inner_mass_joint"]:
                fail(f"joint names {js.name}")
            s = states.get(stamp(js.header))
            if s is None:
                continue
            want = ([s.capsule_position, s.mass_position - s.capsule_position],
                    [s.capsule_velocity, s.mass_velocity - s.capsule_velocity],
                    [s.friction_force, s.actuator_force])
            if (list(js.position), list(js.velocity), list(js.effort)) != want:
                fail(f"joint state {js} does not map state {s}")
            matched += 1
        if matched < 10:
            fail(f"only {matched} joint states matched a state sample ({len(states)} states, {len(got['joint_states'])} joint states)")
        out["joint_states_matched"] = matched
    if "tf" not in args.absent:
        matched = 0
        for m in got["tf"]:
            t = m.transforms[0]
            if (t.header.frame_id, t.child_frame_id) != ("odom", "capsule"):
                fail(f"tf {t.header.frame_id} -> {t.child_frame_id}")
            s = states.get(stamp(t.header))
            if s is not None:
                if t.transform.translation.x != s.capsule_position or t.transform.rotation.w != 1.0:
                    fail(f"tf {t.transform} does not place the capsule of {s}")
                matched += 1
        if matched < 10:
            fail(f"only {matched} tf messages matched a state sample ({len(states)} states, {list(states)[:3]}, tf {[stamp(m.transforms[0].header) for m in got['tf'][:3]]})")
        out["tf_matched"] = matched
    if "robot_description" not in args.absent:
        if not got["robot_description"]:
            fail("no robot_description (transient local: a late reader must get it)")
        urdf = got["robot_description"][-1].data
        for needle in ('<robot name="capsule">', '<joint name="inner_mass_joint" type="prismatic">'):
            if needle not in urdf:
                fail(f"URDF lacks {needle}")
    if "diagnostics" not in args.absent:
        if not got["diagnostics"]:
            fail("no /diagnostics")
        # the plant's loop status (the controller publishes on /diagnostics too)
        loops = [st for m in got["diagnostics"] for st in m.status if st.name.endswith(": loop")]
        if not loops:
            fail(f"no loop status among {[st.name for m in got['diagnostics'] for st in m.status]}")
        st = loops[-1]
        out["diagnostics_last"] = {"level": st.level, "name": st.name, "message": st.message,
                                   "values": {kv.key: kv.value for kv in st.values}}
    print(json.dumps(out))


def cmd_diagnostics(args):
    """Reads /diagnostics for --seconds (counted from the first array) and prints the last
    status of each --name (a node's statuses are named "NODE: ..."); fails if one is missing."""
    dp = participant()
    r = DataReader(dp, Topic(dp, "rt/diagnostics", DiagnosticArray), qos=RELIABLE)
    got = []
    start = time.time()
    deadline = start + args.timeout
    while time.time() < deadline:
        got.extend(r.take(N=64))
        if got and deadline - start > args.seconds:
            start = time.time()
            deadline = start + args.seconds
        time.sleep(0.02)
    last = {}
    for m in got:
        for st in m.status:
            last[st.name] = {"level": st.level, "message": st.message,
                             "values": {kv.key: kv.value for kv in st.values}, "count": last.get(st.name, {}).get("count", 0) + 1}
    out = {}
    for name in args.name:
        found = [k for k in last if k.split(":")[0] == name]
        if not found:
            fail(f"no /diagnostics status of {name} (got {sorted(last)})")
        out[name] = {k: last[k] for k in found}
    print(json.dumps(out))


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    a = sub.add_parser("state")
    a.add_argument("--samples", type=int, default=50)
    a.add_argument("--timeout", type=float, default=15.0)
    a = sub.add_parser("force")
    a.add_argument("--force", type=float, default=0.123)
    a.add_argument("--stale-wait", type=float, default=1.5)
    a = sub.add_parser("joint-command")
    a.add_argument("--effort", type=float, default=0.123)
    a.add_argument("--stale-wait", type=float, default=1.5)
    a = sub.add_parser("status")
    a.add_argument("--periods", type=int, default=10)
    a.add_argument("--timeout", type=float, default=60.0)
    a = sub.add_parser("set-mode")
    a.add_argument("mode", type=int)
    a.add_argument("gain", type=float)
    a.add_argument("--pulse-periods", type=int, default=0, help="SWITCH_ATTRACTOR (mode 5) only")
    a.add_argument("--target-period", type=int, default=0, help="SWITCH_ATTRACTOR (mode 5) only")
    a.add_argument("--max-tries", type=int, default=0, help="SWITCH_ATTRACTOR (mode 5) only")
    a.add_argument("--service", default="/capsule_controller/set_mode")
    a.add_argument("--timeout", type=float, default=15.0)
    a = sub.add_parser("inject")
    a.add_argument("--force", required=True, help="F, or F1,F2,... one phase each")
    a.add_argument("--seconds", type=float, default=1.0, help="per phase")
    a.add_argument("--hz", type=float, default=1000.0)
    a.add_argument("--stamp-sec", type=int, default=None)
    a.add_argument("--min-states", type=int, default=0, help="per phase, states received at least")
    a.add_argument("--until-refused", action="store_true",
                   help="resend until a state shows the plant refused the command")
    a.add_argument("--timeout", type=float, default=15.0)
    a = sub.add_parser("foreign")
    a.add_argument("--kind", choices=["type", "layout"], required=True)
    a.add_argument("--seconds", type=float, default=1.0)
    a = sub.add_parser("params")
    a.add_argument("--node", default="/capsule_controller")
    a.add_argument("--set", action="append", default=[], metavar="NAME=JSON")
    a.add_argument("--refuse", action="append", default=[], metavar="NAME=JSON")
    a.add_argument("--timeout", type=float, default=15.0)
    a = sub.add_parser("diagnostics")
    a.add_argument("--name", nargs="+", required=True)
    a.add_argument("--seconds", type=float, default=2.5)
    a.add_argument("--timeout", type=float, default=30.0)
    a = sub.add_parser("views")
    a.add_argument("--seconds", type=float, default=3.0)
    a.add_argument("--timeout", type=float, default=30.0)
    a.add_argument("--absent", nargs="*", default=[])
    args = p.parse_args()
    {"state": cmd_state, "force": cmd_force, "status": cmd_status, "set-mode": cmd_set_mode,
     "inject": cmd_inject, "foreign": cmd_foreign, "params": cmd_params, "views": cmd_views,
     "diagnostics": cmd_diagnostics, "joint-command": cmd_joint_command}[args.cmd](args)


if __name__ == "__main__":
    main()
