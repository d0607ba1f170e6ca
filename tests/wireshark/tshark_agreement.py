#!/usr/bin/python3
"""Wireshark's own Modbus decoder as an independent check of modtap.

For simulated scenarios and the real sigrok captures, modtap writes JSON Lines and a pcapng
(DLT_USER0); tshark reads the pcapng with plugins/wireshark/modtap.lua and must show, frame
by frame, the same roles, check verdicts, slaves, function codes, exception codes, request
pairs and register values, and with a device model the same register addresses and names. The
exported-PDU pcapng must decode with no plugin at all, with
every frame mbrtu can take classified as a query or a response.

Usage: tshark_agreement.py MODTAP BUSGEN LUA SAMPLES_DIR WORK_DIR
"""
import json
import os
import subprocess
import sys

MODTAP, BUSGEN, LUA, SAMPLES, WORK = sys.argv[1:6]
TSHARK = "tshark"
FIELDS = ["frame.number", "modtap.role", "modtap.check", "modtap.request", "mbrtu.unit_id",
          "modbus.func_code", "modbus.exception_code", "modbus.request_frame",
          "mbrtu.crc16.status", "modbus.regval_uint16", "modtap.model", "modtap.register.addr",
          "modtap.register.name"]
failures = []


def run(args):
    result = subprocess.run(args, capture_output=True, text=True)
    if result.returncode != 0:
        raise SystemExit(f"{' '.join(args)} failed:\n{result.stderr}")
    return result.stdout


def modtap_records(capture, extra):
    out = run([MODTAP, "-r", capture, "-T", "json"] + extra)
    return [json.loads(line) for line in out.splitlines()]


def tshark_rows(pcapng, lua=True):
    args = [TSHARK, "-n", "-r", pcapng, "-o", "mbrtu.tcp.port:502", "-o",
            "mbrtu.crc_verification:TRUE", "-T", "fields", "-E", "separator=|"]
    if lua:
        args += ["-X", f"lua_script:{LUA}"]
    for f in FIELDS:
        args += ["-e", f]
    rows = {}
    for line in run(args).splitlines():
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
    decoded_by_mbrtu = set()
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
            ours = [(reg["addr"], reg["name"] or "-") for reg in r["registers"]]
            check(name, len(addrs) == len(names) and theirs == ours,
                  f"{where}: registers {theirs[:4]} != {ours[:4]}")
        check(name, row["modtap.role"] == r["role"], f"{where}: role {row['modtap.role']} != {r['role']}")
        check(name, row["modtap.check"] == r["check"], f"{where}: check {row['modtap.check']} != {r['check']}")
        if r["request"] is not None:
            check(name, row["modtap.request"] == str(r["request"]), f"{where}: request")
        if not row["mbrtu.unit_id"]:
            # mbrtu takes no ADU under 5 bytes and no broadcast (unit 0); nothing else may fail.
            check(name, len(r["raw"]) < 10 or r["slave"] == 0 or r["mode"] == "ascii",
                  f"{where}: Wireshark did not decode {r['raw']}")
            continue
        decoded_by_mbrtu.add(r["index"])
        compared += 1
        check(name, int(row["mbrtu.unit_id"]) == r["slave"], f"{where}: slave")
        check(name, int(row["modbus.func_code"]) == r["fc"], f"{where}: function {row['modbus.func_code']} != {r['fc']}")
        if r["exception"] is not None:
            check(name, row["modbus.exception_code"] == str(r["exception"]), f"{where}: exception")
        if r["mode"] == "rtu":
            good = row["mbrtu.crc16.status"] == "1"
            check(name, good == (r["check"] == "ok"), f"{where}: CRC verdict {row['mbrtu.crc16.status']}")
        if r["role"] == "response" and r["request"] in decoded_by_mbrtu and r["check"] == "ok":
            # Wireshark 4.0 links no exception response to its request; it must not link
            # one to another request either.
            expected = ("", str(r["request"])) if r["exception"] is not None else (str(r["request"]),)
            check(name, row["modbus.request_frame"] in expected,
                  f"{where}: Wireshark pairs it with {row['modbus.request_frame']!r}, modtap with {r['request']}")
        if r["role"] == "response" and r["fc"] in (3, 4) and r["exception"] is None and "values" in r:
            theirs = [int(v) for v in row["modbus.regval_uint16"].split(",") if v]
            check(name, theirs == r["values"], f"{where}: registers {theirs} != {r['values']}")
    check(name, compared > 0, "no frame compared")
    print(f"{name}: {len(records)} records, {compared} frames compared with Wireshark's decoder")


def exported_pdu(name, capture, extra):
    pcapng = os.path.join(WORK, name + "-exported.pcapng")
    run([MODTAP, "-r", capture, "-w", pcapng, "--link", "exported-pdu"] + extra)
    text = run([TSHARK, "-n", "-r", pcapng, "-o", "mbrtu.tcp.port:502"])
    unclassified = [l for l in text.splitlines() if "Unable to classify" in l]
    classified = [l for l in text.splitlines() if " Query: " in l or " Response: " in l]
    check(name, not unclassified, f"exported PDU: {len(unclassified)} frames unclassified")
    check(name, classified, "exported PDU: nothing classified")
    print(f"{name}: exported PDU, {len(classified)} frames classified with no plugin")


def simulated(name, args, delivery):
    capture = os.path.join(WORK, name + ".pcap")
    run([BUSGEN, "--format", "pcap", "--delivery", delivery, "-o", capture] + args)
    return capture


os.makedirs(WORK, exist_ok=True)
scenarios = [
    ("frames", simulated("frames", ["-n", "3000", "--seed", "21"], "frames"), []),
    ("sniffer", simulated("sniffer", ["-n", "3000", "--seed", "22"], "sniffer"), []),
    ("bursts", simulated("bursts", ["-n", "3000", "--seed", "23"], "bursts"), []),
    ("gd20", simulated("gd20", ["-n", "3000", "--seed", "24"], "frames"), ["--model", "gd20"]),
    ("brainchild", os.path.join(SAMPLES, "brainchild-io-16do.sr"),
     ["--baud", "19200", "--parity", "even", "--sigrok-channels", "tx=1,rx=0", "--sigrok-invert"]),
    ("flowmeter", os.path.join(SAMPLES, "flowmeter_target_15liter_per_min.sr"),
     ["--baud", "9600", "--parity", "none", "--sigrok-channels", "bus=RXTX"]),
]
for name, capture, extra in scenarios:
    compare(name, capture, extra)
    exported_pdu(name, capture, extra)

for f in failures[:40]:
    print("FAIL", f)
print(f"{len(scenarios) * 2 - len({f.split(':')[0] for f in failures})} passed, "
      f"{len({f.split(':')[0] for f in failures})} failed")
sys.exit(1 if failures else 0)
