#!/usr/bin/python3
"""Writes the fuzzers' seed corpora (tests/fuzz/corpus/TARGET/) from the simulator, the bundled
captures and the models. Run from the repository root after building:

    /usr/bin/python3 tests/fuzz/make_corpus.py build
"""
import os
import shutil
import struct
import subprocess
import sys

BUILD = sys.argv[1]
BUSGEN = os.path.join(BUILD, "tools/busgen/modtap-bus-simulator")
OUT = "tests/fuzz/corpus"


def seed(target, name, data):
    os.makedirs(os.path.join(OUT, target), exist_ok=True)
    with open(os.path.join(OUT, target, name), "wb") as f:
        f.write(data)


def busgen(*args):
    return subprocess.run([BUSGEN, "-o", "-", *args], capture_output=True, check=True).stdout


def pcap_packets(data):
    """The packets of a classic pcap file (what busgen writes)."""
    at, packets = 24, []
    while at + 16 <= len(data):
        length = struct.unpack_from("<I", data, at + 8)[0]
        packets.append(data[at + 16:at + 16 + length])
        at += 16 + length
    return packets


def lrc_line(frame):
    """An RTU frame's ADU (CRC dropped) as an ASCII line."""
    body = frame[:-2]
    lrc = (-sum(body)) & 0xFF
    return b":" + (body.hex().upper() + f"{lrc:02X}").encode() + b"\r\n"


def framing_input(setup, pieces, gap=12):
    """The framing fuzzers' layout: a setup byte, then (length-1, gap, bytes) per chunk."""
    out = bytearray([setup])
    for piece in pieces:
        for at in range(0, len(piece), 128):
            part = piece[at:at + 128]
            out += bytes([len(part) - 1, gap]) + part
    return bytes(out)


for target in ("rtu", "ascii", "pdu", "hexlog", "pcap", "sigrok", "model_yaml"):
    shutil.rmtree(os.path.join(OUT, target), ignore_errors=True)

for n, s in enumerate((1, 2, 3, 4)):
    subprocess.run([BUSGEN, "-n", "12", "--seed", str(s), "--format", "pcap", "--delivery",
                           "frames", "-o", f"/tmp/modtap-seed{s}.pcap"], check=True)
    data = open(f"/tmp/modtap-seed{s}.pcap", "rb").read()
    frames = pcap_packets(data)
    seed("pcap", f"busgen-{s}.pcap", data)
    seed("rtu", f"busgen-{s}", framing_input(n * 3, frames))
    seed("rtu", f"busgen-{s}-bytes", framing_input(n * 3 + 1, [bytes([b]) for f in frames for b in f], 1))
    seed("ascii", f"busgen-{s}", framing_input(n * 3, [lrc_line(f) for f in frames]))
    for i, (req, rsp) in enumerate(zip(frames[::2], frames[1::2])):
        if i < 6:
            seed("pdu", f"busgen-{s}-{i}", bytes([1 | ((req[0] << 2) & 0x7C), len(req) - 3]) + req[1:-2] + rsp[1:-2])
            seed("pdu", f"busgen-{s}-{i}-request", bytes([(req[0] << 2) & 0x7C, 0]) + req[1:-2])
    subprocess.run([BUSGEN, "-n", "6", "--seed", str(s), "--format", "hexlog",
                             "--delivery", "sniffer", "-o", f"/tmp/modtap-seed{s}.log"], check=True)
    seed("hexlog", f"busgen-{s}.log", open(f"/tmp/modtap-seed{s}.log", "rb").read())

seed("hexlog", "drives-manual-examples.log", open("captures/samples/drives-manual-examples.log", "rb").read())
subprocess.run([os.path.join(BUILD, "tools/modtap/modtap"), "-r", "captures/samples/drives-manual-examples.log",
                "-w", "/tmp/modtap-seed.pcapng", "-T", "none"], check=True)
seed("pcap", "drives-manual-examples.pcapng", open("/tmp/modtap-seed.pcapng", "rb").read())

sample = "captures/samples/brainchild-io-16do.sr"
show = subprocess.run(["sigrok-cli", "-i", sample, "--show"], capture_output=True, check=True).stdout
seed("sigrok", "show", show)
uart = subprocess.run(["sigrok-cli", "-i", sample, "-P", "uart:rx=1:baudrate=19200:parity=even:invert_rx=yes",
                       "-A", "uart=rx-data", "--protocol-decoder-samplenum"], capture_output=True, check=True).stdout
for i, line in enumerate(uart.splitlines()[:4]):
    seed("sigrok", f"uart-{i}", line + b"\n")

for name in sorted(os.listdir("plugins/models")):
    if name.endswith(".yaml"):
        seed("model_yaml", name, open(os.path.join("plugins/models", name), "rb").read())
