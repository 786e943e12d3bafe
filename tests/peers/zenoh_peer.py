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
  zenoh_peer.py graph --node NAME... [--timeout S]   wait until these nodes are announced,
                                                     print every entity as a JSON line
  zenoh_peer.py state --hash H [--samples N]         read /capsule/state, print JSON
  zenoh_peer.py set-mode MODE GAIN --hash H --status-hash S
                                                     call /capsule_controller/set_mode, print
                                                     the answer, then wait for the status to
                                                     show the mode
"""

import argparse
import json
import math
import struct
import sys
import time

import zenoh

ROUTER = "tcp/127.0.0.1:7447"
DOMAIN = 0
STATE_TYPE = "capsule_msgs::msg::dds_::CapsuleState_"
STATUS_TYPE = "capsule_msgs::msg::dds_::ControllerStatus_"
SET_MODE_TYPE = "capsule_msgs::srv::dds_::SetMode_"


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


def graph(session, nodes, timeout):
    deadline = time.monotonic() + timeout
    while True:
        entities = []
        for reply in session.liveliness().get(f"@ros2_lv/{DOMAIN}/**", timeout=2.0):
            if reply.ok is not None:
                e = parse_token(str(reply.ok.key_expr))
                if e is not None:
                    entities.append(e)
        seen = {e["node"] for e in entities if e["kind"] == "NN"}
        if all(n in seen for n in nodes) or time.monotonic() > deadline:
            break
        time.sleep(0.2)
    for e in sorted(entities, key=lambda e: json.dumps(e, sort_keys=True)):
        print(json.dumps(e, sort_keys=True))
    missing = [n for n in nodes if n not in seen]
    if missing:
        fail(f"nodes not announced within {timeout} s: {missing}")


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


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    g = sub.add_parser("graph")
    g.add_argument("--node", action="append", default=[])
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
    a = p.parse_args()
    with open_session() as session:
        if a.cmd == "graph":
            graph(session, a.node, a.timeout)
        elif a.cmd == "state":
            state(session, a.hash, a.samples, a.timeout)
        else:
            set_mode(session, a.mode, a.gain, a.hash, a.status_hash, a.timeout)


if __name__ == "__main__":
    main()
