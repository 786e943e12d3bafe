#!/usr/bin/env python3
"""An rmw_zenoh speaker, independent of ros2-client: PyPI's `eclipse-zenoh` and this file,
written from rmw_zenoh's design document (docs/design.md of ros2/rmw_zenoh), as an
rmw_zenoh_cpp node sees the capsule graph:

- the graph is liveliness tokens under `@ros2_lv/<domain>/`:
  `@ros2_lv/<domain>/<session id>/<node id>/<entity id>/<kind>/<enclave>/<namespace>/<node>`
  for a node (kind NN), followed by `/<topic>/<type>/<type hash>/<qos>` for a publisher (MP),
  subscription (MS), service server (SS) or client (SC); `/` in a name written as `%`, an empty
  namespace or enclave as `%`;
- data travels on `<domain>/<topic without its leading />/<DDS type name>/<type hash>`; a
  subscriber or client uses the hash its own type support computes (given here with --hash:
  rosidl's, from the interface files), so a publisher or server announcing another hash is
  never heard;
- a sample, request or reply carries CDR (little-endian XCDR1 with its 4-octet encapsulation
  header) and an attachment: sequence number (int64), source timestamp (int64, ns), source
  GID (16 octets, written as a length-prefixed sequence: 0x10 then the octets), in Zenoh's
  serialization (little-endian, LEB128 lengths);
- a service call is a Zenoh query on the service's key with the request as payload and the
  attachment; the reply carries the response.

Usage (inside a loopback-only network namespace, with a Zenoh router on 127.0.0.1:7447):
  zenoh_peer.py graph --node NAME... [--topic T...] [--timeout S]
                                                     wait until these nodes and topics are
                                                     announced, print every entity as a JSON
                                                     line
  zenoh_peer.py state --hash H [--samples N]         read /capsule/state, print JSON
  zenoh_peer.py set-mode MODE GAIN --hash H --status-hash S
                                                     call /capsule_controller/set_mode, print
                                                     the answer, then wait for the status to
                                                     show the mode
  zenoh_peer.py move DISTANCE --send-goal-hash H --get-result-hash H --feedback-hash H
                --status-hash H --cancel-hash H [--cancel-after S]
                                                     send a goal to /capsule_controller/move
                                                     (an action is the services
                                                     _action/send_goal, get_result, cancel_goal
                                                     and the topics _action/feedback, status),
                                                     print its end, feedback and statuses
  zenoh_peer.py estop --state-hash H --flag-hash H [--hold S] [--send-goal-hash H]
                                                     while the controller commands: engage
                                                     /capsule_plant/emergency_stop (SetBool
                                                     true; its hash the one its token
                                                     announces), watch the state's force and
                                                     the latched /capsule/emergency_stop,
                                                     (with --send-goal-hash: a Move goal sent
                                                     while engaged), release it, print JSON
  zenoh_peer.py resume --state-hash H [--hold S]      a lock-step plant started paused: read
                                                     the states it re-sends, resume it
                                                     (/capsule_plant/pause, SetBool false),
                                                     read on, print the sequence numbers seen
  zenoh_peer.py lifecycle --event-hash H [--node /NS/NAME] [--transition ID...]
                                                     a managed node: get_state, then each
                                                     transition through change_state with
                                                     get_state after it, the available states
                                                     and transitions at the end, the
                                                     transition_event topic all along; the
                                                     services' hashes the ones their tokens
                                                     announce; print JSON
  zenoh_peer.py params --node /NS/NAME [--get NAME...] [--set NAME=JSON...]
                                                     call the node's get_parameters with the
                                                     names, then set_parameters once per --set;
                                                     the services' hashes are the ones their
                                                     liveliness tokens announce; print JSON
"""

import argparse
import json
import math
import os
import struct
import sys
import time

import zenoh

ROUTER = "tcp/127.0.0.1:7447"
DOMAIN = 0
STATE_TYPE = "capsule_msgs::msg::dds_::CapsuleState_"
STATUS_TYPE = "capsule_msgs::msg::dds_::ControllerStatus_"
SET_MODE_TYPE = "capsule_msgs::srv::dds_::SetMode_"
MOVE = "capsule_controller/move/_action"
MOVE_TYPE = "capsule_msgs::action::dds_::Move"
STATUS_NAMES = {0: "UNKNOWN", 1: "ACCEPTED", 2: "EXECUTING", 3: "CANCELING", 4: "SUCCEEDED",
                5: "CANCELED", 6: "ABORTED"}


