#!/usr/bin/python3
"""Wireshark's own Modbus decoder as an independent check of modtap.

For simulated scenarios and the real sigrok captures, modtap writes JSON Lines and a pcapng
(DLT_USER0); tshark reads the pcapng with the build's plugin and no preference set,
and must show, frame by frame, the same roles, check verdicts, slaves, function codes and
names, exception codes, request pairs and register values, and with a device model the same
register addresses and names; every frame decoded by Wireshark's Modbus dissector (a frame cut
before its end aside), each response paired with modtap's request. The exported-PDU pcapng must decode with no plugin
at all: every frame classified, and Wireshark's CRC verdict equal to modtap's.

Usage: tshark_agreement.py MODTAP BUSGEN PLUGIN SAMPLES_DIR WORK_DIR
"""
import json
import re
import os
import subprocess
import sys

from wireshark_home import as_user, make_home

MODTAP, BUSGEN, PLUGIN, SAMPLES, WORK = sys.argv[1:6]
TSHARK = "tshark"
FIELDS = ["frame.number", "modtap.role", "modtap.check", "modtap.request", "modtap.slave",
          "modtap.fc", "modtap.function", "modtap.exception",
          "modbus.func_code", "modbus.exception_code", "modbus.request_frame",
          "modbus.regval_uint16", "modtap.model", "modtap.register.addr",
          "modtap.register.name", "_ws.expert.message"]
failures = []


def run(args):
    result = subprocess.run(args, capture_output=True, text=True)
    if result.returncode != 0:
        raise SystemExit(f"{' '.join(args)} failed:\n{result.stderr}")
    return result.stdout


def modtap_records(capture, extra):
    out = run([MODTAP, "-r", capture, "-T", "json"] + extra)
    return [json.loads(line) for line in out.splitlines()]


def tshark_rows(pcapng):
    """Out of the box: the plugin, and no preference."""
    args = [TSHARK, "-n", "-r", pcapng, "-T", "fields", "-E", "separator=|"]
    for f in FIELDS:
        args += ["-e", f]
    rows = {}
    for line in run(as_user(args, HOME)).splitlines():
        values = line.split("|")
        rows[int(values[0])] = dict(zip(FIELDS, values))
        if len(values) != len(FIELDS):
            raise SystemExit(f"tshark row has {len(values)} fields: {line}")
    return rows


def check(name, condition, message):
    if not condition:
        failures.append(f"{name}: {message}")


