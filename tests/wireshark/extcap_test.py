#!/usr/bin/python3
"""tshark captures live through modtap-extcap, as a Wireshark user would.

A pty stands in for a serial port: MODTAP_EXTCAP_PORTS names it, so `tshark -D` lists it as
modtap:/dev/pts/N. `tshark -i modtap:/dev/pts/N` then captures twice while traffic is written
into the pty: known frames at 115200 baud (with the NTA5000 model chosen in the capture
options, so the registers come named), and the bus simulator's mix of every function code,
exceptions, broadcasts and silent slaves at 19200 8E1, replayed with its own timing. The
packets must be the frames written, with the roles modtap gives the same traffic from a file,
decoded by Wireshark's Modbus dissector.

Wireshark 4.0 looks for extcaps only in its global folder (and ignores WIRESHARK_EXTCAP_DIR
when run as root), so the test links the build's modtap-extcap there for its duration, unless
an installed one is already there; it then drives the build's program through the extcap
protocol itself (--capture --fifo), exactly as tshark would, and reads the FIFO with tshark.

Usage: extcap_test.py EXTCAP PLUGIN WORK_DIR MODTAP BUSGEN
"""
import datetime
import json
import os
import subprocess
import sys
import threading
import time
import tty

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from modbus import with_crc  # noqa: E402
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from extcap_link import link_extcap, preference_prefix  # noqa: E402
from wireshark_home import as_user, make_home  # noqa: E402

EXTCAP, PLUGIN, WORK, MODTAP, BUSGEN = sys.argv[1:6]


def traffic():
    """50 transactions of the echo codes Wireshark cannot classify by length, and reads."""
    frames = []
    for i in range(25):
        write = with_crc([1, 0x06, 0x00, i, 0x12, 0x34])
        frames += [("request", write), ("response", write)]
        frames += [("request", with_crc([2, 0x03, 0x00, i, 0x00, 0x02])),
                   ("response", with_crc([2, 0x03, 0x04, 0x00, i, 0x12, 0x34]))]
    return frames


def feed(master_fd, blocks):
    """Writes (seconds, bytes) blocks at their times, after the extcap has opened the port."""
    time.sleep(2.0)
    t0 = time.monotonic()
    for at, data in blocks:
        time.sleep(max(0.0, t0 + at - time.monotonic()))
        os.write(master_fd, data)


def known_blocks():
    # A gap well over t3.5 (1.75 ms at 115200) between frames.
    return [(i * 0.005, frame) for i, (_, frame) in enumerate(traffic())]


def simulated_blocks(log):
    """The simulator's frames as timed blocks, from its jpnevulator-style log."""
    blocks, first = [], None
    for line in open(log):
        line = line.strip()
        if line.endswith(":"):
            stamp = datetime.datetime.strptime(line[:-1], "%Y-%m-%d %H:%M:%S.%f").timestamp()
            first = stamp if first is None else first
            blocks.append((stamp - first, bytearray()))
        elif line:
            blocks[-1][1].extend(bytes.fromhex(line))
    return [(at, bytes(data)) for at, data in blocks]


