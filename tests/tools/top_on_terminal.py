#!/usr/bin/python3
"""modtap top as a technician sees it: in Debian's tmux, on a pseudo-terminal that carries the
bus simulator's traffic in real time (four slaves: slave 3 absent, slave 2 slow).

The screen must show the slaves with their rates and the injected problems on the right rows;
keys sort, choose a slave, filter, pause, write pcapng and quit; a resize redraws to the new
size; the run's --stats equal what was sent. A replay of a file (-r) ends on the numbers -T
stats gives; without a terminal (TERM=dumb, a pipe) the screen is printed as plain text; and a
terminal that reads nothing (a slow SSH link) does not hold the capture back.

Usage: top_on_terminal.py MODTAP BUSGEN WORK_DIR
"""
import glob
import json
import math
import os
import re
import subprocess
import sys
import threading
import time
import tty

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from modbus import replay, simulated_blocks, wait_until_open  # noqa: E402

MODTAP, BUSGEN, WORK = sys.argv[1:4]
SESSION = "modtap-top-test"
failures = []


def check(name, condition, message):
    if not condition:
        failures.append(f"{name}: {message}")
    return condition


def tmux(*args):
    return subprocess.run(["tmux", "-L", SESSION, *args], capture_output=True, text=True,
                          check=False).stdout


def screen():
    return tmux("capture-pane", "-p", "-t", SESSION).splitlines()


def keys(*sent):
    tmux("send-keys", "-t", SESSION, *sent)
    time.sleep(0.4)


def wait_for(condition, seconds=20):
    deadline = time.time() + seconds
    while time.time() < deadline:
        lines = screen()
        if condition(lines):
            return lines
        time.sleep(0.2)
    return screen()


def slave_row(lines, slave):
    """The slave table's row of `slave`, as a list of cells."""
    for line in lines:
        cells = line.split()
        if len(cells) > 10 and cells[0] == str(slave) and cells[1] != "slave":
            return cells
    return None


def table(lines):
    heading = next(i for i, line in enumerate(lines) if line.lstrip().startswith("slave"))
    rows = []
    for line in lines[heading + 1:]:
        cells = line.split()
        if not cells or not cells[0].isdigit():
            break
        rows.append(cells)
    return lines[heading], rows


def panel(lines):
    """The transactions panel's lines, under its heading."""
    at = next(i for i, line in enumerate(lines) if "transactions" in line)
    return [line for line in lines[at + 1:-1] if line.strip()]


def simulate(name, *options):
    path = os.path.join(WORK, name)
    subprocess.run([BUSGEN, "--slaves", "4", "--seed", "3", "--slave-fault", "3:absent",
                    "--slave-fault", "2:slow=131ms", *options, "-o", path],
                   check=True, capture_output=True)
    return path


def stats_of(capture, *options):
    out = os.path.join(WORK, "truth.json")
    subprocess.run([MODTAP, "-r", capture, "-q", "--stats", out, *options], check=True,
                   timeout=120)
    with open(out) as f:
        return json.load(f)


