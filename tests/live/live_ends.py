#!/usr/bin/python3
"""How a live run ends, on a pseudo-terminal: the port going away (the process holding its
other end killed, as an unplugged adapter or a killed socat) marks the statistics and the
report incomplete; -c N stops after N records, noise counted, however much more comes; a
baud slower than the traffic gets the hint a capture file's run gives; and modtap discover on
a port summarises what it read when Ctrl-C ends it.

Usage: live_ends.py MODTAP WORK_DIR
"""
import json
import os
import random
import signal
import subprocess
import sys
import time
import tty

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from modbus import wait_until_open  # noqa: E402

MODTAP, WORK = sys.argv[1:3]
failures = []


def check(name, condition, message):
    if not condition:
        failures.append(f"{name}: {message}")
    return condition


def port_holder():
    """A process that makes a pty pair and holds its master end until killed, as socat does
    (socat is not among the test machines' packages). Returns the process and the port."""
    holder = subprocess.Popen(
        [sys.executable, "-c",
         "import os, sys, time, tty\n"
         "m, s = os.openpty(); tty.setraw(m); tty.setraw(s)\n"
         "print(os.ttyname(s), flush=True); os.close(s)\n"
         "while True: time.sleep(1)\n"],
        stdout=subprocess.PIPE, text=True)
    return holder, holder.stdout.readline().strip()


def port_goes_away():
    holder, port = port_holder()
    stats, report = os.path.join(WORK, "gone.json"), os.path.join(WORK, "gone.html")
    modtap = subprocess.Popen([MODTAP, "-i", port, "--baud", "19200", "-q", "--stats", stats,
                               "--report", report],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    check("port gone", wait_until_open(modtap, port), "the port never opened")
    time.sleep(0.3)
    holder.kill()
    holder.wait()
    try:
        _, err = modtap.communicate(timeout=15)
    except subprocess.TimeoutExpired:
        modtap.kill()
        _, err = modtap.communicate()
    ok = check("port gone", modtap.returncode == 1, f"exit status {modtap.returncode}: {err!r}")
    with open(stats) as f:
        complete = json.load(f)["complete"]
    ok &= check("port gone", complete is False, f'--stats says "complete": {complete}')
    with open(report) as f:
        ok &= check("port gone", "broke off" in f.read(), "the report does not say it broke off")
    print(f"port gone without --reconnect: {'ok' if ok else 'FAILED'}")


def raw_pty():
    """A raw pseudo-terminal pair, and the port name of its slave end for modtap to open."""
    master, slave = os.openpty()
    tty.setraw(master)
    tty.setraw(slave)
    return master, slave, os.ttyname(slave)


def count_stops_on_noise():
    master, slave, port = raw_pty()
    os.set_blocking(master, False)
    modtap = subprocess.Popen([MODTAP, "-i", port, "--baud", "115200", "--mode", "rtu", "-c", "2"],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    check("-c on a port", wait_until_open(modtap, port), "the port never opened")
    rng = random.Random(7)
    deadline = time.time() + 15
    while modtap.poll() is None and time.time() < deadline:  # junk until it stops
        try:
            os.write(master, bytes(rng.randrange(256) for _ in range(256)))
        except BlockingIOError:
            pass
        time.sleep(0.002)
    if modtap.poll() is None:
        modtap.kill()
    out, err = modtap.communicate()
    lines = out.splitlines()
    ok = check("-c on a port", modtap.returncode == 0 and len(lines) == 2,
               f"exit {modtap.returncode}, {len(lines)} lines: {lines[:3]} {err!r}")
    for fd in (master, slave):
        os.close(fd)
    print(f"-c 2 on a port of junk: {'ok' if ok else 'FAILED'}")


def read_request(slave):
    return with_crc(bytes([slave, 0x03, 0x00, 0x00, 0x00, 0x01]))


def with_crc(body):
    crc = 0xFFFF
    for byte in body:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    return body + bytes([crc & 0xFF, crc >> 8])


def hint_after_run(baud):
    """Polls every 10 ms, as a line of 19200 baud can carry them; the run's stderr once ended."""
    master, slave, port = raw_pty()
    modtap = subprocess.Popen([MODTAP, "-i", port, "--baud", str(baud), "--mode", "rtu", "-q"],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    check("hint", wait_until_open(modtap, port), "the port never opened")
    for i in range(40):
        os.write(master, read_request(1 + i % 5))
        time.sleep(0.010)
    time.sleep(0.2)
    modtap.send_signal(signal.SIGINT)
    _, err = modtap.communicate(timeout=15)
    for fd in (master, slave):
        os.close(fd)
    return err


def too_slow_a_baud_gets_a_hint():
    slow, right = hint_after_run(1200), hint_after_run(19200)
    ok = check("hint", "hint: bytes arrive faster than 1200 8E1 allows" in slow,
               f"at 1200 baud: {slow!r}")
    ok &= check("hint", "hint" not in right, f"at 19200 baud: {right!r}")
    print(f"a live run at too slow a baud gets a hint: {'ok' if ok else 'FAILED'}")


def discover_on_a_port():
    """modtap discover -i PORT until Ctrl-C: a meter's temperature across zero, read as a master
    does, summarised when the run ends."""
    master, slave, port = raw_pty()
    modtap = subprocess.Popen([MODTAP, "discover", "-i", port, "--baud", "19200", "--mode", "rtu"],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    check("discover", wait_until_open(modtap, port), "the port never opened")
    for n in range(16):
        tenths = (-40 + 7 * n) & 0xFFFF
        os.write(master, with_crc(bytes([3, 0x04, 0x00, 0x10, 0x00, 0x01])))
        time.sleep(0.015)
        os.write(master, with_crc(bytes([3, 0x04, 0x02, tenths >> 8, tenths & 0xFF])))
        time.sleep(0.030)
    time.sleep(0.2)
    modtap.send_signal(signal.SIGINT)
    out, err = modtap.communicate(timeout=15)
    for fd in (master, slave):
        os.close(fd)
    ok = check("discover", modtap.returncode == 0 and "slave 3" in out
               and "s16" in out and "temperature" in out and "polling program: 1 request" in out,
               f"exit {modtap.returncode}: {out!r} {err!r}")
    print(f"discover on a port, ended by Ctrl-C: {'ok' if ok else 'FAILED'}")


os.makedirs(WORK, exist_ok=True)
port_goes_away()
count_stops_on_noise()
too_slow_a_baud_gets_a_hint()
discover_on_a_port()
for f in failures:
    print("FAIL", f)
print(f"{4 - len({f.split(':')[0] for f in failures})} passed, "
      f"{len({f.split(':')[0] for f in failures})} failed")
sys.exit(1 if failures else 0)