def fail(why):
    print(f"zenoh_peer: {why}", file=sys.stderr)
    sys.exit(1)


def open_session():
    """A client of the router on loopback, no multicast scouting."""
    conf = zenoh.Config()
    conf.insert_json5("mode", '"client"')
    conf.insert_json5("connect/endpoints", json.dumps([ROUTER]))
    conf.insert_json5("scouting/multicast/enabled", "false")
    return zenoh.open(conf)


def demangle(part):
    return "/" if part == "%" else part.replace("%", "/")


def parse_token(key):
    """An entity from its liveliness token (None for anything else)."""
    parts = key.split("/")
    if len(parts) < 9 or parts[0] != "@ros2_lv":
        return None
    entity = {
        "kind": parts[5],
        "namespace": demangle(parts[7]),
        "node": parts[8],
    }
    if len(parts) >= 13:
        entity.update(topic=demangle(parts[9]), type=parts[10], hash=parts[11], qos=parts[12])
    return entity


def graph(session, nodes, topics, timeout):
    deadline = time.monotonic() + timeout
    while True:
        entities = []
        for reply in session.liveliness().get(f"@ros2_lv/{DOMAIN}/**", timeout=2.0):
            if reply.ok is not None:
                e = parse_token(str(reply.ok.key_expr))
                if e is not None:
                    entities.append(e)
        seen = {e["node"] for e in entities if e["kind"] == "NN"}
        seen_topics = {e.get("topic") for e in entities}
        if all(n in seen for n in nodes) and all(t in seen_topics for t in topics):
            break
        if time.monotonic() > deadline:
            break
        time.sleep(0.2)
    for e in sorted(entities, key=lambda e: json.dumps(e, sort_keys=True)):
        print(json.dumps(e, sort_keys=True))
    missing = [n for n in nodes if n not in seen] + [t for t in topics if t not in seen_topics]
    if missing:
        fail(f"nodes or topics not announced within {timeout} s: {missing}")


class Cdr:
    """Little-endian XCDR1 reader (alignment counted after the encapsulation header)."""

    def __init__(self, data):
        if len(data) < 4 or data[:2] != b"\x00\x01":
            raise ValueError(f"not little-endian CDR: {data[:4].hex()}")
        self.data, self.pos = data[4:], 0

    def take(self, fmt, size):
        self.pos += (-self.pos) % size
        (value,) = struct.unpack_from("<" + fmt, self.data, self.pos)
        self.pos += size
        return value

    def string(self):
        n = self.take("I", 4)
        raw = self.data[self.pos : self.pos + n]
        self.pos += n
        return raw.rstrip(b"\x00").decode()

    def header(self):
        sec, nanosec = self.take("i", 4), self.take("I", 4)
        return {"sec": sec, "nanosec": nanosec, "frame_id": self.string()}


def attachment(data):
    """The attachment's sequence number, source timestamp and GID."""
    seq, stamp = struct.unpack_from("<qq", data, 0)
    if len(data) != 33 or data[16] != 16:
        raise ValueError(f"attachment of {len(data)} octets: {data.hex()}")
    return seq, stamp, data[17:33].hex()


def decode_state(payload):
    r = Cdr(payload)
    s = {"header": r.header(), "seq": r.take("Q", 8)}
    for f in ["mass_position", "mass_velocity", "capsule_position", "capsule_velocity"]:
        s[f] = r.take("d", 8)
    s["in_contact"], s["stuck"] = bool(r.take("B", 1)), bool(r.take("B", 1))
    for f in ["friction_force", "contact_force", "actuator_force"]:
        s[f] = r.take("d", 8)
    s["command_stale"], s["rejected_commands"] = bool(r.take("B", 1)), r.take("I", 4)
    return s


