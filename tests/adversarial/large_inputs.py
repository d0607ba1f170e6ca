#!/usr/bin/python3
"""Whole-process runs on inputs no one commits: a long capture streamed through a pipe (memory
must stay flat, every frame found), a frame every microsecond, a hex log with binary junk, and
junk by the hundred megabytes: random bytes, and ':' with no CRLF (a capture read with the
wrong settings, a line full of noise), each in bounded time and memory with every byte kept.

    large_inputs.py MODTAP BUSGEN WORKDIR MEGABYTES RSS_LIMIT_MB
"""
import json
import os
import random
import resource
import struct
import subprocess
import sys
import threading
import time

MODTAP, BUSGEN, WORK = sys.argv[1:4]
MEGABYTES, RSS_LIMIT_MB = int(sys.argv[4]), int(sys.argv[5])
os.makedirs(WORK, exist_ok=True)
failures = []


def check(name, ok, detail):
    if not ok:
        failures.append(f"{name}: {detail}")
    return ok


def stats(lines, key):
    """The first number on the statistics line that starts with `key`."""
    line = next(line for line in lines if line.startswith(key))
    return int(line[len(key):].split()[0])


def streamed(copies, one):
    """modtap reading `copies` copies of a raw capture from a pipe: its stats and peak RSS."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    proc = subprocess.Popen([MODTAP, "-r", "/dev/stdin", "--format", "raw", "--mode", "rtu",
                             "-T", "stats"], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=False)
    for _ in range(copies):
        proc.stdin.write(one)
    proc.stdin.close()
    out = proc.stdout.read().decode().splitlines()
    proc.wait()
    rss_kb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    return proc.returncode, out, rss_kb if rss_kb > before else before


# 1. A long capture: memory stays flat, nothing is lost.
raw = os.path.join(WORK, "one.raw")
made = subprocess.run([BUSGEN, "-n", "20000", "--seed", "5", "--format", "raw", "-o", raw],
                      capture_output=True, text=True, check=True)
frames_one = int(made.stderr.split()[0] if made.stderr.strip() else made.stdout.split()[0])
one = open(raw, "rb").read()
copies = max(1, MEGABYTES * 1024 * 1024 // len(one))
start = time.time()
status, out, rss_kb = streamed(copies, one)
seconds = time.time() - start
check("long capture", status == 0, f"exit {status}")
check("long capture", stats(out, "frames ") == frames_one * copies,
      f"{stats(out, 'frames ')} frames, expected {frames_one * copies}")
check("long capture", stats(out, "noise ") == 0, "noise in clean traffic")
check("long capture", rss_kb < RSS_LIMIT_MB * 1024, f"peak RSS {rss_kb} kB for {copies * len(one)} bytes")
print(f"{copies * len(one) / 1e6:.0f} MB through a pipe in {seconds:.1f} s, "
      f"{stats(out, 'frames ')} frames, peak RSS {rss_kb} kB")

# 2. A frame every microsecond: timestamps closer than the bytes could take on any wire.
pcap = os.path.join(WORK, "every-microsecond.pcap")
request = bytes.fromhex("010300000001840a")
with open(pcap, "wb") as f:
    f.write(struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 147))
    for i in range(100000):
        f.write(struct.pack("<IIII", 1700000000 + i // 1000000, i % 1000000, 8, 8) + request)
run = subprocess.run([MODTAP, "-r", pcap, "-T", "stats"], capture_output=True, text=True, timeout=120)
lines = run.stdout.splitlines()
check("every microsecond", run.returncode == 0, f"exit {run.returncode}: {run.stderr}")
check("every microsecond", stats(lines, "frames ") == 100000, f"{stats(lines, 'frames ')} frames")
check("every microsecond", "faster than" in run.stderr, f"no hint about the clock: {run.stderr!r}")
print(f"a frame every microsecond: {stats(lines, 'frames ')} frames; {run.stderr.strip()}")

# 3. A hex log with binary junk: a clear message with the line, the junk shown escaped.
log = os.path.join(WORK, "junk.log")
with open(log, "wb") as f:
    f.write(b"2026-11-22 09:00:00.000000:\n01 03 00 00 00 01 84 0A\n" + bytes(range(256)) + b"\n")
run = subprocess.run([MODTAP, "-r", log], capture_output=True, timeout=30)
err = run.stderr.decode("utf-8", "replace")
check("junk hex log", run.returncode == 2, f"exit {run.returncode}")
check("junk hex log", err.startswith(f"modtap: {log}: line 3, column 1: expected a hex byte"), err)
check("junk hex log", all(32 <= b < 127 or b == 10 for b in run.stderr), f"raw bytes in {err!r}")
print(f"hex log with junk: {err.strip()}")

# 4. Junk by the hundred megabytes (a few under the sanitizers), through a pipe in automatic
# mode: every byte is in some record, in bounded time and memory.
junk_mb = 100 if MEGABYTES >= 1024 else 2
generator = random.Random(12)
junk_inputs = {
    "random bytes": lambda: generator.randbytes(1 << 20),
    "':' with no CRLF": lambda: b":" * (1 << 20),
}
for name, megabyte in junk_inputs.items():
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    start = time.time()
    proc = subprocess.Popen([MODTAP, "-r", "-", "--format", "raw", "-q", "--stats", "-"],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    feeder = threading.Thread(target=lambda: (
        [proc.stdin.write(megabyte()) for _ in range(junk_mb)], proc.stdin.close()))
    feeder.start()
    out = proc.stdout.read()  # not communicate(): it would close the feeder's stdin
    err = proc.stderr.read()
    proc.wait(timeout=600)
    feeder.join()
    seconds = time.time() - start
    rss_kb = max(before, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)
    counted = json.loads(out) if proc.returncode == 0 else {}
    check(name, proc.returncode == 0, f"exit {proc.returncode}: {err!r}")
    check(name, counted.get("bytes") == junk_mb << 20 and
          counted.get("frame_bytes", 0) + counted.get("noise_bytes", 0) == junk_mb << 20,
          f"of {junk_mb << 20} bytes: {counted.get('frame_bytes')} in frames, "
          f"{counted.get('noise_bytes')} in noise, {counted.get('bytes')} counted")
    check(name, rss_kb < RSS_LIMIT_MB * 1024, f"peak RSS {rss_kb} kB")
    print(f"{junk_mb} MB of {name}: {seconds:.1f} s, {counted.get('noise_records')} noise records, "
          f"{counted.get('frames')} frames, peak RSS {rss_kb} kB")

for f in failures:
    print("FAIL", f)
sys.exit(1 if failures else 0)
