#!/usr/bin/env python3
"""A Foxglove WebSocket client (PyPI `websockets`, not our code) for the live-view test.

    foxglove_ws_client.py URL --topics T1 T2 ... [--seconds S] [--min N] [--timeout S]

Speaks Foxglove's WebSocket protocol (v1 messages) as the Foxglove app does, offering both of
its subprotocol names: foxglove.sdk.v1 (what the Foxglove SDK's server, ours, requires) and the
older foxglove.websocket.v1 (foxglove_bridge's): waits for serverInfo
and the advertisement of every topic asked for, subscribes to them, decodes the binary
messageData frames (opcode 0x01, subscription id u32 LE, log time u64 LE, payload) as the
advertised encoding (json) and checks, per topic: every number is finite, the message's own
time increases (state `t`, status `t`, frame `timestamp`), log times do not go back, and at
least --min messages arrived. Prints one JSON summary line; exits 1 with the reason otherwise.
"""

import argparse
import asyncio
import json
import math
import struct
import sys
import time

import websockets

SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]


def fail(msg):
    print(f"foxglove_ws_client: FAIL: {msg}", file=sys.stderr)
    sys.exit(1)


def numbers(v):
    if isinstance(v, bool):
        return
    if isinstance(v, (int, float)):
        yield float(v)
    elif isinstance(v, dict):
        for x in v.values():
            yield from numbers(x)
    elif isinstance(v, list):
        for x in v:
            yield from numbers(x)


def msg_time(m):
    if "t" in m:
        return float(m["t"])
    ts = m.get("timestamp")
    if isinstance(ts, dict):
        return ts["sec"] + ts["nsec"] * 1e-9
    return None


async def run(args):
    deadline = time.monotonic() + args.timeout
    async with websockets.connect(args.url, subprotocols=SUBPROTOCOLS, max_size=None,
                                  open_timeout=args.timeout) as ws:
        if ws.subprotocol not in SUBPROTOCOLS:
            fail(f"server chose subprotocol {ws.subprotocol!r}")
        channels = {}
        server_info = None
        # serverInfo, then advertise (possibly several) until every wanted topic is known
        while server_info is None or not all(t in channels for t in args.topics):
            left = deadline - time.monotonic()
            if left <= 0:
                fail(f"advertised {sorted(channels)}, wanted {args.topics} (serverInfo {server_info is not None})")
            try:
                raw = await asyncio.wait_for(ws.recv(), left)
            except asyncio.TimeoutError:
                continue
            if isinstance(raw, bytes):
                continue
            m = json.loads(raw)
            if m.get("op") == "serverInfo":
                server_info = m
            elif m.get("op") == "advertise":
                for c in m["channels"]:
                    channels[c["topic"]] = c
        subs = {}
        for i, topic in enumerate(args.topics, start=1):
            c = channels[topic]
            if c["encoding"] != "json" or c.get("schemaEncoding") != "jsonschema":
                fail(f"{topic}: encoding {c['encoding']!r} schema {c.get('schemaEncoding')!r}")
            json.loads(c["schema"])  # the schema must be JSON
            subs[i] = topic
        await ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": i, "channelId": channels[t]["id"]} for i, t in subs.items()]}))
        # for a test that must act only once the client listens (a goal's feedback)
        print("foxglove_ws_client: subscribed", file=sys.stderr, flush=True)
        got = {t: [] for t in args.topics}
        log_times = {t: [] for t in args.topics}
        end = time.monotonic() + args.seconds
        while time.monotonic() < end or any(len(v) < args.min for v in got.values()):
            left = min(end, deadline) - time.monotonic()
            if time.monotonic() >= deadline:
                fail("too few messages: " + json.dumps({t: len(v) for t, v in got.items()}))
            try:
                raw = await asyncio.wait_for(ws.recv(), max(left, 0.1))
            except asyncio.TimeoutError:
                continue
            if not isinstance(raw, bytes):
                continue
            if raw[0] != 0x01:
                continue
            sub_id, log_time = struct.unpack_from("<IQ", raw, 1)
            topic = subs.get(sub_id)
            if topic is None:
                fail(f"messageData for unknown subscription {sub_id}")
            m = json.loads(raw[13:])
            bad = [x for x in numbers(m) if not math.isfinite(x)]
            if bad:
                fail(f"{topic}: non-finite values {bad} in {m}")
            got[topic].append(m)
            log_times[topic].append(log_time)
        out = {"server": server_info.get("name"), "subprotocol": ws.subprotocol, "capabilities": server_info.get("capabilities", [])}
        for t, ms in got.items():
            times = [msg_time(m) for m in ms]
            if any(x is None for x in times):
                fail(f"{t}: a message without a time: {ms[0]}")
            if any(b <= a for a, b in zip(times, times[1:])):
                fail(f"{t}: message times do not increase: {times[:20]}")
            if any(b < a for a, b in zip(log_times[t], log_times[t][1:])):
                fail(f"{t}: log times go back")
            out[t] = {"count": len(ms), "schema": channels[t]["schemaName"],
                      "first_t": times[0], "last_t": times[-1], "last": ms[-1]}
        await ws.send(json.dumps({"op": "unsubscribe", "subscriptionIds": list(subs)}))
        print(json.dumps(out), flush=True)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("url")
    p.add_argument("--topics", nargs="+", required=True)
    p.add_argument("--seconds", type=float, default=2.0)
    p.add_argument("--min", type=int, default=5)
    p.add_argument("--timeout", type=float, default=30.0)
    args = p.parse_args()
    try:
        asyncio.run(run(args))
    except (OSError, websockets.exceptions.WebSocketException) as e:
        fail(f"{args.url}: {e!r}")


if __name__ == "__main__":
    main()
