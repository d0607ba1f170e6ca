#!/usr/bin/python3
"""modtap reads what Debian's jpnevulator logs of a real-time bus.

The bus simulator's traffic (a PLC polling 4 slaves, 19200 8E1) is played into three
pseudo-terminals in real time, each frame written when its last byte would have arrived, and
three jpnevulator processes log them as users run it: with its defaults (a block gathers every
read within 100 ms), with --timing-delta=0 (a block per read), and with --byte-count --ascii.
modtap must read every log to the frames, roles and pairs the simulator sent, never warn that
the time stamps go backwards, never print a latency of 0, measure none inside a block, and
with a block per read measure each latency as the simulator made it, within the jitter of the
pty and the scheduler.

Usage: jpnevulator_clock.py MODTAP BUSGEN WORK_DIR
"""
import json
import os
import subprocess
import sys
import time
import tty

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from modbus import replay, simulated_blocks, wait_until_open  # noqa: E402

MODTAP, BUSGEN, WORK = sys.argv[1:4]
CHAR_SECONDS = 11 / 19200
LOGS = {"defaults": [], "block-per-read": ["--timing-delta=0"],
        "byte-count": ["--timing-delta=0", "--byte-count", "--ascii"]}
failures = []


def check(name, condition, message):
    if not condition:
        failures.append(f"{name}: {message}")


def records(log):
    out = subprocess.run([MODTAP, "-r", log, "-T", "json", "--baud", "19200", "--parity", "even"],
                         capture_output=True, text=True, timeout=60)
    return [json.loads(line) for line in out.stdout.splitlines()], out.stderr


def main():
    os.makedirs(WORK, exist_ok=True)
    simulated = os.path.join(WORK, "simulated.log")
    subprocess.run([BUSGEN, "-n", "200", "--slaves", "4", "--seed", "5", "--format", "hexlog",
                    "--delivery", "frames", "-o", simulated], check=True, capture_output=True)
    truth, _ = records(simulated)
    truth_frames = [r for r in truth if r["type"] == "frame"]
    ptys, readers = [], []
    for name, options in LOGS.items():
        master, slave = os.openpty()
        tty.setraw(master)
        tty.setraw(slave)
        path = os.ttyname(slave)
        log = open(os.path.join(WORK, name + ".log"), "w")
        process = subprocess.Popen(["jpnevulator", "--read", "--timing-print", "--tty", path,
                                    *options], stdout=log, stderr=subprocess.DEVNULL)
        if not wait_until_open(process, path):
            sys.exit(f"jpnevulator did not open {path}")
        ptys.append(master)
        readers.append((name, process, log))
    try:
        replay(simulated_blocks(simulated), ptys)
        time.sleep(0.5)
    finally:  # a jpnevulator left reading a closed pty spins
        for name, process, log in readers:
            process.terminate()
            process.wait()
            log.close()
    for name in LOGS:
        got, errors = records(os.path.join(WORK, name + ".log"))
        frames = [r for r in got if r["type"] == "frame"]
        check(name, [f["raw"] for f in frames] == [f["raw"] for f in truth_frames],
              f"{len(frames)} frames, {len(truth_frames)} sent, or not the same bytes")
        check(name, [(f["role"], f["request"] is not None) for f in frames] ==
              [(f["role"], f["request"] is not None) for f in truth_frames], "roles or pairs differ")
        check(name, "backwards" not in errors, errors.strip())
        latencies = [f["latency_us"] for f in frames if f["latency_us"] is not None]
        check(name, 0 not in latencies, "a latency of 0")
        if name == "defaults":
            check(name, not latencies, f"{len(latencies)} latencies measured inside blocks")
            continue
        # The replay's own lateness on a busy machine moves a few frames; the typical one is
        # read as sent (30 us off on an idle machine).
        errors_us = sorted(abs(m["latency_us"] - t["latency_us"]) if m["latency_us"] is not None
                           else float("inf") for m, t in zip(frames, truth_frames)
                           if t["latency_us"] is not None)
        check(name, errors_us and errors_us[len(errors_us) // 2] < 500,
              f"the median latency is {errors_us[len(errors_us) // 2]} us off")
        check(name, sum(e > 3000 for e in errors_us) <= len(errors_us) // 10,
              f"{sum(e > 3000 for e in errors_us)} of {len(errors_us)} latencies over 3 ms off")
    for failure in failures:
        print("FAIL", failure)
    print(f"{len(LOGS)} jpnevulator logs checked against {len(truth_frames)} frames")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
