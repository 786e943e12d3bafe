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
  cyclone_peer.py estop                     engage the plant's emergency stop (std_srvs/SetBool)
                                            while a controller commands, read the force on the
                                            state and the latched state as a late reader, release
                                            it; print JSON
  cyclone_peer.py diagnostics --name N... [--seconds S]
                                            read /diagnostics, print each named status's last
                                            message (level, message, values) as JSON
  cyclone_peer.py lifecycle T... [--node N] [--settle S] [--window S] [--active-wait S]
                                            drive a managed node through the transitions T
                                            (labels: configure, activate, ...) with
                                            lifecycle_msgs/srv/ChangeState, as `ros2 lifecycle
                                            set` does; after each, get_state and the largest
                                            |actuator_force| on the state from S s on, for a
                                            window; the transition events; print JSON
  cyclone_peer.py estop-time [--repeat N]   the emergency stop's answer time, seen by a client
                                            (engage, release, N times; after a warm-up call)
  cyclone_peer.py first-answers [--node N] [--clients K] [--wait S]
                                            K fresh clients of N's list_parameters, one after
                                            the other, each sending one request at once, never
                                            again: how many were answered within S s; print JSON
  cyclone_peer.py params    [--node N] [--set NAME=V]... [--refuse NAME=V]...
                                            the rcl_interfaces parameter services and
                                            /parameter_events, as `ros2 param` uses them

