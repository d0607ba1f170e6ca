"""-Y against the same selection made over the JSON output: for each filter, modtap's filtered
JSON lines equal the unfiltered lines whose records a plain Python predicate picks. A syntax
error names its column and exits 2.

usage: filter_agrees.py MODTAP BUSGEN WORKDIR
"""
import json
import os
import subprocess
import sys

MODTAP, BUSGEN, WORK = sys.argv[1:4]


def values_of(r, key):
    """Every value of `key` in the record, also inside a list's items (as a filter reads it)."""
    found = []
    for k, v in r.items():
        if k == key and v is not None:
            found += v if isinstance(v, list) else [v]
        if k != "registers" and isinstance(v, list):
            for item in v:
                if isinstance(item, dict):
                    found += values_of(item, key)
    return found


FILTERS = {
    "slave == 3 || slave == 200 && fc == 6": lambda r: r.get("slave") == 3
    or (r.get("slave") == 200 and r.get("fc") == 6),
    "latency_us > 5000": lambda r: (r.get("latency_us") or 0) > 5000,
    "finding": lambda r: bool(r.get("findings")),
    "type == noise && reason == glitch": lambda r: r["type"] == "noise" and r["reason"] == "glitch",
    "retry || unsolicited": lambda r: bool({"retry", "unsolicited"} & set(r.get("findings", []))),
    "check == bad": lambda r: r.get("check") == "bad",
    "!(role == request)": lambda r: r.get("role") != "request",
    "address >= 1000H && address < 2000H": lambda r: 0x1000 <= (r.get("address") or -1) < 0x2000,
    "values == 0": lambda r: 0 in values_of(r, "values"),
    "exception == 2 || exception == 3": lambda r: r.get("exception") in (2, 3),
    "type == timeout": lambda r: r["type"] == "timeout",
    "function == \"Diagnostics\" and sub_function == 0": lambda r: r.get("function") == "Diagnostics"
    and r.get("sub_function") == 0,
    "value": lambda r: bool(values_of(r, "value")),
    "register.name == \"P00.04\" || out-of-range": lambda r: any(
        g["name"] == "P00.04" for g in r.get("registers", [])) or "out-of-range" in r.get("findings", []),
    "P01.02 >= 0": lambda r: any(g["name"] == "P01.02" for g in r.get("registers", [])),
    "waited_us > 10000": lambda r: (r.get("waited_us") or 0) > 10000,
}


def main():
    os.makedirs(WORK, exist_ok=True)
    capture = os.path.join(WORK, "faults.pcap")
    subprocess.run([BUSGEN, "-n", "4000", "--faults", "--format", "pcap", "--delivery", "sniffer",
                    "-o", capture], check=True, stderr=subprocess.DEVNULL)
    base = [MODTAP, "-r", capture, "--model", "gd20", "-T", "json"]
    lines = subprocess.run(base, check=True, capture_output=True, text=True).stdout.splitlines()
    records = [json.loads(line) for line in lines]
    failures = []
    for text, pick in FILTERS.items():
        want = [line for line, r in zip(lines, records) if pick(r)]
        got = subprocess.run(base + ["-Y", text], check=True, capture_output=True,
                             text=True).stdout.splitlines()
        print(f"{text}: {len(got)} of {len(lines)} records")
        if got != want:
            failures.append(f"-Y '{text}': {len(got)} records, the JSON selection has {len(want)}")
        if not want:
            failures.append(f"-Y '{text}': selects nothing on this capture: a weak check")
    bad = subprocess.run(base + ["-Y", "slave == 3 && fc =="], capture_output=True, text=True)
    if bad.returncode != 2 or bad.stderr.strip() != "modtap: -Y: column 20: expected a value after ==":
        failures.append(f"a syntax error: exit {bad.returncode}, {bad.stderr.strip()!r}")
    for f in failures:
        print("FAIL", f)
    return 1 if failures else 0


sys.exit(main())
