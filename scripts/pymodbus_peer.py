#!/usr/bin/python3
"""The second peer of scripts/bench.sh: pymodbus's RTU framer and decoders (Debian's
python3-pymodbus) on the frames of a classic pcap, one frame a packet.

pymodbus frames one direction at a time (a server's framer reads requests, a client's
responses) and drops its buffer at a bad CRC, so it cannot split a raw two-way stream; told
where each frame ends, each packet goes to the request framer, and to the response framer when
that one takes nothing. Prints the frames decoded.

Usage: pymodbus_peer.py CAPTURE.pcap
"""
import logging
import struct
import sys

from pymodbus.factory import ClientDecoder, ServerDecoder
from pymodbus.framer.rtu_framer import ModbusRtuFramer

logging.disable(logging.CRITICAL)


def packets(path):
    with open(path, "rb") as f:
        header = f.read(24)
        endian = "<" if header[:4] in (b"\xd4\xc3\xb2\xa1", b"\x4d\x3c\xb2\xa1") else ">"
        while record := f.read(16):
            _, _, length, _ = struct.unpack(endian + "IIII", record)
            yield f.read(length)


requests = ModbusRtuFramer(ServerDecoder())
responses = ModbusRtuFramer(ClientDecoder())
decoded = 0


def count(_message):
    global decoded
    decoded += 1


for packet in packets(sys.argv[1]):
    before = decoded
    try:
        requests.processIncomingPacket(packet, count, unit=0, single=True)
    except Exception:  # noqa: BLE001 - a frame the request decoder cannot read
        pass
    requests.resetFrame()
    if decoded == before:
        try:
            responses.processIncomingPacket(packet, count, unit=0, single=True)
        except Exception:  # noqa: BLE001
            pass
        responses.resetFrame()
print(decoded)
