#!/usr/bin/env python3
"""Delay, jitter and reordering for the packets of an iptables NFQUEUE, in user space.

The kernel here has no sch_netem; inside a test's network namespace, iptables hands packets to
this program (`-j NFQUEUE --queue-num N --queue-bypass`) and it gives each its verdict (accept)
after DELAY +- JITTER ms (uniform), plus REORDER_MS more for a fraction REORDER of them, so later
packets overtake those. Plain nfnetlink on an AF_NETLINK socket: no library needed.

    nfqueue_delay.py --queue 0 --delay-ms 1 --jitter-ms 1 --reorder 0.05 [--reorder-ms 3]
                     [--seed 1] [--ready FILE]

Runs until SIGTERM / SIGINT; then accepts what it holds, unbinds and prints one JSON line of
counts to stdout. `--ready FILE` is created once the queue is bound (a test waits for it before
adding the iptables rule that feeds the queue).
"""

import argparse
import heapq
import json
import os
import random
import select
import signal
import socket
import struct
import sys
import time

NETLINK_NETFILTER = 12
NFNL_SUBSYS_QUEUE = 3
NFQNL_MSG_PACKET, NFQNL_MSG_VERDICT, NFQNL_MSG_CONFIG = 0, 1, 2
NFQA_CFG_CMD, NFQA_CFG_PARAMS = 1, 2
NFQNL_CFG_CMD_BIND, NFQNL_CFG_CMD_UNBIND = 1, 2
NFQNL_COPY_META = 1
NFQA_PACKET_HDR, NFQA_VERDICT_HDR = 1, 2
NF_ACCEPT = 1
NLM_F_REQUEST, NLM_F_ACK = 1, 4
NLMSG_ERROR = 2


def attr(kind, payload):
    """One netlink attribute, padded to 4 bytes."""
    length = 4 + len(payload)
    return struct.pack("=HH", length, kind) + payload + b"\0" * ((4 - length % 4) % 4)


def message(kind, queue, attrs, flags=NLM_F_REQUEST, seq=0):
    """An nfnetlink message of the queue subsystem: nlmsghdr, nfgenmsg, attributes."""
    body = struct.pack("=BBH", socket.AF_UNSPEC, 0, socket.htons(queue)) + b"".join(attrs)
    header = struct.pack("=IHHII", 16 + len(body), (NFNL_SUBSYS_QUEUE << 8) | kind, flags, seq, 0)
    return header + body


def config(sock, queue, attrs, seq):
    """Sends a config message and waits for its acknowledgement; raises on a kernel error."""
    sock.send(message(NFQNL_MSG_CONFIG, queue, attrs, NLM_F_REQUEST | NLM_F_ACK, seq))
    while True:
        data = sock.recv(65536)
        for kind, payload in messages(data):
            if kind == NLMSG_ERROR:
                (err,) = struct.unpack_from("=i", payload)
                if err != 0:
                    raise OSError(-err, f"nfqueue config: {os.strerror(-err)}")
                return


def messages(data):
    """(type, payload) of every netlink message in a datagram."""
    at = 0
    while at + 16 <= len(data):
        length, kind, _flags, _seq, _pid = struct.unpack_from("=IHHII", data, at)
        if length < 16:
            return
        yield kind, data[at + 16 : at + length]
        at += (length + 3) & ~3


def packet_id(payload):
    """The packet id of an NFQNL_MSG_PACKET payload (after its nfgenmsg), or None."""
    at = 4
    while at + 4 <= len(payload):
        length, kind = struct.unpack_from("=HH", payload, at)
        if length < 4:
            return None
        if kind & 0x7FFF == NFQA_PACKET_HDR:
            return struct.unpack_from("!I", payload, at + 4)[0]
        at += (length + 3) & ~3
    return None


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--queue", type=int, default=0)
    p.add_argument("--delay-ms", type=float, default=1.0)
    p.add_argument("--jitter-ms", type=float, default=0.0)
    p.add_argument("--reorder", type=float, default=0.0, help="fraction held back REORDER_MS more")
    p.add_argument("--reorder-ms", type=float, default=3.0)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--ready", help="file created once the queue is bound")
    a = p.parse_args()
    if not (0 <= a.queue <= 65535) or a.delay_ms < 0 or a.jitter_ms < 0 or a.jitter_ms > a.delay_ms \
            or not (0 <= a.reorder <= 1) or a.reorder_ms < 0:
        print("nfqueue_delay: bad arguments (queue 0-65535, 0 <= jitter <= delay, 0 <= reorder <= 1)",
              file=sys.stderr)
        return 2
    rng = random.Random(a.seed)
    sock = socket.socket(socket.AF_NETLINK, socket.SOCK_RAW, NETLINK_NETFILTER)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8 << 20)
    sock.bind((0, 0))
    cmd = struct.pack("=BBH", NFQNL_CFG_CMD_BIND, 0, 0)
    config(sock, a.queue, [attr(NFQA_CFG_CMD, cmd)], 1)
    config(sock, a.queue, [attr(NFQA_CFG_PARAMS, struct.pack("!IB", 0, NFQNL_COPY_META))], 2)
    if a.ready:
        open(a.ready, "w").close()
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(1))
    signal.signal(signal.SIGINT, lambda *_: stop.append(1))
    held = []  # (due, packet id)
    counts = {"packets": 0, "reordered": 0, "max_held": 0, "overruns": 0}

    def accept(pid):
        verdict = struct.pack("!II", NF_ACCEPT, pid)
        sock.send(message(NFQNL_MSG_VERDICT, a.queue, [attr(NFQA_VERDICT_HDR, verdict)]))

    while not stop:
        now = time.monotonic()
        while held and held[0][0] <= now:
            accept(heapq.heappop(held)[1])
        timeout = max(0.0, held[0][0] - now) if held else 0.2
        try:
            ready, _, _ = select.select([sock], [], [], timeout)
        except InterruptedError:
            continue
        if not ready:
            continue
        try:
            data = sock.recv(1 << 16)
        except OSError as e:  # ENOBUFS: the kernel dropped what did not fit, as a full link would
            counts["overruns"] += 1
            if e.errno == 105:
                continue
            raise
        now = time.monotonic()
        for kind, payload in messages(data):
            if kind & 0xFF != NFQNL_MSG_PACKET:
                continue
            pid = packet_id(payload)
            if pid is None:
                continue
            counts["packets"] += 1
            d = a.delay_ms + rng.uniform(-a.jitter_ms, a.jitter_ms)
            if rng.random() < a.reorder:
                d += a.reorder_ms
                counts["reordered"] += 1
            heapq.heappush(held, (now + d * 1e-3, pid))
            counts["max_held"] = max(counts["max_held"], len(held))
    while held:
        accept(heapq.heappop(held)[1])
    try:
        config(sock, a.queue, [attr(NFQA_CFG_CMD, struct.pack("=BBH", NFQNL_CFG_CMD_UNBIND, 0, 0))], 3)
    except OSError:
        pass
    print(json.dumps(counts), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