def state(session, type_hash, samples, timeout):
    key = f"{DOMAIN}/capsule/state/{STATE_TYPE}/{type_hash}"
    sub = session.declare_subscriber(key)
    got, deadline = [], time.monotonic() + timeout
    while len(got) < samples and time.monotonic() < deadline:
        sample = sub.try_recv()
        if sample is None:
            time.sleep(0.002)
            continue
        att = attachment(sample.attachment.to_bytes())
        got.append((decode_state(sample.payload.to_bytes()), att))
    if len(got) < samples:
        fail(f"{len(got)} of {samples} states on {key} within {timeout} s")
    seqs = [s["seq"] for s, _ in got]
    att_seqs = [a[0] for _, a in got]
    stamps = [s["header"]["sec"] + s["header"]["nanosec"] * 1e-9 for s, _ in got]
    span = stamps[-1] - stamps[0]
    finite = all(math.isfinite(s[f]) for s, _ in got for f in ["mass_position", "capsule_position"])
    print(json.dumps({
        "samples": len(got),
        "seq_increasing": all(b > a for a, b in zip(seqs, seqs[1:])),
        "attachment_seq_increasing": all(b > a for a, b in zip(att_seqs, att_seqs[1:])),
        "gids": len({a[2] for _, a in got}),
        "rate_hz": (len(got) - 1) / span if span > 0 else None,
        "finite": finite,
        "frame_id": got[-1][0]["header"]["frame_id"],
        "last": got[-1][0],
    }))


def encode_set_mode(mode, gain):
    # uint8 mode, float64 gain (aligned to 8), Time effective_from, 3 x int32
    body = struct.pack("<B7xdiIiii", mode, gain, 0, 0, 0, 0, 0)
    return b"\x00\x01\x00\x00" + body


def request_attachment(seq):
    gid = bytes(range(16))
    return struct.pack("<qq", seq, time.time_ns()) + bytes([16]) + gid


def set_mode(session, mode, gain, type_hash, status_hash, timeout):
    status_key = f"{DOMAIN}/capsule_controller/status/{STATUS_TYPE}/{status_hash}"
    statuses = session.declare_subscriber(status_key)
    key = f"{DOMAIN}/capsule_controller/set_mode/{SET_MODE_TYPE}/{type_hash}"
    answer = None
    for reply in session.get(key, payload=encode_set_mode(mode, gain),
                             attachment=request_attachment(1), timeout=timeout):
        if reply.ok is None:
            fail(f"set_mode on {key}: error reply {reply.err.payload.to_bytes()!r}")
        r = Cdr(reply.ok.payload.to_bytes())
        accepted, got_mode = bool(r.take("B", 1)), r.take("B", 1)
        answer = {"accepted": accepted, "mode": got_mode, "gain": r.take("d", 8),
                  "reason": r.string()}
        seq = attachment(reply.ok.attachment.to_bytes())[0]
        answer["attachment_seq"] = seq
    if answer is None:
        fail(f"set_mode on {key}: no reply within {timeout} s (no server with this hash?)")
    print(json.dumps(answer))
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        sample = statuses.try_recv()
        if sample is None:
            time.sleep(0.005)
            continue
        r = Cdr(sample.payload.to_bytes())
        r.header()
        status = {"status_mode": r.take("B", 1), "mode_name": r.string(), "gain": r.take("d", 8)}
        if status["status_mode"] == mode:
            print(json.dumps(status))
            return
    fail(f"no status on {status_key} showing mode {mode} within {timeout} s")


def call(session, key, payload, seq, timeout):
    """A service call: the reply's payload as a CDR reader (fails on none or an error)."""
    got = None
    for reply in session.get(key, payload=b"\x00\x01\x00\x00" + payload,
                             attachment=request_attachment(seq), timeout=timeout):
        if reply.ok is None:
            fail(f"{key}: error reply {reply.err.payload.to_bytes()!r}")
        got = Cdr(reply.ok.payload.to_bytes())
    if got is None:
        fail(f"{key}: no reply within {timeout} s (no server with this hash?)")
    return got


def goal_statuses(payload):
    """action_msgs/GoalStatusArray: [(goal id, status)]."""
    r = Cdr(payload)
    out = []
    for _ in range(r.take("I", 4)):
        goal_id = bytes(r.data[r.pos : r.pos + 16])
        r.pos += 16
        r.take("i", 4), r.take("I", 4)
        out.append((goal_id, r.take("b", 1)))
    return out