def compare(name, capture, extra):
    pcapng = os.path.join(WORK, name + ".pcapng")
    run([MODTAP, "-r", capture, "-w", pcapng] + extra)
    records = [r for r in modtap_records(capture, extra) if r["type"] not in ("timeout", "unanswered")]
    rows = tshark_rows(pcapng)
    check(name, len(rows) == len(records), f"{len(rows)} packets for {len(records)} records")
    decoded = set()
    compared = 0
    for r in records:
        row = rows.get(r["index"])
        if row is None:
            check(name, False, f"record {r['index']} has no packet")
            continue
        if r["type"] == "noise":
            continue
        where = f"frame {r['index']}"
        if "model" in r:
            check(name, row["modtap.model"] == r["model"], f"{where}: model {row['modtap.model']!r}")
            addrs = [int(a, 16) for a in row["modtap.register.addr"].split(",") if a]
            names = [n for n in row["modtap.register.name"].split(",") if n]
            theirs = list(zip(addrs, names))
            ours = [(reg["addr"], reg["name"]) for reg in r["registers"] if reg["name"]]
            check(name, len(addrs) == len(names) and theirs == ours,
                  f"{where}: registers {theirs[:4]} != {ours[:4]}")
        check(name, row["modtap.role"] == r["role"], f"{where}: role {row['modtap.role']} != {r['role']}")
        check(name, row["modtap.check"] == r["check"], f"{where}: check {row['modtap.check']} != {r['check']}")
        if r["check"] == "bad":  # the check it should have had, or that it was cut before it
            said = ("the frame was cut before it" if r.get("damage") == "cut"
                    else f"expected 0x{r['expected_check']:0{4 if r['mode'] == 'rtu' else 2}x}")
            check(name, f"Bad check{':' if r.get('damage') == 'cut' else ','} {said}"
                  in row["_ws.expert.message"], f"{where}: expert info {row['_ws.expert.message']!r}")
        if r["request"] is not None:
            check(name, row["modtap.request"] == str(r["request"]), f"{where}: request")
        # Every frame: slave, function code and name as modtap's JSON has them.
        identity = (row["modtap.slave"], row["modtap.fc"], row["modtap.function"])
        fc = r["fc"] & 0x7F
        check(name, identity == (str(r["slave"]), str(fc), r["function"]),
              f"{where}: slave, function {identity} != {(r['slave'], fc, r['function'])}")
        if r["exception"] is not None:
            check(name, row["modtap.exception"] == str(r["exception"]), f"{where}: exception")
        if not row["modbus.func_code"]:
            # Wireshark's Modbus dissector takes every frame but one cut before its end.
            check(name, r.get("damage") == "cut", f"{where}: Wireshark did not decode {r['raw']}")
            continue
        decoded.add(r["index"])
        compared += 1
        check(name, int(row["modbus.func_code"]) == r["fc"], f"{where}: function {row['modbus.func_code']} != {r['fc']}")
        if r["exception"] is not None:
            check(name, row["modbus.exception_code"] == str(r["exception"]), f"{where}: exception")
        if r["role"] == "response" and r["request"] in decoded and r["check"] == "ok":
            # Wireshark 4.0 links no exception response to its request (modtap.request does);
            # it must not link one to another request either.
            expected = ("", str(r["request"])) if r["exception"] is not None else (str(r["request"]),)
            check(name, row["modbus.request_frame"] in expected,
                  f"{where}: Wireshark pairs it with {row['modbus.request_frame']!r}, modtap with {r['request']}")
        if r["role"] == "response" and r["fc"] in (3, 4) and r["exception"] is None and "values" in r:
            theirs = [int(v) for v in row["modbus.regval_uint16"].split(",") if v]
            check(name, theirs == r["values"], f"{where}: registers {theirs} != {r['values']}")
    check(name, compared > 0, "no frame compared")
    print(f"{name}: {len(records)} records, {compared} frames compared with Wireshark's decoder")


def exported_pdu(name, capture, extra):
    """No plugin: stock Wireshark with the modtap profile's one preference."""
    pcapng = os.path.join(WORK, name + "-exported.pcapng")
    run([MODTAP, "-r", capture, "-w", pcapng, "--link", "exported-pdu"] + extra)
    text = run([TSHARK, "-n", "-r", pcapng, "-o", "mbrtu.tcp.port:502"])
    unclassified = [l for l in text.splitlines() if "Unable to classify" in l]
    classified = [l for l in text.splitlines() if " Query: " in l or " Response: " in l]
    check(name, not unclassified, f"exported PDU: {len(unclassified)} frames unclassified")
    check(name, classified, "exported PDU: nothing classified")
    # Wireshark's own CRC check, against modtap's verdict, frame by frame.
    verdicts = run([TSHARK, "-n", "-r", pcapng, "-o", "mbrtu.tcp.port:502", "-o",
                    "mbrtu.crc_verification:TRUE", "-T", "fields", "-e", "frame.number",
                    "-e", "mbrtu.crc16.status"]).splitlines()
    records = {r["index"]: r for r in modtap_records(capture, extra) if r["type"] == "frame"}
    crc_compared = 0
    for line in verdicts:
        number, status = (line.split("\t") + [""])[:2]
        r = records.get(int(number))
        if r is None or not status or r["mode"] != "rtu":
            continue
        crc_compared += 1
        check(name, (status == "1") == (r["check"] == "ok"),
              f"exported PDU frame {number}: Wireshark's CRC verdict {status}, modtap's {r['check']}")
    check(name, crc_compared > 0, "exported PDU: no CRC compared")
    print(f"{name}: exported PDU, {len(classified)} frames classified with no plugin, "
          f"{crc_compared} CRC verdicts compared")