def capture_with_tshark(port, pcapng, settings):
    env = dict(os.environ, MODTAP_EXTCAP_PORTS=port)
    listed = subprocess.run(["tshark", "-D"], capture_output=True, text=True, env=env).stdout
    if f"modtap:{port}" not in listed:
        raise SystemExit(f"tshark -D does not list modtap:{port}:\n{listed}")
    pref = preference_prefix(port)
    options = [x for key, value in settings.items() for x in ("-o", f"{pref}.{key}:{value}")]
    return subprocess.Popen(["tshark", "-i", f"modtap:{port}"] + options + ["-a", "duration:8", "-w", pcapng],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def capture_with_fifo(port, pcapng, settings):
    fifo = os.path.join(WORK, "extcap.fifo")
    if os.path.exists(fifo):
        os.unlink(fifo)
    os.mkfifo(fifo)
    options = [x for key, value in settings.items() for x in (f"--{key}", value)]
    extcap = subprocess.Popen([EXTCAP, "--capture", "--extcap-interface", f"modtap:{port}",
                               "--fifo", fifo] + options)
    reader = subprocess.Popen(["tshark", "-r", fifo, "-w", pcapng],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    threading.Timer(8.0, extcap.terminate).start()
    return reader


def capture(name, blocks, settings):
    """Captures `blocks` written into a fresh pty; returns tshark's rows for the packets."""
    master, slave = os.openpty()
    tty.setraw(master)
    tty.setraw(slave)
    port = os.ttyname(slave)
    pcapng = os.path.join(WORK, name + ".pcapng")
    linked, cleanup = link_extcap(EXTCAP)
    how = "tshark" if linked else "fifo"
    try:
        start = capture_with_tshark if linked else capture_with_fifo
        process = start(port, pcapng, settings)
        feed(master, blocks)
        _, err = process.communicate(timeout=60)
    finally:
        cleanup()
        os.close(master)
        os.close(slave)
    os.chmod(pcapng, 0o644)  # dumpcap's file is its user's alone; Wireshark's user reads it
    fields = ["modtap.role", "modtap.check", "modtap.slave", "modbus.func_code", "frame.len",
              "modtap.model", "modtap.register.name"]
    # Out of the box: the plugin and no preference.
    args = ["tshark", "-n", "-r", pcapng, "-T", "fields", "-E", "separator=|"] + \
        [x for f in fields for x in ("-e", f)]
    rows = [dict(zip(fields, line.split("|"))) for line in run(as_user(args, HOME)).splitlines()]
    print(f"{name}: captured through {how}, {len(rows)} packets")
    return rows, err


def run(args):
    return subprocess.run(args, capture_output=True, text=True).stdout


failures = []


def check(name, condition, message):
    if not condition:
        failures.append(f"{name}: {message}")


os.makedirs(WORK, exist_ok=True)
HOME = make_home(WORK, PLUGIN)

# Known frames, and the model chosen in the capture options names the registers.
frames = traffic()
rows, err = capture("known", known_blocks(),
                                  {"baud": "115200", "parity": "none", "model": "nta5000"})
got = [(r["modtap.role"], r["modtap.check"], r["modtap.slave"], r["modbus.func_code"],
        r["frame.len"]) for r in rows]
want = [(role, "ok", str(frame[0]), str(frame[1]), str(len(frame))) for role, frame in frames]
check("known", got == want, f"{got[:3]} != {want[:3]} ({err})")
check("known", rows and (rows[0]["modtap.model"], rows[0]["modtap.register.name"]) == ("nta5000", "F00.00"),
      f"registers not named by the chosen model: {rows[:1]}")

# The simulator's traffic, replayed with its timing: the same frames and roles as modtap finds
# in the simulator's file.
log = os.path.join(WORK, "simulated.log")
subprocess.run([BUSGEN, "-n", "100", "--seed", "31", "--format", "hexlog", "--delivery", "frames",
                "-o", log], check=True, capture_output=True)
expected = [json.loads(line) for line in run([MODTAP, "-r", log, "-T", "json"]).splitlines()]
expected = [r for r in expected if r["type"] == "frame"]
rows, err = capture("simulated", simulated_blocks(log), {"baud": "19200", "parity": "even"})
frames_seen = [r for r in rows if r["modtap.role"]]
check("simulated", [(r["modtap.role"], r["modtap.check"], int(r["frame.len"])) for r in frames_seen] ==
      [(r["role"], r["check"], len(r["raw"]) // 2) for r in expected],
      f"{len(frames_seen)} frames captured, {len(expected)} in the file ({err})")
decodable = expected  # every frame, broadcasts and the short requests included
decoded = [r for r in frames_seen if r["modbus.func_code"]]
check("simulated", len(decoded) == len(decodable),
      f"Wireshark decoded {len(decoded)} of {len(decodable)} frames")

# tshark stops a capture while the bus still talks by closing the FIFO the extcap writes: the
# capture's end, not an error for tshark to show ("Error by extcap pipe: ... Broken pipe").
poll = with_crc([1, 0x03, 0x00, 0x00, 0x00, 0x01])
_, err = capture("stopped", [(i * 0.05, poll) for i in range(200)],
                    {"baud": "115200", "parity": "none"})
check("stopped", "Broken pipe" not in err and "modtap-extcap" not in err, f"tshark said: {err!r}")

# The capture options are checked as modtap checks its own: a setting Wireshark never offers
# is refused by name, before the port is opened.
refused = subprocess.run([EXTCAP, "--capture", "--extcap-interface", "modtap:/dev/null", "--fifo",
                          os.path.join(WORK, "never.fifo"), "--parity", "sideways"],
                         capture_output=True, text=True)
check("options", refused.returncode != 0 and "--parity" in refused.stderr,
      f"--parity sideways gave {refused.returncode}: {refused.stderr!r}")

for f in failures:
    print("FAIL", f)
if failures:
    sys.exit(1)
print("ok: every frame captured live through the extcap, with modtap's roles, classified by "
      "Wireshark, and named by the chosen model")