The capsule_msgs types are built from capsule_msgs/msg/*.msg and srv/*.srv, the files the Rust
crate embeds; the standard ROS 2 types the peer uses are spelt out in STANDARD below.
Only typed readers and writers are used (Cyclone's built-in DCPSSubscription reader crashed with
RustDDS participants present). Exit status 0 = the checks held; 1 = a check failed.
"""
import argparse
import json
import math
import os
import random
import re
import sys
import time
import types
from dataclasses import dataclass

from cyclonedds.core import Qos, Policy
from cyclonedds.domain import DomainParticipant
from cyclonedds.internal import InvalidSample
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, int8, int32, int64, uint8, uint32, uint64, float64, sequence
import cyclonedds.idl.annotations as annotate
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration


# rmw_cyclonedds puts a 16-byte header (client GUID half, sequence number) before the request
# and response fields of a service; the type names stay those of the .srv halves.
SERVICE_HEADER = {"client_guid": uint64, "sequence": int64}

PRIMITIVES = {"bool": bool, "byte": uint8, "uint8": uint8, "int8": int8, "int32": int32, "uint32": uint32,
              "int64": int64, "uint64": uint64, "float64": float64, "string": str}

# The standard ROS 2 interfaces the peer uses, as the ROS 2 distribution defines them (one type
# an entry, its fields separated by ";", a service's halves by "---"), dependencies first.
STANDARD = {
    "builtin_interfaces/msg/Time": "int32 sec; uint32 nanosec",
    "std_msgs/msg/Header": "builtin_interfaces/Time stamp; string frame_id",
    "std_msgs/msg/String": "string data",
    "sensor_msgs/msg/JointState": "std_msgs/Header header; string[] name; float64[] position; "
                                  "float64[] velocity; float64[] effort",
    "geometry_msgs/msg/Vector3": "float64 x; float64 y; float64 z",
    "geometry_msgs/msg/Quaternion": "float64 x; float64 y; float64 z; float64 w",
    "geometry_msgs/msg/Transform": "Vector3 translation; Quaternion rotation",
    "geometry_msgs/msg/TransformStamped": "std_msgs/Header header; string child_frame_id; "
                                          "Transform transform",
    "tf2_msgs/msg/TFMessage": "geometry_msgs/TransformStamped[] transforms",
    "std_msgs/msg/Bool": "bool data",
    "std_srvs/srv/SetBool": "bool data --- bool success; string message",
    "lifecycle_msgs/msg/State": "uint8 id; string label",
    "lifecycle_msgs/msg/Transition": "uint8 id; string label",
    "lifecycle_msgs/msg/TransitionDescription": "Transition transition; State start_state; "
                                                "State goal_state",
    "lifecycle_msgs/msg/TransitionEvent": "uint64 timestamp; Transition transition; "
                                          "State start_state; State goal_state",
    "lifecycle_msgs/srv/ChangeState": "Transition transition --- bool success",
    "lifecycle_msgs/srv/GetState": "uint8 structure_needs_at_least_one_member --- "
                                   "State current_state",
    "lifecycle_msgs/srv/GetAvailableStates": "uint8 structure_needs_at_least_one_member --- "
                                             "State[] available_states",
    "lifecycle_msgs/srv/GetAvailableTransitions": "uint8 structure_needs_at_least_one_member --- "
                                                  "TransitionDescription[] available_transitions",
    "diagnostic_msgs/msg/KeyValue": "string key; string value",
    "diagnostic_msgs/msg/DiagnosticStatus": "byte level; string name; string message; "
                                            "string hardware_id; KeyValue[] values",
    "diagnostic_msgs/msg/DiagnosticArray": "std_msgs/Header header; DiagnosticStatus[] status",
    "rcl_interfaces/msg/ParameterValue": "uint8 type; bool bool_value; int64 integer_value; "
                                         "float64 double_value; string string_value; "
                                         "byte[] byte_array_value; bool[] bool_array_value; "
                                         "int64[] integer_array_value; "
                                         "float64[] double_array_value; string[] string_array_value",
    "rcl_interfaces/msg/Parameter": "string name; ParameterValue value",
    "rcl_interfaces/msg/SetParametersResult": "bool successful; string reason",
    "rcl_interfaces/msg/FloatingPointRange": "float64 from_value; float64 to_value; float64 step",
    "rcl_interfaces/msg/IntegerRange": "int64 from_value; int64 to_value; uint64 step",
    "rcl_interfaces/msg/ParameterDescriptor": "string name; uint8 type; string description; "
                                              "string additional_constraints; bool read_only; "
                                              "bool dynamic_typing; "
                                              "FloatingPointRange[<=1] floating_point_range; "
                                              "IntegerRange[<=1] integer_range",
    "rcl_interfaces/msg/ListParametersResult": "string[] names; string[] prefixes",
    "rcl_interfaces/msg/ParameterEvent": "builtin_interfaces/Time stamp; string node; "
                                         "Parameter[] new_parameters; "
                                         "Parameter[] changed_parameters; "
                                         "Parameter[] deleted_parameters",
    "rcl_interfaces/srv/ListParameters": "string[] prefixes; uint64 depth --- "
                                         "ListParametersResult result",
    "rcl_interfaces/srv/DescribeParameters": "string[] names --- "
                                             "ParameterDescriptor[] descriptors",
    "rcl_interfaces/srv/GetParameters": "string[] names --- ParameterValue[] values",
    "rcl_interfaces/srv/GetParameterTypes": "string[] names --- uint8[] types",
    "rcl_interfaces/srv/SetParameters": "Parameter[] parameters --- "
                                        "SetParametersResult[] results",
    "rcl_interfaces/srv/SetParametersAtomically": "Parameter[] parameters --- "
                                                  "SetParametersResult result",
}

# capsule_msgs' own interfaces: the files the Rust crate embeds (one source of truth)
CAPSULE_MSGS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "capsule_msgs")


def valid(samples):
    """The samples that carry data: a take also returns InvalidSample entries (a writer went
    away or disposed), which have no fields."""
    return [x for x in samples if not isinstance(x, InvalidSample)]


def idl_type(full_name, fields, known, header=None):
    """The final IdlStruct of FULL_NAME ('pkg/msg/Name'; DDS name 'pkg::msg::dds_::Name_') with
    the fields of interface text FIELDS (comments and constants skipped; a nested type is
    looked up in KNOWN by 'pkg/Name', the package FULL_NAME's if the field names none), after
    HEADER's fields."""
    pkg, kind, name = full_name.split("/")
    ann = dict(header or {})
    for field in fields.split(";"):
        words = field.split()
        if len(words) < 2 or "=" in "".join(words[1:]):  # a constant: TYPE NAME=VALUE
            continue
        base, _, bound = words[0].partition("[")
        ty = PRIMITIVES.get(base) or known[base if "/" in base else f"{pkg}/{base}"]
        if bound == "]":
            ty = sequence[ty]
        elif bound.startswith("<="):
            ty = sequence[ty, int(bound[2:-1])]
        elif bound:
            ty = array[ty, int(bound[:-1])]
        ann[words[1]] = ty
    cls = types.new_class(name, (IdlStruct,), {"typename": f"{pkg}::{kind}::dds_::{name}_"},
                          lambda ns: ns.update({"__annotations__": ann}))
    return annotate.final(dataclass(cls))


def load_types():
    """Every type the peer uses, by 'pkg/Name' (a service's halves: 'pkg/Name_Request', ..)."""
    files = [(f"capsule_msgs/{d}/{f[:-4]}", os.path.join(CAPSULE_MSGS, d, f))
             for d in ("msg", "srv") for f in sorted(os.listdir(os.path.join(CAPSULE_MSGS, d)))]
    texts = list(STANDARD.items())
    for full_name, path in files:
        with open(path) as f:
            # comments off, one field a ';'-separated part, as in STANDARD
            texts.append((full_name, ";".join(line.split("#")[0] for line in f)))
    known = {}
    for full_name, text in texts:
        pkg, kind, name = full_name.split("/")
        if kind == "srv":
            for half, part in zip(("Request", "Response"), text.split("---")):
                known[f"{pkg}/{name}_{half}"] = idl_type(f"{full_name}_{half}", part, known,
                                                         SERVICE_HEADER)
        else:
            known[f"{pkg}/{name}"] = idl_type(full_name, text, known)
    return known


TYPES = load_types()
# the types by their short names: T.CapsuleState, T.SetMode_Request, ..
T = types.SimpleNamespace(**{k.split("/")[1]: v for k, v in TYPES.items()})


# the rcl_interfaces parameter services, by the name a node serves them under
PARAM_SRV = {re.sub(r"(?<!^)([A-Z])", r"_\1", name).lower():
             (TYPES[f"rcl_interfaces/{name}_Request"], TYPES[f"rcl_interfaces/{name}_Response"])
             for name in (k.split("/")[2] for k in STANDARD if k.startswith("rcl_interfaces/srv/"))}


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
    return T.ParameterValue(**base)


def pyvalue(pv):
    return {0: None, 1: pv.bool_value, 2: pv.integer_value, 3: pv.double_value,
            4: pv.string_value}.get(pv.type, f"type {pv.type}")


def reliable(durability=Policy.Durability.Volatile, depth=16):
    """Reliable QoS (100 ms blocking), DURABILITY, keeping the last DEPTH samples."""
    return Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
               durability, Policy.History.KeepLast(depth))


RELIABLE = reliable()


def fail(msg):
    print(f"cyclone_peer: FAIL: {msg}", file=sys.stderr)
    sys.exit(1)


def participant():
    return DomainParticipant(int(os.environ.get("ROS_DOMAIN_ID", "0")))


def reader(dp, topic, ty, qos=RELIABLE):
    """A reader of ROS topic TOPIC (DDS topic rt/TOPIC) of type TY."""
    return DataReader(dp, Topic(dp, f"rt/{topic}", ty), qos=qos)


def writer(dp, topic, ty):
    """A reliable writer of ROS topic TOPIC (DDS topic rt/TOPIC) of type TY."""
    return DataWriter(dp, Topic(dp, f"rt/{topic}", ty), qos=RELIABLE)


def wait_for(r, done, timeout, poll, n=64):
    """Takes samples from reader R until DONE(all taken so far) holds or TIMEOUT s have passed,
    polling every POLL s; returns all taken."""
    got = []
    deadline = time.time() + timeout
    while time.time() < deadline:
        got.extend(valid(r.take(N=n)))
        if done(got):
            break
        time.sleep(poll)
    return got


def read_window(take, seconds, timeout, poll):
    """Calls TAKE() every POLL s (it returns whether the first sample has come) until it has,
    bounded by TIMEOUT s (discovery can take seconds on a loaded host), then for SECONDS more."""
    deadline = time.time() + timeout
    windowed = False
    while time.time() < deadline:
        # once: comparing deadline - start with SECONDS again would restart the window forever
        # whenever the subtraction rounds above SECONDS (1.2 s does)
        if take() and not windowed:
            windowed = True
            deadline = time.time() + seconds
        time.sleep(poll)


def force_command(stamp, state_seq, force):
    """An ActuatorForce command stamped STAMP answering state STATE_SEQ."""
    return T.ActuatorForce(header=T.Header(stamp=stamp, frame_id="odom"), state_seq=state_seq,
                           force=force)


def read_states(dp, n, timeout):
    return wait_for(reader(dp, "capsule/state", T.CapsuleState), lambda got: len(got) >= n,
                    timeout, 0.002)


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
    states = read_states(dp, args.samples, args.timeout)
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


class Pump:
    """Reads the plant's state every 5 ms and, while commanding, sends a command each time: the
    checks `force` and `joint-command` share."""

    def __init__(self, dp, also=lambda: None):
        self.reader = reader(dp, "capsule/state", T.CapsuleState)
        self.also = also  # called every round (other readers)
        self.latest = None

    def run(self, seconds, send=None):
        """The states that came in SECONDS s; SEND(latest state) every round once one came."""
        end = time.time() + seconds
        seen = []
        while time.time() < end:
            for s in valid(self.reader.take(N=64)):
                self.latest = s
                seen.append(s)
            self.also()
            if send is not None and self.latest is not None:
                send(self.latest)
            time.sleep(0.005)
        return seen

    def until(self, grown, seconds, send=None, timeout=5.0):
        """run(SECONDS, SEND), then on in steps of 0.1 s until GROWN(last state) holds, at most
        TIMEOUT s more (a loaded host may deliver late): the states seen."""
        seen = self.run(seconds, send)
        end = time.time() + timeout
        while not (seen and grown(seen[-1])) and time.time() < end:
            seen += self.run(0.1, send)
        return seen

    def first_state(self, w, timeout=15.0, match_timeout=5.0):
        """Reads for 1 s and until the first state, at most TIMEOUT s (discovery can take
        seconds on a loaded host), then until W matches a reader (a write before that is
        lost), at most MATCH_TIMEOUT s: no match is left to the checks that follow (a plant
        that does not take these commands may have no reader)."""
        deadline = time.time() + timeout
        self.run(1.0)
        while self.latest is None and time.time() < deadline:
            self.run(0.05)
        if self.latest is None:
            fail("no state from the plant")
        deadline = time.time() + match_timeout
        while w.get_publication_matched_status().current_count < 1 and time.time() < deadline:
            self.run(0.05)

    def applied(self, send, value, what):
        """Commands by SEND for 1 s; the states that show VALUE applied (at least 5, or fail
        naming WHAT)."""
        seen = self.run(1.0, send)
        applied = [s for s in seen if not s.command_stale and abs(s.actuator_force - value) < 1e-9]
        if len(applied) < 5:
            fail(f"plant did not apply {what}: last {[(s.actuator_force, s.command_stale) for s in seen[-5:]]}")
        return applied

    def refused(self, send, what):
        """Commands by SEND (non-finite) for 0.3 s, then 0.3 s of silence: the plant's refusal
        count must have grown and no non-finite force reached the simulation. Returns the
        counts before and after."""
        before = self.latest.rejected_commands
        seen = self.until(lambda s: s.rejected_commands > before, 0.3, send) + self.run(0.3)
        after = seen[-1].rejected_commands if seen else before
        if after <= before:
            fail(f"{what} not counted as refused ({before} -> {after})")
        if any(not math.isfinite(s.actuator_force) for s in seen):
            fail(f"{what} reached the simulation")
        return before, after

    def falls_back(self, seconds):
        """Silence for SECONDS: the watchdog must fall back to zero force and say so."""
        tail = self.run(seconds)[-3:]
        if not tail or not all(s.command_stale and s.actuator_force == 0.0 for s in tail):
            fail(f"no zero-force fallback after silence: {[(s.actuator_force, s.command_stale) for s in tail]}")


def cmd_force(args):
    dp = participant()
    pump = Pump(dp)
    w = writer(dp, "capsule/actuator_force", T.ActuatorForce)

    def send(force):
        return lambda s: w.write(force_command(s.header.stamp, s.seq, force))

    pump.first_state(w)
    applied = pump.applied(send(args.force), args.force, f"{args.force} N")
    # a late command (stamped before the last accepted one) must not take over
    last_ok = pump.latest.rejected_commands
    late = force_command(T.Time(sec=0, nanosec=1), 0, -args.force)
    resend_at = [time.time()]

    def send_and_late(st):
        # the late command, again every 0.5 s until its refusal shows (a write can be lost)
        if time.time() >= resend_at[0]:
            w.write(late)
            resend_at[0] = time.time() + 0.5
        send(args.force)(st)
    seen = pump.until(lambda st: st.rejected_commands > last_ok, 0.3, send_and_late)
    if seen[-1].rejected_commands <= last_ok:
        fail("a late (old-stamped) command was not refused")
    if any(abs(s.actuator_force + args.force) < 1e-12 for s in seen):
        fail("a late command was applied (time rewound)")
    before, after = pump.refused(send(float("nan")), "NaN commands")
    pump.falls_back(args.stale_wait)
    print(json.dumps({"applied_samples": len(applied), "refused_before": before, "refused_after": after,
                      "stale_fallback": True}))


def cmd_joint_command(args):
    dp = participant()
    js_reader = reader(dp, "joint_states", T.JointState)
    joint_states = []
    pump = Pump(dp, also=lambda: joint_states.extend(valid(js_reader.take(N=64))))
    w = writer(dp, "capsule/joint_commands", T.JointState)

    def send(names, efforts):
        def command(_):
            now = time.time()
            w.write(T.JointState(header=T.Header(stamp=T.Time(sec=int(now), nanosec=int((now % 1) * 1e9)), frame_id=""),
                                 name=names, position=[], velocity=[], effort=efforts))
        return command

    pump.first_state(w)
    f = args.effort
    # both joints named, as topic_based_ros2_control sends them when both have an effort
    # interface: the plant must pick inner_mass_joint's by name
    applied = pump.applied(send(["capsule_joint", "inner_mass_joint"], [9.0, f]), f,
                           f"the effort {f} N")
    efforts = [js.effort[list(js.name).index("inner_mass_joint")] for js in joint_states
               if "inner_mass_joint" in js.name and len(js.effort) == len(js.name)]
    if not any(abs(e - f) < 1e-9 for e in efforts):
        fail(f"joint_states never showed inner_mass_joint's effort {f} ({len(joint_states)} joint states, last efforts {efforts[-3:]})")
    before, after = pump.refused(send(["inner_mass_joint"], [float("nan")]), "NaN efforts")
    seen = pump.run(0.5, send(["wheel_joint"], [-f]))
    if any(abs(s.actuator_force + f) < 1e-12 for s in seen):
        fail("a command for another joint was applied")
    pump.falls_back(args.stale_wait)
    print(json.dumps({"applied_samples": len(applied), "joint_states_effort_seen": True,
                      "refused_before": before, "refused_after": after, "stale_fallback": True}))


def cmd_status(args):
    """Waits for a status with at least --periods complete periods and prints it."""
    dp = participant()
    got = wait_for(reader(dp, "capsule_controller/status", T.ControllerStatus),
                   lambda got: got and got[-1].periods >= args.periods, args.timeout, 0.01, n=16)
    last = got[-1] if got else None
    if last is None or last.periods < args.periods:
        fail(f"no status with {args.periods} periods within {args.timeout} s (last: {last})")
    print(json.dumps({k: getattr(last, k) for k in (
        "mode", "mode_name", "gain", "drive_amplitude", "drive_frequency", "commanding",
        "commands_sent", "periods", "progression_per_period", "progression_per_period_m",
        "mean_speed", "efficiency", "switch_state", "switch_tries", "orbit_period")} | {"stamp_s": last.header.stamp.sec + 1e-9 * last.header.stamp.nanosec}))


class ServiceClient:
    """Calls SERVICE in the rmw_cyclonedds request/reply mapping: the request again (with a new
    sequence number) after 0.5 s, then 1, 2 and every 4 s, until a reply to one of them comes,
    for at most TIMEOUT s. The first request's reply counts when it comes after the second was
    sent: on a loaded host it can, and a repeated transition is refused once taken (seen: an
    activation of 9 s, 18 repeats, whose burst of refusals pushed the first answer out of the
    reader's 16)."""

    def __init__(self, dp, service, req, resp, timeout):
        self.service = service.strip("/")
        self.req, self.timeout = req, timeout
        self.writer = DataWriter(dp, Topic(dp, f"rq/{self.service}Request", req), qos=RELIABLE)
        self.reader = DataReader(dp, Topic(dp, f"rr/{self.service}Reply", resp), qos=RELIABLE)
        self.guid = random.getrandbits(63)
        self.seq = 0

    def call_once(self, wait, **fields):
        """One request, sent at once (as a client that has just been made does), never again:
        the seconds its reply took, or None after WAIT s."""
        self.seq += 1
        t0 = time.time()
        self.writer.write(self.req(client_guid=self.guid, sequence=self.seq, **fields))
        while time.time() < t0 + wait:
            for r in valid(self.reader.take(N=16)):
                if r.client_guid == self.guid and r.sequence == self.seq:
                    return time.time() - t0
            time.sleep(0.002)
        return None

    def call(self, **fields):
        deadline = time.time() + self.timeout
        sent = set()
        wait = 0.5
        while time.time() < deadline:
            self.seq += 1
            sent.add(self.seq)
            self.writer.write(self.req(client_guid=self.guid, sequence=self.seq, **fields))
            end = min(deadline, time.time() + wait)
            wait = min(2 * wait, 4.0)
            while time.time() < end:
                for r in valid(self.reader.take(N=16)):
                    if r.client_guid == self.guid and r.sequence in sent:
                        return r
                time.sleep(0.005)
        fail(f"no /{self.service} reply within {self.timeout} s")


def cmd_set_mode(args):
    dp = participant()
    r = ServiceClient(dp, args.service, T.SetMode_Request, T.SetMode_Response, args.timeout).call(
        mode=args.mode, gain=args.gain, effective_from=T.Time(sec=0, nanosec=0),
        pulse_periods=args.pulse_periods, target_period=args.target_period,
        max_tries=args.max_tries)
    print(json.dumps({"accepted": r.accepted, "mode": r.mode, "gain": r.gain, "reason": r.reason}))


def cmd_inject(args):
    dp = participant()
    states = reader(dp, "capsule/state", T.CapsuleState)
    w = writer(dp, "capsule/actuator_force", T.ActuatorForce)
    deadline = time.time() + args.timeout
    got = wait_for(states, bool, args.timeout, 0.002)
    if not got:
        fail("no state from the plant")
    latest = got[-1]
    # the state came through, but our writer may not have matched the plant's reader yet: a
    # volatile write before that is lost (on a loaded host the single future-stamped command was)
    while w.get_publication_matched_status().current_count < 1:
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
                for s in valid(states.take(N=64)):
                    gaps += max(0, s.seq - latest.seq - 1)
                    received += 1
                    max_applied = max(max_applied, abs(s.actuator_force))
                    finite = finite and all(math.isfinite(getattr(s, k)) for k in (
                        "mass_position", "mass_velocity", "capsule_position", "capsule_velocity"))
                    latest = s
                stamp = latest.header.stamp if args.stamp_sec is None else T.Time(sec=args.stamp_sec, nanosec=0)
                cmd = force_command(stamp, latest.seq, force)
            w.write(cmd)
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
                for s in valid(states.take(N=64)):
                    received += 1
                    latest = s
                if time.time() >= resend_at:
                    w.write(cmd)
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


# what the plant cannot take on its force topic: the ActuatorForce name with another layout
FOREIGN_LAYOUT = idl_type("capsule_msgs/msg/ActuatorForce", "uint8 x", TYPES)


def cmd_foreign(args):
    dp = participant()
    ty, make = {"type": (T.String, lambda i: T.String(data=f"not a force {i}")),
                "layout": (FOREIGN_LAYOUT, lambda i: FOREIGN_LAYOUT(x=i % 256))}[args.kind]
    w = writer(dp, "capsule/actuator_force", ty)
    end = time.time() + args.seconds
    sent = 0
    while time.time() < end:
        w.write(make(sent))
        sent += 1
        time.sleep(0.001)
    print(json.dumps({"kind": args.kind, "sent": sent}))


class ParamClient:
    """Calls a node's rcl_interfaces parameter services (rmw_cyclonedds mapping)."""

    def __init__(self, dp, node, timeout):
        self.node = "/" + node.strip("/")
        self.services = {svc: ServiceClient(dp, f"{self.node}/{svc}", req, resp, timeout)
                         for svc, (req, resp) in PARAM_SRV.items()}

    def call(self, svc, **fields):
        return self.services[svc].call(**fields)

    def get(self, *names):
        return [pyvalue(v) for v in self.call("get_parameters", names=list(names)).values]

    def set(self, name, value):
        r = self.call("set_parameters", parameters=[T.Parameter(name=name, value=pvalue(value))])
        return r.results[0]


def take_events(r, node, wait, until=None, timeout=5.0):
    """NODE's parameter changes on /parameter_events for WAIT s and, with UNTIL, until one of
    them changes that parameter (at most TIMEOUT s: it can come late on a loaded host)."""
    start = time.time()
    out = []
    while time.time() < start + wait or (until is not None and not any(until in e for e in out)
                                         and time.time() < start + timeout):
        for e in valid(r.take(N=64)):
            if e.node == node:
                out.append({p.name: pyvalue(p.value) for p in e.changed_parameters})
        time.sleep(0.01)
    return out


def cmd_first_answers(args):
    """Fresh clients that send at once: the server must answer each first request (it waits
    for the client's reply reader to match before it answers, as rmw_cyclonedds does)."""
    dp = participant()
    req, resp = PARAM_SRV["list_parameters"]
    service = "/" + args.node.strip("/") + "/list_parameters"
    # one call to make sure the node is there before the counted clients come
    ServiceClient(dp, service, req, resp, args.timeout).call(prefixes=[], depth=0)
    took = []
    for _ in range(args.clients):
        c = ServiceClient(dp, service, req, resp, args.timeout)
        took.append(c.call_once(args.wait, prefixes=[], depth=0))
        del c
    answered = [t for t in took if t is not None]
    print(json.dumps({"clients": args.clients, "answered_first": len(answered),
                      "unanswered": [i for i, t in enumerate(took) if t is None],
                      "slowest_s": max(answered, default=None)}))


def cmd_params(args):
    """Lists, gets, describes, sets and refuses parameters of --node; checks /parameter_events.

    --set NAME=VALUE (a value that must be accepted; JSON-typed, e.g. 0.5, true, "FORWARD")
    --refuse NAME=VALUE (must be refused with a reason, nothing changed, no event)
    Prints one JSON line with what it saw."""
    dp = participant()
    events = reader(dp, "parameter_events", T.ParameterEvent, reliable(depth=1000))
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
    # the events reader must know the node's writer before the first set (at most --timeout s)
    deadline = time.time() + args.timeout
    while events.get_subscription_matched_status().current_count < 1 and time.time() < deadline:
        time.sleep(0.01)
    take_events(events, c.node, 0.3)  # drop what came before
    out["set"] = []
    for item in args.set:
        name, value = item.split("=", 1)
        value = json.loads(value)
        r = c.set(name, value)
        if not r.successful:
            fail(f"set {name}={value!r} refused: {r.reason}")
        after = c.get(name)[0]
        evs = take_events(events, c.node, 0.5, until=name)
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
                   parameters=[T.Parameter(name=name, value=pvalue(json.loads(value))),
                               T.Parameter(name="no_such", value=pvalue(1.0))]).result
        if r.successful:
            fail("set_parameters_atomically with an unknown name succeeded")
        out["atomic_refused"] = r.reason
    print(json.dumps(out))


def cmd_views(args):
    """Reads the plant's standard-type views beside rt/capsule/state and checks each against
    the state sample with the same stamp; --absent NAME... must stay silent. Prints JSON."""
    dp = participant()
    readers = {
        "state": reader(dp, "capsule/state", T.CapsuleState),
        "joint_states": reader(dp, "joint_states", T.JointState),
        "tf": reader(dp, "tf", T.TFMessage),
        "diagnostics": reader(dp, "diagnostics", T.DiagnosticArray),
        # latched: a late reader must get it
        "robot_description": reader(dp, "robot_description", T.String,
                                    reliable(Policy.Durability.TransientLocal, 1)),
    }
    got = {k: [] for k in readers}

    def take():
        for k, r in readers.items():
            got[k].extend(valid(r.take(N=256)))
        return bool(got["state"])

    # counted from the first state sample
    read_window(take, args.seconds, args.timeout, 0.005)
    if not got["state"]:
        fail(f"no state sample within {args.timeout} s")
    stamp = lambda h: (h.stamp.sec, h.stamp.nanosec)
    states = {stamp(s.header): s for s in got["state"]}
    out = {k: len(v) for k, v in got.items()}
    for name in args.absent:
        if got[name]:
            fail(f"{name} is switched off but {len(got[name])} messages came")

    def matched(view, header_of, check):
        """CHECK(message, the state sample of its stamp or None) on each message of VIEW; at
        least 10 must have a state sample. Returns how many had one."""
        n = 0
        for m in got[view]:
            s = states.get(stamp(header_of(m)))
            check(m, s)
            n += s is not None
        if n < 10:
            fail(f"only {n} {view} messages matched a state sample ({len(states)} states, "
                 f"{len(got[view])} {view}; first stamps {list(states)[:3]}, "
                 f"{[stamp(header_of(m)) for m in got[view][:3]]})")
        return n

    def joint_state(js, s):
        if list(js.name) != ["capsule_joint", "inner_mass_joint"]:
            fail(f"joint names {js.name}")
        if s is None:
            return
        want = ([s.capsule_position, s.mass_position - s.capsule_position],
                [s.capsule_velocity, s.mass_velocity - s.capsule_velocity],
                [s.friction_force, s.actuator_force])
        if (list(js.position), list(js.velocity), list(js.effort)) != want:
            fail(f"joint state {js} does not map state {s}")

    def tf(m, s):
        t = m.transforms[0]
        if (t.header.frame_id, t.child_frame_id) != ("odom", "capsule"):
            fail(f"tf {t.header.frame_id} -> {t.child_frame_id}")
        if s is None:
            return
        if t.transform.translation.x != s.capsule_position or t.transform.rotation.w != 1.0:
            fail(f"tf {t.transform} does not place the capsule of {s}")

    if "joint_states" not in args.absent:
        out["joint_states_matched"] = matched("joint_states", lambda js: js.header, joint_state)
    if "tf" not in args.absent:
        out["tf_matched"] = matched("tf", lambda m: m.transforms[0].header, tf)
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


def cmd_estop(args):
    """Engages the plant's emergency stop, as `ros2 service call ... std_srvs/srv/SetBool` would,
    reads the state for a second, joins the latched topic late, releases the stop and reads the
    state again; prints what it saw as JSON."""
    dp = participant()
    states = reader(dp, "capsule/state", T.CapsuleState, qos=reliable(depth=512))
    svc = ServiceClient(dp, args.service, T.SetBool_Request, T.SetBool_Response, args.timeout)

    def forces(seconds):
        got = []
        end = time.time() + seconds
        while time.time() < end:
            got.extend(abs(st.actuator_force) for st in valid(states.take(N=256)))
            time.sleep(0.005)
        return got

    before = forces(0.5)
    engaged = svc.call(data=True)
    during = forces(1.0)
    late = reader(dp, "capsule/emergency_stop", T.Bool,
                  qos=reliable(Policy.Durability.TransientLocal, 1))
    latched = None
    end = time.time() + args.timeout
    while latched is None and time.time() < end:
        for st in valid(late.take(N=4)):
            latched = st.data
        time.sleep(0.01)
    released = svc.call(data=False)
    after = forces(1.0)
    # samples published before the stop took effect may still be in flight: from the first zero
    zero_at = next((i for i, f in enumerate(during) if f == 0.0), None)
    print(json.dumps({
        "engaged": engaged.success, "engaged_message": engaged.message,
        "released": released.success, "released_message": released.message,
        "latched": latched,
        "max_force_before": max(before, default=None),
        "samples_until_zero": zero_at,
        "max_force_once_zero": max(during[zero_at:], default=None) if zero_at is not None else None,
        "samples_engaged": len(during),
        "max_force_after": max(after, default=None),
    }))


def cmd_lifecycle(args):
    """Drives --node through the transitions given, as `ros2 lifecycle set` would (the id
    looked up by label in get_available_transitions; an unknown label is sent with id 0, which
    the node must refuse); after each, the state and the forces on capsule/state."""
    dp = participant()
    node = args.node.rstrip("/")
    states = reader(dp, "capsule/state", T.CapsuleState, qos=reliable(depth=512))
    events = reader(dp, node.strip("/") + "/transition_event", T.TransitionEvent,
                    qos=reliable(depth=64))
    empty = dict(structure_needs_at_least_one_member=0)

    def client(name, ty):
        return ServiceClient(dp, f"{node}/{name}", getattr(T, ty + "_Request"),
                             getattr(T, ty + "_Response"), args.timeout)

    change = client("change_state", "ChangeState")
    get = client("get_state", "GetState")
    avail = client("get_available_transitions", "GetAvailableTransitions")
    all_states = client("get_available_states", "GetAvailableStates").call(**empty)
    graph = client("get_transition_graph", "GetAvailableTransitions").call(**empty)
    steps = []
    for label in args.transitions:
        before = get.call(**empty).current_state.label
        ids = {t.transition.label: t.transition.id
               for t in avail.call(**empty).available_transitions}
        t0 = time.time()
        r = change.call(transition=T.Transition(id=ids.get(label, 0), label=label))
        answered_s = time.time() - t0
        after = get.call(**empty).current_state.label
        valid(states.take(N=4096))
        seen = []
        end = time.time() + args.settle + args.window
        # NaN: a sample without a new measurement from the device (nobody measured what acted);
        # max() would keep a NaN that comes first
        def late():
            return [f for t, f in seen if t >= t0 + args.settle and not math.isnan(f)]
        # once active, the window is extended (up to --active-wait) until a force shows: a
        # device answered late gets zero for that sample (docs/hardware.md), and on a loaded
        # host every answer of a whole window can be late
        longest = t0 + args.settle + max(args.window, args.active_wait)
        while time.time() < end or (after == "active" and time.time() < longest
                                    and max(late(), default=0.0) <= 0.01):
            now = time.time()
            seen.extend((now, abs(st.actuator_force)) for st in valid(states.take(N=256)))
            time.sleep(0.005)
        late = late()
        steps.append({"transition": label, "success": r.success, "before": before,
                      "after": after, "answered_s": answered_s, "samples": len(late),
                      "max_force": max(late, default=None)})
    got = []
    end = time.time() + 0.5
    while time.time() < end:
        got.extend(valid(events.take(N=64)))
        time.sleep(0.01)
    print(json.dumps({
        "steps": steps,
        "events": [[e.transition.id, e.start_state.label, e.goal_state.label] for e in got],
        "available_states": len(all_states.available_states),
        "graph": len(graph.available_transitions),
    }))


def cmd_estop_time(args):
    """The emergency stop's answer time as a client sees it: a warm-up call (release), then
    REPEAT times engage and release, each timed from the request's write to its reply; prints
    the wall clock of each engage (ns since the epoch) for the device's force log."""
    dp = participant()
    svc = ServiceClient(dp, args.service, T.SetBool_Request, T.SetBool_Response, args.timeout)
    svc.call(data=False)
    calls = []
    for _ in range(args.repeat):
        time.sleep(args.gap)
        t0 = time.time_ns()
        r = svc.call(data=True)
        t1 = time.time_ns()
        calls.append({"sent_ns": t0, "answer_ms": (t1 - t0) * 1e-6, "success": r.success})
        time.sleep(args.gap)
        svc.call(data=False)
    print(json.dumps({"estop": calls}))


def cmd_diagnostics(args):
    """Reads /diagnostics for --seconds (counted from the first array) and prints the last
    status of each --name (a node's statuses are named "NODE: ..."); fails if one is missing."""
    dp = participant()
    r = reader(dp, "diagnostics", T.DiagnosticArray)
    got = []

    def take():
        got.extend(valid(r.take(N=64)))
        return bool(got)

    read_window(take, args.seconds, args.timeout, 0.02)
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


def options(parser, type, help=None, **defaults):
    """Adds --NAME options of TYPE with their defaults (NAME's '_' spelt '-'); returns PARSER."""
    for name, default in defaults.items():
        parser.add_argument("--" + name.replace("_", "-"), type=type, default=default, help=help)
    return parser


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    options(options(sub.add_parser("state"), int, samples=50), float, timeout=15.0)
    options(sub.add_parser("force"), float, force=0.123, stale_wait=1.5)
    options(sub.add_parser("joint-command"), float, effort=0.123, stale_wait=1.5)
    options(options(sub.add_parser("status"), int, periods=10), float, timeout=60.0)
    a = sub.add_parser("set-mode")
    a.add_argument("mode", type=int)
    a.add_argument("gain", type=float)
    options(a, int, "SWITCH_ATTRACTOR (mode 5) only", pulse_periods=0, target_period=0, max_tries=0)
    options(a, str, service="/capsule_controller/set_mode")
    options(a, float, timeout=15.0)
    a = sub.add_parser("inject")
    a.add_argument("--force", required=True, help="F, or F1,F2,... one phase each")
    options(a, float, "per phase", seconds=1.0)
    options(a, float, hz=1000.0, timeout=15.0)
    options(a, int, stamp_sec=None)
    options(a, int, "per phase, states received at least", min_states=0)
    a.add_argument("--until-refused", action="store_true",
                   help="resend until a state shows the plant refused the command")
    a = sub.add_parser("foreign")
    a.add_argument("--kind", choices=["type", "layout"], required=True)
    options(a, float, seconds=1.0)
    a = sub.add_parser("params")
    a.add_argument("--node", default="/capsule_controller")
    for name in ("--set", "--refuse"):
        a.add_argument(name, action="append", default=[], metavar="NAME=JSON")
    options(a, float, timeout=15.0)
    a = sub.add_parser("first-answers")
    a.add_argument("--node", default="/capsule_controller")
    options(a, int, clients=20)
    options(a, float, "per client", wait=2.0)
    options(a, float, timeout=15.0)
    a = sub.add_parser("estop")
    options(a, str, service="/capsule_plant/emergency_stop")
    options(a, float, timeout=15.0)
    a = sub.add_parser("lifecycle")
    a.add_argument("transitions", nargs="+")
    options(a, str, node="/capsule_plant")
    options(a, float, settle=0.3, window=0.7, active_wait=3.0, timeout=15.0)
    a = sub.add_parser("estop-time")
    options(a, str, service="/capsule_plant/emergency_stop")
    options(a, int, repeat=5)
    options(a, float, gap=0.3, timeout=15.0)
    a = sub.add_parser("diagnostics")
    a.add_argument("--name", nargs="+", required=True)
    options(a, float, seconds=2.5, timeout=30.0)
    a = options(sub.add_parser("views"), float, seconds=3.0, timeout=30.0)
    a.add_argument("--absent", nargs="*", default=[])
    args = p.parse_args()
    {"state": cmd_state, "force": cmd_force, "status": cmd_status, "set-mode": cmd_set_mode,
     "inject": cmd_inject, "foreign": cmd_foreign, "params": cmd_params, "views": cmd_views,
     "diagnostics": cmd_diagnostics, "estop": cmd_estop, "joint-command": cmd_joint_command,
     "lifecycle": cmd_lifecycle, "estop-time": cmd_estop_time,
     "first-answers": cmd_first_answers}[args.cmd](args)


if __name__ == "__main__":
    main()