def move(session, distance, a):
    """A Move goal over the action's services and topics, as rmw_zenoh_cpp's client sends it."""
    goal_id = os.urandom(16)
    feedback, statuses = [], []

    def on_feedback(sample):
        r = Cdr(sample.payload.to_bytes())
        if bytes(r.data[:16]) == goal_id:
            r.pos = 16
            fb = [r.take("d", 8) for _ in range(3)] + [r.take("B", 1)]
            feedback.append((time.monotonic(), fb))

    def on_status(sample):
        for gid, st in goal_statuses(sample.payload.to_bytes()):
            if gid == goal_id and (not statuses or statuses[-1] != st):
                statuses.append(st)

    subs = [
        session.declare_subscriber(
            f"{DOMAIN}/{MOVE}/feedback/{MOVE_TYPE}_FeedbackMessage_/{a.feedback_hash}", on_feedback),
        session.declare_subscriber(
            f"{DOMAIN}/{MOVE}/status/action_msgs::msg::dds_::GoalStatusArray_/{a.status_hash}",
            on_status),
    ]
    time.sleep(0.3)  # the subscriptions reach the router before the goal
    r = call(session, f"{DOMAIN}/{MOVE}/send_goal/{MOVE_TYPE}_SendGoal_/{a.send_goal_hash}",
             goal_id + struct.pack("<ddd", distance, 0.0, 0.0), 1, a.timeout)
    accepted = bool(r.take("B", 1))
    if not accepted:
        print(json.dumps({"distance": distance, "accepted": False}))
        return
    out = {"distance": distance, "accepted": True}
    if a.cancel_after is not None:
        time.sleep(a.cancel_after)
        r = call(session, f"{DOMAIN}/{MOVE}/cancel_goal/action_msgs::srv::dds_::CancelGoal_/"
                 f"{a.cancel_hash}", goal_id + struct.pack("<iI", 0, 0), 2, a.timeout)
        out["cancel_code"] = r.take("b", 1)
        canceling = []
        for _ in range(r.take("I", 4)):
            canceling.append(bytes(r.data[r.pos : r.pos + 16]))
            r.pos += 16
            r.take("i", 4), r.take("I", 4)
        out["canceling_ours"] = canceling == [goal_id]
    r = call(session, f"{DOMAIN}/{MOVE}/get_result/{MOVE_TYPE}_GetResult_/{a.get_result_hash}",
             goal_id, 3, 120.0)
    status = r.take("b", 1)
    out.update(status=STATUS_NAMES.get(status, status), reached=bool(r.take("B", 1)),
               travelled_m=r.take("d", 8), error_m=r.take("d", 8), elapsed_s=r.take("d", 8),
               message=r.string())
    time.sleep(0.3)  # the last status
    times = [t for t, _ in feedback]
    out.update(feedback=len(feedback),
               feedback_hz=(len(times) - 1) / (times[-1] - times[0]) if len(times) > 1 else 0.0,
               last_feedback=feedback[-1][1] if feedback else None,
               statuses=[STATUS_NAMES.get(s, s) for s in statuses])
    del subs
    print(json.dumps(out))


class CdrOut:
    """Little-endian XCDR1 writer (alignment counted after the encapsulation header)."""

    def __init__(self):
        self.data = bytearray()

    def put(self, fmt, size, value):
        self.data += b"\x00" * ((-len(self.data)) % size)
        self.data += struct.pack("<" + fmt, value)

    def string(self, text):
        raw = text.encode() + b"\x00"
        self.put("I", 4, len(raw))
        self.data += raw


# rcl_interfaces/msg/ParameterType
PARAM_TYPES = {0: "NOT_SET", 1: "bool", 2: "integer", 3: "double", 4: "string"}