def live_screen():
    log = simulate("live.log", "-n", "160", "--format", "hexlog", "--delivery", "frames")
    truth = stats_of(log)
    master, slave = os.openpty()
    tty.setraw(master)
    tty.setraw(slave)
    port = os.ttyname(slave)
    stats = os.path.join(WORK, "live-stats.json")
    tmux("kill-server")
    tmux("new-session", "-d", "-s", SESSION, "-x", "80", "-y", "24", "-c", WORK,
         f"{MODTAP} top -i {port} --baud 19200 --stats {stats}; sleep 60")
    lines = wait_for(lambda lines: any("modtap top" in line for line in lines))
    check("start", any(f"port {port}" in line for line in lines), "\n".join(lines))
    feeder = threading.Thread(target=replay, args=(simulated_blocks(log), [master]))
    feeder.start()

    # The faulty slaves on their rows, while the traffic flows.
    lines = wait_for(lambda l: (slave_row(l, 3) or [""])[-1].startswith("no-resp")
                     and (slave_row(l, 2) or [""])[-1].startswith("slow-resp"))
    check("rows", all(slave_row(lines, s) for s in (1, 2, 3, 4)), "\n".join(lines))
    check("no-response row", (slave_row(lines, 3) or [""])[-1].startswith("no-resp"),
          "\n".join(lines))
    check("slow row", (slave_row(lines, 2) or [""])[-1].startswith("slow-resp"),
          "\n".join(lines))
    check("never answered", (slave_row(lines, 3) or [""] * 11)[10] == "-",
          "slave 3 never answered, yet its row says it was seen")
    check("slow latency", float((slave_row(lines, 2) or ["0"] * 9)[8]) > 100,
          "slave 2's p50 is not its 131 ms turnaround")
    rate = re.search(r"(\d+) frames/s", lines[1])
    check("rate", rate and int(rate.group(1)) > 0, lines[1])
    check("size", len(lines) == 24 and all(len(line) <= 80 for line in lines),
          f"{len(lines)} lines")

    # Sort by time-outs, the most first: slave 3, which never answers, heads the table.
    keys(">", ">", ">", ">", "r")
    lines = screen()
    _, rows = table(lines)
    check("sort", "sorted by t/o, down" in lines[3] and rows and rows[0][0] == "3",
          f"{lines[3]!r}, first row {rows[:1]}")

    # Choose the first row (slave 3): the panel shows its transactions only.
    keys("Up", "Up", "Up", "Up", "Enter")
    time.sleep(1.2)
    lines = screen()
    shown = panel(lines)
    check("choose", any("transactions of slave 3" in line for line in lines), "\n".join(lines))
    check("choose", shown and all("slave 3" in line for line in shown), "\n".join(shown))
    keys("Escape")

    # A filter: only slave 1's responses from now on.
    keys("/")
    tmux("send-keys", "-t", SESSION, "-l", "slave == 1 && role == rsp")
    keys("Enter")
    time.sleep(2.5)
    lines = screen()
    shown = panel(lines)
    check("filter", shown and all("rsp slave 1 " in line for line in shown), "\n".join(lines))
    check("filter", any("filter: slave == 1 && role == rsp" in line for line in lines),
          "the filter is not shown")
    keys("/", "Enter")

    # Pause: the screen stays as it is while frames go on coming.
    keys("p")
    paused = screen()
    time.sleep(2.2)
    check("pause", screen() == paused and any("PAUSED" in line for line in paused),
          "the paused screen changed")
    keys("p")

    # w: the frames that follow, to a pcapng file modtap reads back.
    keys("w")
    time.sleep(2)
    keys("w")
    lines = screen()
    written = re.search(r"wrote (\S+\.pcapng) \((\d+) packets\)", "\n".join(lines))
    if check("write", written, "\n".join(lines)):
        out = subprocess.run([MODTAP, "-r", os.path.join(WORK, written.group(1)), "-T", "json"],
                             capture_output=True, text=True).stdout.splitlines()
        packets = [r for r in map(json.loads, out) if r["type"] in ("frame", "noise")]
        check("write", int(written.group(2)) > 0 and len(packets) == int(written.group(2)),
              f"{len(packets)} frames and noise read back, {written.group(2)} written")

    # A bigger terminal: every line drawn again to its size.
    tmux("resize-window", "-t", SESSION, "-x", "132", "-y", "40")
    time.sleep(1.5)
    lines = screen()
    check("resize", len(lines) == 40 and lines[-1].startswith("q quit")
          and any("corrupted" in l or "no-response" in l for l in lines), f"{len(lines)} lines")
    check("resize", (slave_row(lines, 2) or [""])[-1] == "slow-response", "\n".join(lines))

    feeder.join()
    time.sleep(1.5)
    keys("q")
    time.sleep(1)
    check("quit", not any("modtap top" in line for line in screen()), "\n".join(screen()))
    try:
        with open(stats) as f:
            got = json.load(f)
        check("stats", got["frames"] == truth["frames"] and got["timeouts"] == truth["timeouts"],
              f"{got['frames']} frames and {got['timeouts']} time-outs, {truth['frames']} and "
              f"{truth['timeouts']} sent")
    except (OSError, ValueError) as e:
        check("stats", False, f"{stats}: {e}")
    tmux("kill-server")
    os.close(master)
    os.close(slave)


