#!/usr/bin/python3
"""tshark captures live through modtap-extcap, as a Wireshark user would.

A pty stands in for a serial port: MODTAP_EXTCAP_PORTS names it, so `tshark -D` lists it as
modtap:/dev/pts/N. `tshark -i modtap:/dev/pts/N` then captures while known RTU traffic is
written into the pty at 115200 baud, and the packets must be those frames, decoded by
Wireshark's Modbus dissector with the request/response roles modtap gave them, and with the
registers named by the device model chosen in the capture options.

Wireshark 4.0 looks for extcaps only in its global folder (and ignores WIRESHARK_EXTCAP_DIR
when run as root), so the test links the build's modtap-extcap there for its duration, unless
an installed one is already there; it then drives the build's program through the extcap
protocol itself (--capture --fifo), exactly as tshark would, and reads the FIFO with tshark.

Usage: extcap_test.py EXTCAP LUA WORK_DIR
"""
import os
import subprocess
import sys
import threading
import time
import tty

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from modbus import with_crc  # noqa: E402

EXTCAP, LUA, WORK = sys.argv[1:4]
GLOBAL_EXTCAP = "/usr/lib/x86_64-linux-gnu/wireshark/extcap"


def traffic():
    """50 transactions of the echo codes Wireshark cannot classify by length, and reads."""
    frames = []
    for i in range(25):
        write = with_crc([1, 0x06, 0x00, i, 0x12, 0x34])
        frames += [("request", write), ("response", write)]
        frames += [("request", with_crc([2, 0x03, 0x00, i, 0x00, 0x02])),
                   ("response", with_crc([2, 0x03, 0x04, 0x00, i, 0x12, 0x34]))]
    return frames


def feed(master_fd, frames):
    time.sleep(2.0)  # tshark starts the extcap, which opens the port
    for _, frame in frames:
        os.write(master_fd, frame)
        time.sleep(0.005)  # a gap well over t3.5 (1.75 ms) between frames


def link_extcap():
    """Returns (how, cleanup): 'tshark' when tshark can find the build's extcap."""
    target = os.path.join(GLOBAL_EXTCAP, "modtap-extcap")
    if os.path.lexists(target):
        if os.path.realpath(target) == os.path.realpath(EXTCAP):
            return "tshark", lambda: None
        return "fifo", lambda: None
    try:
        os.symlink(os.path.realpath(EXTCAP), target)
    except OSError:
        return "fifo", lambda: None
    return "tshark", lambda: os.unlink(target)


def capture_with_tshark(port, pcapng):
    env = dict(os.environ, MODTAP_EXTCAP_PORTS=port)
    listed = subprocess.run(["tshark", "-D"], capture_output=True, text=True, env=env).stdout
    if f"modtap:{port}" not in listed:
        raise SystemExit(f"tshark -D does not list modtap:{port}:\n{listed}")
    pref = "extcap.modtap_" + "".join(c if c.isalnum() else "_" for c in port)
    return subprocess.Popen(["tshark", "-i", f"modtap:{port}", "-o", f"{pref}.baud:115200",
                             "-o", f"{pref}.parity:none", "-o", f"{pref}.model:nta5000", "-a", "duration:6",
                             "-w", pcapng],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def capture_with_fifo(port, pcapng):
    fifo = os.path.join(WORK, "extcap.fifo")
    if os.path.exists(fifo):
        os.unlink(fifo)
    os.mkfifo(fifo)
    extcap = subprocess.Popen([EXTCAP, "--capture", "--extcap-interface", f"modtap:{port}",
                               "--fifo", fifo, "--baud", "115200", "--parity", "none", "--model", "nta5000"])
    reader = subprocess.Popen(["tshark", "-r", fifo, "-w", pcapng],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    threading.Timer(6.0, extcap.terminate).start()
    return reader


os.makedirs(WORK, exist_ok=True)
master, slave = os.openpty()
tty.setraw(master)
tty.setraw(slave)
port = os.ttyname(slave)
pcapng = os.path.join(WORK, "extcap.pcapng")
frames = traffic()
how, cleanup = link_extcap()
try:
    capture = capture_with_tshark(port, pcapng) if how == "tshark" else capture_with_fifo(port, pcapng)
    feed(master, frames)
    _, err = capture.communicate(timeout=60)
finally:
    cleanup()
rows = subprocess.run(["tshark", "-n", "-r", pcapng, "-X", f"lua_script:{LUA}", "-o",
                       "mbrtu.tcp.port:502", "-T", "fields", "-E", "separator=|", "-e", "modtap.role",
                       "-e", "modtap.check", "-e", "mbrtu.unit_id", "-e", "modbus.func_code",
                       "-e", "frame.len", "-Y", "mbrtu"],
                      capture_output=True, text=True).stdout.splitlines()
expected = [f"{role}|ok|{frame[0]}|{frame[1]}|{len(frame)}" for role, frame in frames]
print(f"captured through {how}: {len(rows)} frames, {len(expected)} written")
if rows != expected:
    print("tshark's stderr:", err)
    for got, want in list(zip(rows, expected))[:10]:
        print(f"  got {got!r}, want {want!r}")
    sys.exit(1)
classified = subprocess.run(["tshark", "-n", "-r", pcapng, "-X", f"lua_script:{LUA}", "-o",
                             "mbrtu.tcp.port:502"], capture_output=True, text=True).stdout
unclassified = [line for line in classified.splitlines() if "Unable to classify" in line]
if unclassified:
    print("unclassified:", unclassified[:3])
    sys.exit(1)
# The registers come named by the model chosen in the capture options: F00.00 is at 0000H.
names = subprocess.run(["tshark", "-n", "-r", pcapng, "-X", f"lua_script:{LUA}", "-T", "fields",
                        "-e", "modtap.model", "-e", "modtap.register.name", "-c", "1"],
                       capture_output=True, text=True).stdout.strip()
if names != "nta5000\tF00.00":
    print("registers not named by the chosen model:", repr(names))
    sys.exit(1)
print("ok: every frame captured live, with modtap's roles and the model's register names, and "
      "classified by Wireshark")