def put_value(w, value):
    """rcl_interfaces/msg/ParameterValue of a JSON value (bool, integer, double or string)."""
    kind = (1 if isinstance(value, bool) else 2 if isinstance(value, int)
            else 3 if isinstance(value, float) else 4)
    w.put("B", 1, kind)
    w.put("B", 1, value if kind == 1 else False)
    w.put("q", 8, value if kind == 2 else 0)
    w.put("d", 8, value if kind == 3 else 0.0)
    w.string(value if kind == 4 else "")
    for _ in range(5):  # byte, bool, integer, double and string arrays: empty
        w.put("I", 4, 0)


def take_value(r):
    """rcl_interfaces/msg/ParameterValue: its value (None for NOT_SET or an array)."""
    kind, b, i, d, text = r.take("B", 1), r.take("B", 1), r.take("q", 8), r.take("d", 8), r.string()
    arrays = []
    for size, fmt in [(1, "B"), (1, "B"), (8, "q"), (8, "d")]:
        n = r.take("I", 4)
        arrays.append([r.take(fmt, size) for _ in range(n)])
    for _ in range(r.take("I", 4)):
        r.string()
    return {1: bool(b), 2: i, 3: d, 4: text}.get(kind)


def service_hash(session, service, dds_type, timeout):
    """The hash the server of `service` announces in its liveliness token."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        for reply in session.liveliness().get(f"@ros2_lv/{DOMAIN}/**", timeout=2.0):
            if reply.ok is not None:
                e = parse_token(str(reply.ok.key_expr))
                if e and e["kind"] == "SS" and e.get("topic") == service and e["type"] == dds_type:
                    return e["hash"]
        time.sleep(0.2)
    fail(f"no server of {service} ({dds_type}) announced within {timeout} s")


def params(session, a):
    node = a.node.strip("/")
    out = {"node": a.node, "hashes": {}}
    seq = 10

    def key(service, ty):
        dds_type = f"rcl_interfaces::srv::dds_::{ty}_"
        h = service_hash(session, f"/{node}/{service}", dds_type, a.timeout)
        out["hashes"][ty] = h
        return f"{DOMAIN}/{node}/{service}/{dds_type}/{h}"

    get_key = key("get_parameters", "GetParameters")
    w = CdrOut()
    w.put("I", 4, len(a.get))
    for name in a.get:
        w.string(name)
    seq += 1
    r = call(session, get_key, bytes(w.data), seq, a.timeout)
    values = [take_value(r) for _ in range(r.take("I", 4))]
    out["values"] = dict(zip(a.get, values))
    set_key = key("set_parameters", "SetParameters")
    out["set"] = []
    for item in a.set:
        name, value = item.split("=", 1)
        value = json.loads(value)
        w = CdrOut()
        w.put("I", 4, 1)
        w.string(name)
        put_value(w, value)
        seq += 1
        r = call(session, set_key, bytes(w.data), seq, a.timeout)
        results = [(bool(r.take("B", 1)), r.string()) for _ in range(r.take("I", 4))]
        w = CdrOut()
        w.put("I", 4, 1)
        w.string(name)
        seq += 1
        r = call(session, get_key, bytes(w.data), seq, a.timeout)
        now = take_value(r) if r.take("I", 4) == 1 else None
        for ok, reason in results:
            out["set"].append({"name": name, "value": value, "successful": ok, "reason": reason,
                               "now": now})
    print(json.dumps(out))


def set_bool(session, key, data, seq, timeout):
    """std_srvs/SetBool: (answer's success, message, seconds the call took)."""
    started = time.monotonic()
    r = call(session, key, struct.pack("<B", 1 if data else 0), seq, timeout)
    return bool(r.take("B", 1)), r.string(), time.monotonic() - started


def estop(session, a):
    """Engage the plant's emergency stop while the controller commands, release it.

    Every state is kept with the time it arrived; the stop promises zero force from the
    plant's next sample on, so the states arriving from 50 ms after the answer until the
    release must all carry zero force, and some before the engage and after the release not.
    """
    states, flags = [], []

    def on_state(sample):
        states.append((time.monotonic(), decode_state(sample.payload.to_bytes())["actuator_force"]))

    def on_flag(sample):
        r = Cdr(sample.payload.to_bytes())
        flags.append(bool(r.take("B", 1)))

    subs = [
        session.declare_subscriber(f"{DOMAIN}/capsule/state/{STATE_TYPE}/{a.state_hash}",
                                   on_state),
        session.declare_subscriber(
            f"{DOMAIN}/capsule/emergency_stop/std_msgs::msg::dds_::Bool_/{a.flag_hash}", on_flag),
    ]
    service = "/capsule_plant/emergency_stop"
    dds_type = "std_srvs::srv::dds_::SetBool_"
    key = f"{DOMAIN}{service}/{dds_type}/{service_hash(session, service, dds_type, a.timeout)}"
    time.sleep(a.hold)  # the controller commands meanwhile
    ok, said, took = set_bool(session, key, True, 21, a.timeout)
    engaged_at = time.monotonic()
    out = {"engage": {"success": ok, "message": said, "took_s": took}}
    if a.send_goal_hash:
        time.sleep(0.2)  # the controller's reader has the flag
        r = call(session, f"{DOMAIN}/{MOVE}/send_goal/{MOVE_TYPE}_SendGoal_/{a.send_goal_hash}",
                 os.urandom(16) + struct.pack("<ddd", 0.01, 0.0, 0.0), 23, a.timeout)
        out["goal_accepted_while_engaged"] = bool(r.take("B", 1))
    time.sleep(a.hold)
    ok, said, took = set_bool(session, key, False, 22, a.timeout)
    released_at = time.monotonic()
    out["release"] = {"success": ok, "message": said, "took_s": took}
    time.sleep(a.hold)
    del subs
    before = [f for t, f in states if t < engaged_at - took]
    held = [f for t, f in states if engaged_at + 0.05 <= t < released_at - took]
    after = [f for t, f in states if t >= released_at + 0.05]
    out.update(
        states_before=len(before), nonzero_before=sum(f != 0.0 for f in before),
        states_held=len(held), nonzero_held=sum(f != 0.0 for f in held),
        states_after=len(after), nonzero_after=sum(f != 0.0 for f in after),
        flags=flags)
    print(json.dumps({"estop": out}))


def resume(session, a):
    """A paused lock-step plant re-sends its sample and takes no step until resumed."""
    seqs = []

    def on_state(sample):
        seqs.append((time.monotonic(), decode_state(sample.payload.to_bytes())["seq"]))

    sub = session.declare_subscriber(f"{DOMAIN}/capsule/state/{STATE_TYPE}/{a.state_hash}",
                                     on_state)
    service = "/capsule_plant/pause"
    dds_type = "std_srvs::srv::dds_::SetBool_"
    key = f"{DOMAIN}{service}/{dds_type}/{service_hash(session, service, dds_type, a.timeout)}"
    time.sleep(a.hold)
    ok, said, took = set_bool(session, key, False, 31, a.timeout)
    resumed_at = time.monotonic() - took
    time.sleep(a.hold)
    del sub
    paused = sorted({s for t, s in seqs if t < resumed_at})
    after = [s for t, s in seqs if t >= resumed_at]
    print(json.dumps({"resume": {"success": ok, "message": said, "seqs_paused": paused,
                                 "states_paused": sum(t < resumed_at for t, _ in seqs),
                                 "last_seq": max(after, default=None)}}))


def take_lifecycle_state(r):
    """lifecycle_msgs/State (or Transition): [id, label]."""
    return [r.take("B", 1), r.string()]


def lifecycle(session, a):
    """Drive a managed node through `a.transition` as `ros2 lifecycle set` does."""
    node = a.node.strip("/")
    events = []

    def on_event(sample):
        r = Cdr(sample.payload.to_bytes())
        r.take("Q", 8)
        events.append([take_lifecycle_state(r)[0], take_lifecycle_state(r)[0],
                       take_lifecycle_state(r)[0]])

    sub = session.declare_subscriber(
        f"{DOMAIN}/{node}/transition_event/lifecycle_msgs::msg::dds_::TransitionEvent_/"
        f"{a.event_hash}", on_event)
    keys = {}
    for service, ty in [("get_state", "GetState"), ("change_state", "ChangeState"),
                        ("get_available_states", "GetAvailableStates"),
                        ("get_available_transitions", "GetAvailableTransitions")]:
        dds_type = f"lifecycle_msgs::srv::dds_::{ty}_"
        h = service_hash(session, f"/{node}/{service}", dds_type, a.timeout)
        keys[service] = f"{DOMAIN}/{node}/{service}/{dds_type}/{h}"
    time.sleep(0.3)  # the subscription reaches the router before the first transition
    seq = 40

    def get_state():
        nonlocal seq
        seq += 1
        return take_lifecycle_state(call(session, keys["get_state"], b"\x00", seq, a.timeout))

    out = {"lifecycle": {"first": get_state(), "steps": []}}
    for transition in a.transition:
        w = CdrOut()
        w.put("B", 1, transition)
        w.string("")
        seq += 1
        r = call(session, keys["change_state"], bytes(w.data), seq, a.timeout)
        out["lifecycle"]["steps"].append({"transition": transition,
                                          "success": bool(r.take("B", 1)),
                                          "state": get_state()})
    seq += 1
    r = call(session, keys["get_available_states"], b"\x00", seq, a.timeout)
    out["lifecycle"]["available_states"] = [take_lifecycle_state(r)[0]
                                            for _ in range(r.take("I", 4))]
    seq += 1
    r = call(session, keys["get_available_transitions"], b"\x00", seq, a.timeout)
    found = []
    for _ in range(r.take("I", 4)):
        found.append([take_lifecycle_state(r)[0] for _ in range(3)])
    out["lifecycle"]["available_transitions"] = found
    time.sleep(0.3)  # the last events
    del sub
    out["lifecycle"]["events"] = events
    print(json.dumps(out))


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    g = sub.add_parser("graph")
    g.add_argument("--node", action="append", default=[])
    g.add_argument("--topic", action="append", default=[])
    g.add_argument("--timeout", type=float, default=15.0)
    s = sub.add_parser("state")
    s.add_argument("--hash", required=True)
    s.add_argument("--samples", type=int, default=200)
    s.add_argument("--timeout", type=float, default=15.0)
    m = sub.add_parser("set-mode")
    m.add_argument("mode", type=int)
    m.add_argument("gain", type=float)
    m.add_argument("--hash", required=True)
    m.add_argument("--status-hash", required=True)
    m.add_argument("--timeout", type=float, default=10.0)
    mv = sub.add_parser("move")
    mv.add_argument("distance", type=float)
    for h in ["send-goal", "get-result", "feedback", "status", "cancel"]:
        mv.add_argument(f"--{h}-hash", required=True)
    mv.add_argument("--cancel-after", type=float)
    mv.add_argument("--timeout", type=float, default=10.0)
    es = sub.add_parser("estop")
    es.add_argument("--state-hash", required=True)
    es.add_argument("--flag-hash", required=True)
    es.add_argument("--hold", type=float, default=0.5)
    es.add_argument("--send-goal-hash")
    es.add_argument("--timeout", type=float, default=10.0)
    rs = sub.add_parser("resume")
    rs.add_argument("--state-hash", required=True)
    rs.add_argument("--hold", type=float, default=0.5)
    rs.add_argument("--timeout", type=float, default=10.0)
    lc = sub.add_parser("lifecycle")
    lc.add_argument("--event-hash", required=True)
    lc.add_argument("--node", default="/capsule_plant")
    lc.add_argument("--transition", type=int, action="append", default=[])
    lc.add_argument("--timeout", type=float, default=10.0)
    pa = sub.add_parser("params")
    pa.add_argument("--node", required=True)
    pa.add_argument("--get", action="append", default=[])
    pa.add_argument("--set", action="append", default=[])
    pa.add_argument("--timeout", type=float, default=10.0)
    a = p.parse_args()
    with open_session() as session:
        if a.cmd == "graph":
            graph(session, a.node, a.topic, a.timeout)
        elif a.cmd == "state":
            state(session, a.hash, a.samples, a.timeout)
        elif a.cmd == "params":
            params(session, a)
        elif a.cmd == "estop":
            estop(session, a)
        elif a.cmd == "lifecycle":
            lifecycle(session, a)
        elif a.cmd == "resume":
            resume(session, a)
        elif a.cmd == "move":
            move(session, a.distance, a)
        else:
            set_mode(session, a.mode, a.gain, a.hash, a.status_hash, a.timeout)


if __name__ == "__main__":
    main()
