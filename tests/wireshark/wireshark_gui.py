#!/usr/bin/python3
"""Wireshark itself (Debian's Qt wireshark) under Xvfb opens a modtap pcapng of the simulator's
traffic of every public function code, with modtap's plugin and profile as a user installs
them, and a screenshot shows it: modtap's columns, and rows in the profile's colors (requests,
responses, and the trouble rows: a bad check, no response, noise). Then Wireshark captures
live through modtap-extcap from a pty, and the same colors show as the traffic comes. The
content is tshark's over the same profile (tshark_agreement.py, extcap_test.py); the window is
checked here. The screenshots are kept in WORK_DIR to look at.

Exits 77 (ctest: skipped) with a message when no X server can be started.

usage: wireshark_gui.py MODTAP BUSGEN PLUGIN WORK_DIR EXTCAP"""
import os
import shutil
import subprocess
import sys
import threading
import time
import tty

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from extcap_link import link_extcap, preference_prefix  # noqa: E402
from checks import verdict  # noqa: E402
from modbus import with_crc  # noqa: E402
from wireshark_home import as_user, make_home  # noqa: E402

MODTAP, BUSGEN, PLUGIN, WORK, EXTCAP = map(os.path.abspath, sys.argv[1:6])
WIDTH, HEIGHT = 1600, 1000

# The profile's coloring rules (plugins/wireshark/profile/colorfilters), 16-bit to 8-bit.
COLORS = {
    "request": (238, 255, 238),
    "response": (221, 238, 255),
    "bad check": (255, 170, 170),
    "no response": (255, 204, 153),
    "noise": (204, 204, 204),
    "device fault": (255, 153, 153),
}


def skip(why):
    print(f"SKIP: {why}")
    sys.exit(77)


def start_x():
    """Xvfb on a display it chooses itself (-displayfd), so parallel tests do not collide."""
    if not shutil.which("Xvfb") or not shutil.which("wireshark"):
        skip("Xvfb or wireshark is not installed (scripts/setup.sh installs both)")
    read, write = os.pipe()
    xvfb = subprocess.Popen(["Xvfb", "-displayfd", str(write), "-screen", "0",
                             f"{WIDTH}x{HEIGHT}x24", "-nolisten", "tcp"], pass_fds=(write,),
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write)
    with os.fdopen(read) as f:
        number = f.readline().strip()
    if not number:
        xvfb.kill()
        skip("Xvfb did not start")
    return xvfb, f":{number}"


def user_home():
    """A user's home with the plugin and the profile where a personal install puts them, and
    Wireshark's main window filling the screen (there is no window manager to maximise it)."""
    home = make_home(WORK, PLUGIN)
    recent = os.path.join(home, ".config", "wireshark", "recent_common")
    with open(recent, "w") as f:
        f.write(f"gui.geometry_main_x: 0\ngui.geometry_main_y: 0\n"
                f"gui.geometry_main_width: {WIDTH}\ngui.geometry_main_height: {HEIGHT}\n")
    if os.geteuid() == 0:
        shutil.chown(recent, "nobody", "nogroup")
    return home


def colors_seen(image):
    """Which of the profile's row colors fill at least a row's worth of pixels."""
    counts = {name: 0 for name in COLORS}
    wanted = {rgb: name for name, rgb in COLORS.items()}
    for count, rgb in image.convert("RGB").getcolors(WIDTH * HEIGHT):
        if rgb in wanted:
            counts[wanted[rgb]] += count
    return {name for name, count in counts.items() if count > 2000}


def look(name, command, env, expected, display, feed=None):
    """Runs Wireshark until its window shows rows in every `expected` color (or 90 s pass),
    and keeps the last screenshot. Returns the failures."""
    from PIL import ImageGrab

    log = open(os.path.join(WORK, f"wireshark-{name}.log"), "w")
    wireshark = subprocess.Popen(command, env=env, stdout=log, stderr=subprocess.STDOUT)
    stop = threading.Event()
    if feed:
        threading.Thread(target=feed, args=(stop,), daemon=True).start()
    seen, shot = set(), None
    deadline = time.time() + 90
    try:
        while time.time() < deadline and not expected <= seen:
            time.sleep(2)
            if wireshark.poll() is not None:
                break
            shot = ImageGrab.grab(xdisplay=display)
            seen = colors_seen(shot)
    finally:
        stop.set()
        wireshark.terminate()
        try:
            wireshark.wait(timeout=20)
        except subprocess.TimeoutExpired:
            wireshark.kill()
    if shot is None:
        return [f"{name}: Wireshark ended before showing anything (see wireshark-{name}.log)"]
    path = os.path.join(WORK, f"wireshark-{name}.png")
    shot.save(path)
    print(f"{name}: screenshot {path}; rows colored {sorted(seen)}")
    if not expected <= seen:
        return [f"{name}: the window shows rows colored {sorted(seen)}, expected {sorted(expected)}"]
    return []


