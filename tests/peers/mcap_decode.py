#!/usr/bin/env python3
"""Decode a capsule recording with the two reference ROS 2 MCAP readers and print JSON.

    python3 tests/peers/mcap_decode.py FILE [--reader mcap|rosbags|both]

Uses only the readers' own ROS 2 decoders (mcap + mcap-ros2-support, rosbags AnyReader): no
custom decoding. For each reader it prints, per topic, the type, the count, and the fields the
tests compare (floats as their IEEE-754 bit patterns; state: seq, stamp, mass_position, capsule_velocity, stuck; force: state_seq,
force; service events: event_type, mode, gain, accepted; clock: ns; status: mode,
commands_sent; diagnostics: the first status's level, message and key=value pairs; action
feedback: goal id, travelled_m or orbit_period; action status: goal id and status of each; an
action's service events: kind, sequence number, client and the request or response), plus
the file's profile and the rosbag2 metadata keys. The mcap reader's refusals of a schema are
listed per topic under "refused" with the reader's reason (mcap-ros2-support refuses rosidl's
`_` in derived names such as `Move_FeedbackMessage`), and that topic's messages left out.
"""
import argparse
import json
import struct
import sys


def bits(x):
    """The IEEE-754 bit pattern of a float64 (JSON floats need not round-trip exactly)."""
    return struct.unpack("<q", struct.pack("<d", float(x)))[0]


def stamp_ns(t):
    return int(t.sec) * 1_000_000_000 + int(t.nanosec)


def plain(v):
    """A decoded message as JSON: fields by name, byte arrays (ids) as hex, floats as they are."""
    if hasattr(v, "tobytes"):
        return v.tobytes().hex()
    if isinstance(v, (bytes, bytearray)):
        return bytes(v).hex()
    if isinstance(v, (list, tuple)):
        return [plain(x) for x in v]
    names = getattr(v, "__dataclass_fields__", None) or getattr(v, "__slots__", None)
    if names:
        # fields only: not the constants (upper case) nor rosbags' private names
        return {k: plain(getattr(v, k)) for k in names if not k.startswith("_") and not k.isupper()}
    return v


def row(topic_type, m):
    if topic_type.endswith("/CapsuleState"):
        return [int(m.seq), stamp_ns(m.header.stamp), bits(m.mass_position),
                bits(m.capsule_velocity), bool(m.stuck)]
    if topic_type.endswith("/ActuatorForce"):
        return [int(m.state_seq), bits(m.force), stamp_ns(m.header.stamp)]
    if topic_type.endswith("/SetModeEvent"):
        req = list(m.request)
        res = list(m.response)
        return [int(m.info.event_type), int(m.info.sequence_number),
                int(req[0].mode) if req else None, bits(req[0].gain) if req else None,
                bool(res[0].accepted) if res else None]
    if topic_type.endswith("_Event"):
        # an action's service events (rosidl's `A_SendGoal_Event`, `A_GetResult_Event`,
        # `action_msgs/srv/CancelGoal_Event`): the event and its request or response
        req, res = list(m.request), list(m.response)
        return {"event_type": int(m.info.event_type),
                "sequence_number": int(m.info.sequence_number),
                "client_gid": bytes(m.info.client_gid).hex(),
                "request": plain(req[0]) if req else None,
                "response": plain(res[0]) if res else None}
    if topic_type.endswith("/Clock"):
        return [stamp_ns(m.clock)]
    if topic_type.endswith("/ControllerStatus"):
        return [int(m.mode), int(m.commands_sent)]
    if topic_type.endswith("_FeedbackMessage"):
        f = m.feedback
        first = "travelled_m" if hasattr(f, "travelled_m") else "orbit_period"
        return [bytes(m.goal_id.uuid).hex(), getattr(f, first)]
    if topic_type.endswith("/GoalStatusArray"):
        return [[bytes(s.goal_info.goal_id.uuid).hex(), int(s.status)] for s in m.status_list]
    if topic_type.endswith("/DiagnosticArray"):
        s = m.status[0]
        level = s.level[0] if isinstance(s.level, (bytes, bytearray)) else int(s.level)
        return [level, s.message, [f"{v.key}={v.value}" for v in s.values]]
    return None


def add(out, topic, typ, m, log_ns):
    t = out.setdefault(topic, {"type": typ, "count": 0, "rows": [], "log_ns": []})
    t["count"] += 1
    t["rows"].append(row(typ, m))
    t["log_ns"].append(int(log_ns))


def with_mcap(path):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    out = {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        header = reader.get_header()
        meta = {}
        for rec in reader.iter_metadata():
            meta[rec.name] = sorted(rec.metadata.keys())
        schemas = {}
        # decoders made per channel, as iter_decoded_messages makes them, but a schema the
        # reader refuses is reported (per topic, with its reason) instead of ending the read
        factory, decoders, refused = DecoderFactory(), {}, {}
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            if channel.id not in decoders:
                try:
                    decoders[channel.id] = factory.decoder_for(channel.message_encoding, schema)
                    if decoders[channel.id] is None:
                        refused[channel.topic] = "no decoder for this encoding"
                except Exception as e:
                    decoders[channel.id] = None
                    refused[channel.topic] = f"{type(e).__name__}: {e}"
            if decoders[channel.id] is None:
                continue
            decoded = decoders[channel.id](message.data)
            add(out, channel.topic, schema.name, decoded, message.log_time)
            schemas[channel.topic] = {
                "schema": schema.name,
                "schema_encoding": schema.encoding,
                "message_encoding": channel.message_encoding,
                "qos": "offered_qos_profiles" in channel.metadata,
                "cdr_header": list(message.data[:4]),
            }
        summary = reader.get_summary()
        stats = None
        if summary is not None and summary.statistics is not None:
            stats = summary.statistics.message_count
    return {"profile": header.profile, "metadata": meta, "channels": schemas,
            "statistics_messages": stats, "topics": out, "refused": refused}


def with_rosbags(path):
    from pathlib import Path
    from rosbags.highlevel import AnyReader

    out = {}
    with AnyReader([Path(path)]) as reader:
        for conn, log_ns, raw in reader.messages():
            add(out, conn.topic, conn.msgtype, reader.deserialize(raw, conn.msgtype), log_ns)
    return {"topics": out}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("file")
    ap.add_argument("--reader", choices=["mcap", "rosbags", "both"], default="both")
    a = ap.parse_args()
    res = {}
    try:
        if a.reader in ("mcap", "both"):
            res["mcap"] = with_mcap(a.file)
        if a.reader in ("rosbags", "both"):
            res["rosbags"] = with_rosbags(a.file)
    except Exception as e:  # report, do not hide: the test fails on a non-zero exit
        print(f"mcap_decode: {type(e).__name__}: {e}", file=sys.stderr)
        return 1
    json.dump(res, sys.stdout)
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