def profile_columns():
    """The modtap profile (as installed among the global profiles, here as a personal one):
    tshark -C modtap shows modtap's columns, and exported-PDU files are classified by it alone."""
    pcapng = os.path.join(WORK, "frames.pcapng")
    records = [r for r in modtap_records(os.path.join(WORK, "frames.pcap"), [])
               if r["type"] == "frame"][:50]
    lines = run(as_user([TSHARK, "-n", "-C", "modtap", "-r", pcapng, "-c", "50"],
                        HOME)).splitlines()
    for r, line in zip(records, lines):
        columns = f" {r['role']} {r['slave']} {r['function']} "
        check("profile", columns in line, f"frame {r['index']}: {line!r} lacks {columns!r}")
    check("profile", len(lines) == 50, f"{len(lines)} lines")
    # A time-out reads in the Findings column as a person says it, with the time waited.
    waits = [f"timeout {r['waited_us'] / 1000:.1f} ms"
             for r in modtap_records(os.path.join(WORK, "frames.pcap"), []) if r["type"] == "timeout"]
    shown = run(as_user([TSHARK, "-n", "-C", "modtap", "-r", pcapng, "-Y", "modtap.no_response"],
                        HOME)).splitlines()
    check("profile", waits and len(shown) == len(waits), f"{len(shown)} time-outs shown, {len(waits)} in JSON")
    for wait, line in zip(waits, shown):
        check("profile", re.search(f"[ ,]{re.escape(wait)} ", line), f"{line!r} lacks {wait!r}")
    exported = os.path.join(WORK, "frames-exported.pcapng")
    text = run(as_user([TSHARK, "-n", "-C", "modtap", "-r", exported], HOME))
    check("profile", "Unable to classify" not in text and " Query: " in text,
          "exported PDU not classified by the profile")
    print("profile: modtap's columns, and exported PDUs classified")


def simulated(name, args, delivery):
    capture = os.path.join(WORK, name + ".pcap")
    run([BUSGEN, "--format", "pcap", "--delivery", delivery, "-o", capture] + args)
    return capture


os.makedirs(WORK, exist_ok=True)
HOME = make_home(WORK, PLUGIN)
scenarios = [
    ("frames", simulated("frames", ["-n", "3000", "--seed", "21"], "frames"), []),
    ("sniffer", simulated("sniffer", ["-n", "3000", "--seed", "22"], "sniffer"), []),
    ("bursts", simulated("bursts", ["-n", "3000", "--seed", "23"], "bursts"), []),
    ("faults", simulated("faults", ["-n", "3000", "--seed", "26", "--faults"], "frames"), []),
    ("gd20", simulated("gd20", ["-n", "3000", "--seed", "24"], "frames"), ["--model", "gd20"]),
    ("ascii", simulated("ascii", ["-n", "1000", "--seed", "25", "--ascii"], "frames"),
     ["--mode", "ascii", "--data-bits", "7"]),
    ("brainchild", os.path.join(SAMPLES, "brainchild-io-16do.sr"),
     ["--baud", "19200", "--parity", "even", "--sigrok-channels", "tx=1,rx=0", "--sigrok-invert"]),
    ("flowmeter", os.path.join(SAMPLES, "flowmeter_target_15liter_per_min.sr"),
     ["--baud", "9600", "--parity", "none", "--sigrok-channels", "bus=RXTX"]),
]
for name, capture, extra in scenarios:
    compare(name, capture, extra)
    if name != "ascii":  # stock Wireshark has no Modbus ASCII dissector to export to
        exported_pdu(name, capture, extra)
profile_columns()

for f in failures[:40]:
    print("FAIL", f)
print(f"{len(scenarios) * 2 - 1 - len({f.split(':')[0] for f in failures})} passed, "
      f"{len({f.split(':')[0] for f in failures})} failed")
sys.exit(1 if failures else 0)
