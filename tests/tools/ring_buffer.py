#!/usr/bin/python3
"""-b, dumpcap's ring buffer, for -w and --save-raw: files named as dumpcap names them, each a
pcapng tshark reads, the oldest removed past files:N, and nothing lost or split: the packets of
all files in order are the packets of a run without -b, and the raw files, each read alone,
give the same frames. Then the same on a live pty.

usage: ring_buffer.py MODTAP BUSGEN WORKDIR"""
import functools
import glob
import json
import os
import re
import shutil
import subprocess
import sys
import time
import tty

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from checks import failures, verdict  # noqa: E402

MODTAP, BUSGEN, WORK = map(os.path.abspath, sys.argv[1:4])
ENV = dict(os.environ, TZ="UTC")  # the names' time stamps, checked below, are local time


def check(what, got, expected):
    if got == expected:
        return
    if isinstance(got, list) and isinstance(expected, list):
        at = next((i for i, (a, b) in enumerate(zip(got, expected)) if a != b),
                  min(len(got), len(expected)))
        failures.append(f"{what}: {len(got)} items, expected {len(expected)}; first difference "
                        f"at {at}: {got[at:at + 2]!r}, expected {expected[at:at + 2]!r}")
    else:
        failures.append(f"{what}: {got!r}, expected {expected!r}")


def modtap(*args):
    run = subprocess.run([MODTAP, *args], capture_output=True, text=True, env=ENV, timeout=120)
    if run.returncode != 0:
        raise SystemExit(f"FAIL: modtap {' '.join(args)}: exit {run.returncode}: {run.stderr}")
    return run.stdout


@functools.cache
def packets(path):
    """Each packet as tshark reads it: time, interface, comment, bytes. tshark fails on a file
    that is not a whole pcapng."""
    run = subprocess.run(["tshark", "-r", path, "-T", "fields", "-e", "frame.time_epoch",
                          "-e", "frame.interface_name", "-e", "frame.comment", "-e", "data.data"],
                         capture_output=True, text=True, timeout=120)
    if run.returncode != 0:
        failures.append(f"tshark cannot read {path}: {run.stderr.strip()}")
    return run.stdout.splitlines()


def explicit(path):
    """The packets of a file with what each comment leaves to the packets before it said
    (docs/pcapng.md): the record number, and the model of the frame's first byte. Each file of
    a ring starts anew, so its first packets say what the one file's leave out."""
    index, models, out = 0, {}, []
    for line in packets(path):
        time_stamp, interface, comment, data = (line.split("\t") + ["", "", "", ""])[:4]
        keys = comment.split(" ")
        given = [k for k in keys if k.startswith("index=")]
        index = int(given[0][6:]) if given else index + 1
        named = [k for k in keys if k.startswith("model=")]
        if named and data:
            models[data[:2]] = named[0][6:]
        rest = [k for k in keys if not k.startswith(("index=", "model="))]
        model = models.get(data[:2], "none") if "noise=" not in comment else ""
        out.append((time_stamp, interface, index, model, " ".join(rest), data))
    return out


def ring_files(stem, extension):
    """The files of a ring, in order, after checking their names: STEM_NNNNN_YYYYmmddHHMMSS."""
    names = sorted(glob.glob(os.path.join(WORK, f"{stem}_*{extension}")))
    pattern = re.compile(re.escape(stem) + r"_(\d{5})_(\d{14})" + re.escape(extension) + "$")
    for name in names:
        if not pattern.match(os.path.basename(name)):
            failures.append(f"{name} is not named as dumpcap names a ring's files")
    return names


def first_time_stamp(path):
    """The local (UTC) time of the file's first packet, as dumpcap writes it in a name."""
    first = packets(path)[0].split("\t")[0]
    return time.strftime("%Y%m%d%H%M%S", time.gmtime(int(float(first))))


def frames(path):
    """What modtap reads in a raw file: each record's kind, time, bytes and check (not the
    requests whose answers fall in the next file)."""
    records = [json.loads(line) for line in modtap("-r", path, "-T", "json").splitlines()]
    return [(r["type"], r["t_ns"], r.get("raw"), r.get("check")) for r in records
            if r["type"] not in ("timeout", "unanswered")]


def files_of_a_file_read(capture):
    whole = os.path.join(WORK, "whole.pcapng")
    whole_raw = os.path.join(WORK, "whole-raw.pcapng")
    modtap("-r", capture, "-w", whole, "--save-raw", whole_raw)
    modtap("-r", capture, "-w", os.path.join(WORK, "ring.pcapng"), "-b", "filesize:60")
    modtap("-r", capture, "-T", "none", "--save-raw", os.path.join(WORK, "raw.pcapng"),
           "-b", "filesize:20")

    ring = ring_files("ring", ".pcapng")
    if len(ring) < 5:
        failures.append(f"-b filesize:60 on {os.path.getsize(whole)} bytes made {len(ring)} files")
    check("the ring's numbers", [int(os.path.basename(n)[5:10]) for n in ring],
          list(range(1, len(ring) + 1)))
    for name in ring:
        check(f"{name}'s time stamp", os.path.basename(name)[11:25], first_time_stamp(name))
    # A file turns before the record that would take it past the size: by at most one record.
    for name in ring[:-1]:
        if not 60000 <= os.path.getsize(name) < 62000:
            failures.append(f"{name} holds {os.path.getsize(name)} bytes, for -b filesize:60")
    joined = [p for name in ring for p in explicit(name)]
    check("packets of the ring, in order, equal those of one file", joined, explicit(whole))

    raw = ring_files("raw", ".pcapng")
    if len(raw) < 5:
        failures.append(f"--save-raw -b filesize:20 made {len(raw)} files")
    joined = [p for name in raw for p in packets(name)]
    check("reads of the raw ring, in order, equal those of one file", joined, packets(whole_raw))
    # Each raw file begins with a frame: read alone, they give the frames of the whole.
    joined = [f for name in raw for f in frames(name)]
    check("frames of the raw files read one by one", joined, frames(whole_raw))