def replay_ends_on_the_statistics():
    capture = simulate("replay.pcap", "-n", "300", "--format", "pcap", "--faults",
                       "--slave-fault", "4:late")
    # Told the master's 200 ms time-out, slave 4's answers are late: time-outs, not answers.
    truth = stats_of(capture, "--timeout", "0.2")
    tmux("kill-server")
    tmux("new-session", "-d", "-s", SESSION, "-x", "100", "-y", "30", "-c", WORK,
         f"{MODTAP} top -r {capture} --speed 1000 --timeout 0.2; sleep 60")
    lines = wait_for(lambda lines: "end of capture" in lines[0] if lines else False)
    numbers = re.search(r"(\d+) frames +(\d+) bad checks +(\d+) noise", lines[1])
    check("replay", numbers and [int(n) for n in numbers.groups()] ==
          [truth["frames"], truth["bad_checks"], truth["noise_records"]],
          f"{lines[1]!r}: {truth['frames']} frames, {truth['bad_checks']} bad checks, "
          f"{truth['noise_records']} noise")
    # ans%: the answers in time (late ones are time-outs), as --stats counts them.
    for slave in truth["slaves"]:
        row = slave_row(lines, slave["slave"])
        in_time = slave["responses"] - slave["late_responses"]
        answered = math.floor(100 * in_time / slave["requests"]) if slave["requests"] else None
        check("replay", row and int(row[2]) == slave["requests"] and
              int(row[4]) == slave["timeouts"] and
              row[3] == (str(answered) if answered is not None else "-"),
              f"slave {slave['slave']}: {row}, {slave}")
    late = next(s for s in truth["slaves"] if s["slave"] == 4)
    check("replay", late["late_responses"] > 0, f"slave 4 answered none late: {late}")
    keys("q")

    # TERM=dumb on a terminal 100 columns wide, a session of its own beside the first: the
    # plain pages are as wide as the terminal, so no line wraps (joined again, none is longer).
    dumb = "dumb"
    tmux("new-session", "-d", "-s", dumb, "-x", "100", "-y", "30", "-c", WORK,
         f"env TERM=dumb {MODTAP} top -r {capture} --speed 1000; sleep 60")
    deadline = time.time() + 30
    joined = []
    while time.time() < deadline and not any("end of capture" in line for line in joined):
        time.sleep(0.3)
        joined = tmux("capture-pane", "-p", "-J", "-S", "-200", "-t", dumb).splitlines()
    check("dumb terminal", joined and max(map(len, joined)) <= 100,
          f"{max(map(len, joined), default=0)} columns on a terminal of 100: {joined[-3:]}")
    tmux("kill-server")

    plain = subprocess.run([MODTAP, "top", "-r", capture, "--speed", "1000"], env={
        **os.environ, "TERM": "dumb"}, capture_output=True, text=True, timeout=120)
    lines = plain.stdout.splitlines()
    last = lines[max(i for i, line in enumerate(lines) if line.startswith("modtap top")):]
    check("plain", plain.returncode == 0 and "end of capture" in last[0]
          and f"{truth['frames']} frames" in last[1] and "\x1b" not in plain.stdout,
          plain.stdout[-2000:] + plain.stderr)
    # A capture that breaks off says so on its last screen, and the run fails after it.
    cut = os.path.join(WORK, "cut.pcap")
    with open(capture, "rb") as whole, open(cut, "wb") as part:
        part.write(whole.read(os.path.getsize(capture) * 2 // 3))
    broken = subprocess.run([MODTAP, "top", "-r", cut, "--speed", "1000"],
                            env={**os.environ, "TERM": "dumb"}, capture_output=True, text=True,
                            timeout=120)
    titles = [line for line in broken.stdout.splitlines() if line.startswith("modtap top")]
    check("broken capture", broken.returncode == 2 and titles and
          "the capture broke off" in titles[-1] and "truncated" in broken.stderr,
          f"exit status {broken.returncode}, {titles[-1:]}, {broken.stderr!r}")
    # The reader goes away after one line: the replay stops at the next screen, quietly, and
    # does not end in success, as modtap's own lines into `head` do.
    head = subprocess.run(f"{MODTAP} top -r {capture} --speed 10 | head -1; "
                          "exit ${PIPESTATUS[0]}", shell=True, executable="/bin/bash",
                          env={**os.environ, "TERM": "dumb"}, capture_output=True, text=True,
                          timeout=60)
    check("pipe closed", head.returncode == 2 and not head.stderr,
          f"exit status {head.returncode}: {head.stderr!r}")


def waits_on_terminal(process):
    """Whether a thread of `process` is blocked writing to its terminal."""
    tasks = f"/proc/{process.pid}/task"
    return any(open(os.path.join(tasks, t, "wchan")).read() in ("wait_woken", "n_tty_write")
               for t in os.listdir(tasks))


def slow_terminal_loses_nothing():
    """The screen's terminal stopped (XOFF, Ctrl-S, as a stalled SSH link): the screen's
    writes block, the capture must not."""
    log = simulate("slow.log", "-n", "60", "--format", "hexlog", "--delivery", "frames")
    truth = stats_of(log)
    bus_master, bus_slave = os.openpty()
    tty.setraw(bus_master)
    tty.setraw(bus_slave)
    term_master, term_slave = os.openpty()
    stats = os.path.join(WORK, "slow-stats.json")
    modtap = subprocess.Popen([MODTAP, "top", "-i", os.ttyname(bus_slave), "--baud", "19200",
                               "--stats", stats], stdin=term_slave, stdout=term_slave,
                              stderr=subprocess.DEVNULL, env={**os.environ, "TERM": "xterm"})
    check("slow terminal", wait_until_open(modtap, os.ttyname(bus_slave)),
          "the port never opened")
    time.sleep(0.5)
    os.write(term_master, b"\x13")
    replay(simulated_blocks(log), [bus_master])
    time.sleep(1)
    check("slow terminal", waits_on_terminal(modtap), "the screen never waited on its terminal")
    modtap.terminate()
    os.write(term_master, b"\x11")
    drained = threading.Thread(target=lambda: drain(term_master, modtap))
    drained.start()
    modtap.wait(timeout=30)
    drained.join()
    with open(stats) as f:
        got = json.load(f)
    check("slow terminal", got["frames"] == truth["frames"],
          f"{got['frames']} frames read, {truth['frames']} sent")
    # Read as the bus ran, not in a heap once the terminal drained: the slow slave's latency
    # is its turnaround.
    latency = {s["slave"]: s["latency_us"]["p50"] for s in got["slaves"] if s["latency_us"]}
    check("slow terminal", abs(latency.get(2, 0) - 133000) < 5000,
          f"slave 2's latency reads {latency.get(2)} us")
    for fd in (bus_master, bus_slave, term_master, term_slave):
        os.close(fd)


def drain(fd, process):
    """What a terminal does at last: reads what was written, until the program ends."""
    os.set_blocking(fd, False)
    while process.poll() is None:
        try:
            os.read(fd, 65536)
        except BlockingIOError:
            time.sleep(0.05)
        except OSError:
            return


def main():
    os.makedirs(WORK, exist_ok=True)
    for old in glob.glob(os.path.join(WORK, "modtap-top-*.pcapng")):
        os.remove(old)
    try:
        live_screen()
        replay_ends_on_the_statistics()
        slow_terminal_loses_nothing()
    finally:
        tmux("kill-server")
    for failure in failures:
        print("FAIL", failure)
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
