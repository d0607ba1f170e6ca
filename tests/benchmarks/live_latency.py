#!/usr/bin/python3
"""How soon a live modtap prints a frame after its last byte arrives.

Writes request/response pairs into a pseudo-terminal that `modtap -i` listens on, and times
each JSON line on modtap's stdout against the moment the frame's last byte was written. A
frame is complete only after t3.5 of silence (or when the framer can tell its end from its
length), so the delay should be about t3.5 plus the loop's wake-up.

Usage: live_latency.py MODTAP [BAUD ...]
"""
import json
import os
import statistics
import subprocess
import sys
import threading
import time
import tty

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from modbus import with_crc  # noqa: E402

MODTAP = sys.argv[1]
BAUDS = [int(b) for b in sys.argv[2:]] or [9600, 115200]


def measure(baud, pairs=200):
    master, slave = os.openpty()
    tty.setraw(master)
    tty.setraw(slave)
    modtap = subprocess.Popen([MODTAP, "-i", os.ttyname(slave), "--baud", str(baud), "--parity",
                               "none", "--mode", "rtu", "-T", "json"],
                              stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    printed = {}

    def read_lines():
        for line in modtap.stdout:
            record = json.loads(line)
            if record["type"] == "frame":
                printed[record["index"]] = time.monotonic()

    reader = threading.Thread(target=read_lines, daemon=True)
    reader.start()
    time.sleep(0.5)
    written = {}
    index = 0
    for i in range(pairs):
        for frame in (with_crc([1, 3, 0, i % 100, 0, 1]), with_crc([1, 3, 2, 0, i % 100])):
            os.write(master, frame)
            index += 1
            written[index] = time.monotonic()
            time.sleep(0.02)
    time.sleep(0.5)
    modtap.terminate()
    modtap.wait()
    reader.join(timeout=2)
    os.close(master)
    os.close(slave)
    delays = [(printed[i] - written[i]) * 1000 for i in written if i in printed]
    t35 = 1.75 if baud > 19200 else 3.5 * 11 / baud * 1000
    print(f"{baud} baud (t3.5 = {t35:.2f} ms): {len(delays)} of {len(written)} frames printed; "
          f"delay after the last byte: median {statistics.median(delays):.2f} ms, "
          f"95th percentile {sorted(delays)[int(len(delays) * 0.95)]:.2f} ms, "
          f"max {max(delays):.2f} ms")


for baud in BAUDS:
    measure(baud)