def files_kept(capture):
    """-b files:3: the three newest remain, numbered as the run counted them."""
    modtap("-r", capture, "-w", os.path.join(WORK, "kept.pcapng"), "-b", "duration:10",
           "-b", "files:3")
    kept = ring_files("kept", ".pcapng")
    numbers = [int(os.path.basename(n)[5:10]) for n in kept]
    check("files kept by -b files:3", len(numbers), 3)
    if numbers and numbers[0] < 2:
        failures.append(f"-b files:3 kept {numbers}: the oldest were not removed")
    if numbers:
        check("the kept files are the newest", numbers, list(range(numbers[0], numbers[0] + 3)))


def hex_log_ring(capture):
    """A raw ring of timed hex logs: the files, joined, are the one file byte for byte."""
    whole = os.path.join(WORK, "whole.log")
    modtap("-r", capture, "-T", "none", "--save-raw", whole)
    modtap("-r", capture, "-T", "none", "--save-raw", os.path.join(WORK, "hex.log"),
           "-b", "filesize:30")
    logs = ring_files("hex", ".log")
    if len(logs) < 2:
        failures.append(f"--save-raw hex.log -b filesize:30 made {len(logs)} files")
    joined = b"".join(open(name, "rb").read() for name in logs)
    check("the hex log ring joined", joined == open(whole, "rb").read(), True)
    joined = [f for name in logs for f in frames(name)]
    check("frames of the hex logs read one by one", joined, frames(whole))


def refusals(capture):
    for args, words in (
            (["-b", "files:3", "-w", "x.pcapng"], "-b files:N"),
            (["-b", "filesize:10"], "give one of them"),
            (["-b", "filesize:10", "-w", "-"], "standard output"),
            (["-b", "size:10", "-w", "x.pcapng"], "-b size:10"),
            (["-b", "duration:0", "-w", "x.pcapng"], "-b duration:0")):
        run = subprocess.run([MODTAP, "-r", capture, *args], capture_output=True, text=True,
                             cwd=WORK, timeout=60)
        check(f"{' '.join(args)}: exit status", run.returncode, 2)
        if words not in run.stderr:
            failures.append(f"{' '.join(args)}: says {run.stderr.strip()!r}")


def live_ring(capture):
    """On a port, files turn by wall time; each is whole, and together they hold every frame
    modtap counted."""
    with open(capture, "rb") as f:
        data = f.read()
    master, slave = os.openpty()
    tty.setraw(master)
    tty.setraw(slave)
    stats = os.path.join(WORK, "live-stats.json")
    run = subprocess.Popen([MODTAP, "-i", os.ttyname(slave), "--baud", "115200", "--parity",
                            "none", "-w", os.path.join(WORK, "live.pcapng"), "-b", "duration:1",
                            "-a", "duration:4", "--stats", stats],
                           stderr=subprocess.PIPE, text=True, env=ENV)
    try:
        deadline = time.time() + 3.5
        at = 0
        while time.time() < deadline and at < len(data):
            os.write(master, data[at:at + 128])
            at += 128
            time.sleep(128 / 11520)
        run.wait(timeout=30)
    finally:
        if run.poll() is None:
            run.kill()
        os.close(master)
        os.close(slave)
    check("live run's exit status", run.returncode, 0)
    live = ring_files("live", ".pcapng")
    if len(live) < 3:
        failures.append(f"-b duration:1 over a 4 s live run made {len(live)} files")
    with open(stats) as f:
        counted = json.load(f)["frames"]
    written = sum(1 for name in live for p in packets(name) if "noise=" not in p)
    check("frames in the live ring", written, counted)
    if counted < 100:
        failures.append(f"only {counted} frames reached modtap live")


def main():
    shutil.rmtree(WORK, ignore_errors=True)
    os.makedirs(WORK)
    capture = os.path.join(WORK, "bus.pcap")
    subprocess.run([BUSGEN, "-n", "1500", "--slaves", "5", "--faults", "--format", "pcap",
                    "--delivery", "bursts", "-o", capture], check=True, stderr=subprocess.DEVNULL)
    files_of_a_file_read(capture)
    files_kept(capture)
    hex_log_ring(capture)
    refusals(capture)
    live_capture = os.path.join(WORK, "live.raw")
    subprocess.run([BUSGEN, "-n", "1500", "--slaves", "4", "-o", live_capture], check=True,
                   stderr=subprocess.DEVNULL)
    live_ring(live_capture)
    return verdict("ring buffer")


if __name__ == "__main__":
    sys.exit(main())
