#!/usr/bin/env python3
"""A device that says little, on a pseudo-terminal: for timing what the plant's serial driver
sends while it waits (tests/integration/ros/lifecycle.rs, docs/perf/hardware.md).

Usage: quiet_device.py LINK LOG [--hello] [--measurements N] [--seconds S]
  Makes LINK a symbolic link to a new pty, then (with --hello) sends a hello and N measurements
  at 1 kHz, then nothing; meanwhile reads what the driver sends and writes one CSV line per
  force frame to LOG: wall clock [ns since the epoch], force [N], the frame it answers.
The frames are capsule_device's (docs/hardware.md): sync CA 95, type, seq u16, len, payload,
CRC-16/CCITT-FALSE over type..payload, little endian.
"""
import argparse
import os
import pty
import select
import struct
import time
import tty


def crc16(data):
    crc = 0xFFFF
    for b in data:
        crc ^= b << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else (crc << 1)
            crc &= 0xFFFF
    return crc


def frame(kind, seq, payload):
    body = struct.pack("<BHB", kind, seq, len(payload)) + payload
    return b"\xca\x95" + body + struct.pack("<H", crc16(body))


def main():
    p = argparse.ArgumentParser()
    p.add_argument("link")
    p.add_argument("log")
    p.add_argument("--hello", action="store_true")
    p.add_argument("--measurements", type=int, default=0)
    p.add_argument("--seconds", type=float, default=60.0)
    a = p.parse_args()
    master, slave = pty.openpty()
    tty.setraw(slave)
    os.set_blocking(master, False)
    if os.path.islink(a.link):
        os.remove(a.link)
    os.symlink(os.ttyname(slave), a.link)
    seq = 0
    if a.hello:
        # protocol 1, measures x1 - x2 and x2, 10 N, 0.01 m, 1 kHz, timeout 0.1 s
        os.write(master, frame(1, seq, struct.pack("<BBxxffff", 1, 3, 10.0, 0.01, 1000.0, 0.1)))
        seq += 1
        for k in range(a.measurements):
            m = struct.pack("<IfffffB", k * 1000, 0.0, 0.0, float("nan"), float("nan"), 0.0, 0)
            os.write(master, frame(2, seq, m))
            seq += 1
            time.sleep(0.001)
    buf = b""
    end = time.time() + a.seconds
    with open(a.log, "w") as log:
        while time.time() < end:
            r, _, _ = select.select([master], [], [], 0.05)
            if not r:
                continue
            now = time.time_ns()
            try:
                buf += os.read(master, 4096)
            except BlockingIOError:
                continue
            while True:
                i = buf.find(b"\xca\x95")
                if i < 0 or len(buf) < i + 6:
                    break
                n = buf[i + 5]
                if len(buf) < i + 8 + n:
                    break
                kind = buf[i + 2]
                if kind == 3 and n == 6:
                    force, answers = struct.unpack("<fH", buf[i + 6:i + 12])
                    log.write(f"{now},{force},{answers}\n")
                    log.flush()
                buf = buf[i + 8 + n:]
    os.remove(a.link)


if __name__ == "__main__":
    main()