def drive_capture():
    """A master polling an NTA5000 drive's fault register (2521H), which reports a fault now and
    then: the model's device-fault finding, in the profile's own color."""
    raw = bytearray()
    for i in range(40):
        raw += with_crc([1, 3, 0x25, 0x21, 0, 1])
        raw += with_crc([1, 3, 2, 0, 3 if i % 4 == 3 else 0])
    path = os.path.join(WORK, "drive.raw")
    with open(path, "wb") as f:
        f.write(raw)
    pcapng = os.path.join(WORK, "drive.pcapng")
    subprocess.run([MODTAP, "-r", path, "--format", "raw", "--model", "nta5000", "-w", pcapng],
                   check=True, stderr=subprocess.DEVNULL)
    return pcapng


def live_traffic(master):
    """A master polling two slaves through the pty, one of which stops answering now and
    then, with a stray byte between polls: requests, responses, no response and noise."""
    def feed(stop):
        time.sleep(3)  # Wireshark starts the extcap, which opens the port
        number = 0
        while not stop.is_set():
            slave = 1 + number % 2
            os.write(master, with_crc([slave, 3, 0, number % 50, 0, 1]))
            time.sleep(0.005)
            if number % 5 != 4:
                os.write(master, with_crc([slave, 3, 2, 0, number % 256]))
            time.sleep(0.05)
            if number % 7 == 3:
                os.write(master, b"\x55")
                time.sleep(0.05)
            number += 1
    return feed


def main():
    shutil.rmtree(WORK, ignore_errors=True)
    os.makedirs(WORK)
    capture = os.path.join(WORK, "bus.pcap")
    subprocess.run([BUSGEN, "-n", "2000", "--seed", "7", "--faults", "--format", "pcap", "-o",
                    capture], check=True, stderr=subprocess.DEVNULL)
    pcapng = os.path.join(WORK, "bus.pcapng")
    subprocess.run([MODTAP, "-r", capture, "-w", pcapng], check=True)
    # The first screen of the capture shows requests and responses, noise and a request
    # that got no answer; a filter for trouble brings the bad checks into view as well.
    views = [("all", []),
             ("trouble", ["-Y", 'modtap.check == "bad" || modtap.timeout || modtap.noise'])]
    expected = {"all": {"request", "response", "noise", "no response"},
                "trouble": {"bad check", "no response", "noise"}}

    xvfb, display = start_x()
    home = user_home()
    env = dict(os.environ, HOME=home, DISPLAY=display, XDG_RUNTIME_DIR=home)
    failures = []
    try:
        for name, extra in views:
            failures += look(name, as_user(["wireshark", "-C", "modtap", "-r", pcapng] + extra,
                                           home), env, expected[name], display)
        failures += look("drive", as_user(["wireshark", "-C", "modtap", "-r", drive_capture()],
                                          home), env, {"device fault", "request", "response"},
                         display)
        linked, cleanup = link_extcap(EXTCAP)
        if not linked:
            print("live: skipped: Wireshark's extcap folder cannot take the build's extcap")
        else:
            master, slave = os.openpty()
            tty.setraw(master)
            tty.setraw(slave)
            port = os.ttyname(slave)
            if os.geteuid() == 0:  # the user Wireshark runs as may read the port, as in dialout
                shutil.chown(port, "nobody")
            prefix = preference_prefix(port)
            try:
                failures += look(
                    "live", as_user(["wireshark", "-C", "modtap", "-k", "-i", f"modtap:{port}",
                                     "-o", f"{prefix}.baud:115200", "-o", f"{prefix}.parity:none"],
                                    home),
                    dict(env, MODTAP_EXTCAP_PORTS=port), {"request", "response", "noise",
                                                          "no response"},
                    display, live_traffic(master))
            finally:
                cleanup()
                os.close(master)
                os.close(slave)
    finally:
        xvfb.terminate()
        xvfb.wait(timeout=20)
    return verdict("wireshark window", failures)


if __name__ == "__main__":
    sys.exit(main())
