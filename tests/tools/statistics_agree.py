"""The statistics (--stats) against the records they count (-T json), on simulator captures
clean and faulty, RTU and ASCII, timed and untimed, with and without a device model: every
count equal, every percentile within the histogram's stated error of the exact one.

usage: statistics_agree.py MODTAP BUSGEN WORKDIR
"""
import collections
import json
import math
import os
import subprocess
import sys

MODTAP, BUSGEN, WORK = sys.argv[1:4]
RELATIVE_ERROR = 1 / 64  # decoder/histogram.hpp

# name: (busgen arguments, modtap arguments)
CAPTURES = {
    "clean-raw": (["-n", "3000"], ["--format", "raw"]),
    "faults-sniffer": (["-n", "6000", "--faults", "--format", "pcap", "--delivery", "sniffer"], []),
    "faults-bytes": (["-n", "4000", "--faults", "--format", "hexlog", "--delivery", "bytes"], []),
    "faults-model": (["-n", "3000", "--faults", "--format", "pcap"], ["--model", "gd20"]),
    "ascii-bursts": (["-n", "2000", "--faults", "--ascii", "--format", "pcap", "--delivery", "bursts"],
                     ["--data-bits", "7"]),
}

failures = []


def check(what, got, want):
    if got != want:
        failures.append(f"{what}: statistics say {got!r:.300}, records say {want!r:.300}")


def counted_latency(frame):
    """A latency that is the slave's: not a late answer's, nor one after another master's
    exchange (BusStatistics::counts_latency)."""
    return (frame["latency_us"] is not None and frame["latency_us"] >= 0
            and not {"late-response", "after-other-master"} & set(frame["findings"]))


def nearest_rank(values, p):
    ordered = sorted(values)
    rank = max(1, math.ceil(p / 100 * len(ordered)))
    return ordered[rank - 1]


def check_percentiles(what, got, values, scale):
    """got: the statistics' object; values: exact values in the object's unit."""
    if not values:
        check(what, got, None)
        return
    check(what + ".count", got["count"], len(values))
    for key, p in (("p50", 50), ("p95", 95), ("p99", 99), ("median", 50)):
        if key not in got:
            continue
        exact = nearest_rank(values, p)
        # The estimate is a bucket's middle; printed values are rounded to 1/scale.
        if abs(got[key] - exact) > exact * RELATIVE_ERROR + 1 / scale:
            failures.append(f"{what}.{key}: {got[key]} is not within 1/64 of {exact}")
    for key, pick in (("min", min), ("max", max)):
        if key in got:
            check(what + "." + key, round(got[key] * scale), round(pick(values) * scale))


def expected(records):
    """The statistics computed the simple way, from the records."""
    frames = [r for r in records if r["type"] == "frame"]
    noise = [r for r in records if r["type"] == "noise"]
    findings = collections.Counter()
    first = collections.defaultdict(list)
    for r in records:  # frames and noise both carry findings
        for name in r.get("findings", []):
            findings[name] += 1  # a model's finding counts for each register that shows it
            if len(first[name]) < 5 and r["index"] not in first[name]:
                first[name].append(r["index"])  # each record once
    e = {
        "frames": len(frames),
        "requests": sum(f["role"] == "request" for f in frames),
        "responses": sum(f["role"] == "response" for f in frames),
        "unknown_roles": sum(f["role"] == "unknown" for f in frames),
        "bad_checks": sum(f["check"] == "bad" for f in frames),
        "exceptions": sum(f["check"] == "ok" and f["role"] == "response" and f["exception"] is not None
                          for f in frames),
        "broadcasts": findings["broadcast"],
        "retries": findings["retry"],
        "unsolicited": findings["unsolicited"],
        "timeouts": sum(r["type"] == "timeout" for r in records),
        "unanswered": sum(r["type"] == "unanswered" for r in records),
        "noise_records": len(noise),
        "noise_bytes": sum(len(n["raw"]) // 2 for n in noise),
        "frame_bytes": sum(len(f["raw"]) // 2 for f in frames),
        "noise": collections.Counter(n["reason"] for n in noise),
        "damaged": collections.Counter(f["damage"] for f in frames if f["damage"]),
        "diagnostics": {name: {"count": n, "first": first[name]} for name, n in findings.items()},
    }
    times = [r["t_ns"] for r in frames + noise] + [r["t_ns"] for r in records if r["type"] == "timeout"]
    ends = [r["end_ns"] for r in frames + noise] + [r["t_ns"] for r in records if r["type"] == "timeout"]
    e["first_t_ns"], e["last_t_ns"] = min(times), max(ends)
    return e


def device(record, slave_of):
    """The slave a record is to or from: a response's or a damaged answer's request says."""
    if record.get("request") is not None and record["request"] in slave_of:
        return slave_of[record["request"]]
    return record.get("slave")


def expected_slaves(records):
    slave_of = {r["index"]: r["slave"] for r in records
                if r["type"] == "frame" and r["role"] == "request"}
    frames = [r for r in records if r["type"] == "frame" and device(r, slave_of) != 0]
    good = {device(f, slave_of) for f in frames if f["check"] == "ok"}
    slaves = {}
    for s in sorted(good):
        mine = [f for f in frames if device(f, slave_of) == s]
        ok = [f for f in mine if f["check"] == "ok"]
        timeouts = [r for r in records if r["type"] == "timeout" and r["slave"] == s]
        garbled = [r for r in records if r["type"] == "noise" and r["damaged_answer"]
                   and device(r, slave_of) == s]

        def counts(frames_of, timeouts_of, garbled_of=None):
            c = {
                "requests": sum(f["role"] == "request" for f in frames_of),
                "responses": sum(f["role"] == "response" for f in frames_of),
                "timeouts": len(timeouts_of),
                "exceptions": sum(f["check"] == "ok" and f["role"] == "response"
                                  and f["exception"] is not None for f in frames_of),
                "bad_checks": sum(f["check"] == "bad" for f in frames_of),
                "retries": sum("retry" in f["findings"] for f in frames_of),
            }
            if garbled_of is not None:
                c["garbled"] = len(garbled_of)
            return c

        by_fc = {}
        for fc in sorted({f["fc"] for f in ok} | {t["fc"] & 0x7F for t in timeouts}):
            by_fc[str(fc)] = counts([f for f in ok if f["fc"] == fc],
                                    [t for t in timeouts if t["fc"] & 0x7F == fc])
        requests = [f["t_ns"] for f in ok if f["role"] == "request"]
        slaves[s] = {
            **counts(mine, timeouts, garbled),
            "exceptions_by_code": dict(collections.Counter(
                str(f["exception"]) for f in ok if f["role"] == "response" and f["exception"] is not None)),
            "by_fc": by_fc,
            "latency": [f["latency_us"] for f in ok if counted_latency(f)],
            "poll": [(b - a) / 1e6 for a, b in zip(requests, requests[1:]) if b >= a],
        }
    stray = {device(f, slave_of) for f in frames} - good
    stray_bad = sum(f["check"] == "bad" for f in frames if device(f, slave_of) in stray)
    return slaves, len(stray), stray_bad


def check_registers(name, stats, records):
    """The last value of each register: what good responses, to reads and to writes, carried."""
    last = {}
    for r in records:
        if r["type"] != "frame" or r["check"] != "ok" or r["slave"] == 0:
            continue
        if r["role"] != "response":
            continue
        for g in r.get("registers", []):
            last[(r["slave"], g["addr"], g["name"])] = (g["raw"], r["t_ns"])
    got = {(g["slave"], g["addr"], g["name"]): (g["raw"], g["t_ns"]) for g in stats["registers"]}
    if stats["register_values_not_kept"] == 0:
        check(f"{name} registers", got, last)
    else:  # those kept are right; the rest were counted
        check(f"{name} kept registers", {k: v for k, v in got.items() if last.get(k) != v}, {})


def compare(name, stats, records):
    e = expected(records)
    for key in ("frames", "requests", "responses", "unknown_roles", "bad_checks", "exceptions",
                "broadcasts", "retries", "unsolicited", "timeouts", "unanswered", "noise_records",
                "noise_bytes", "frame_bytes", "first_t_ns", "last_t_ns"):
        check(f"{name} {key}", stats[key], e[key])
    check(f"{name} bytes", stats["bytes"], e["frame_bytes"] + e["noise_bytes"])
    check(f"{name} noise", {k: v for k, v in stats["noise"].items() if v}, dict(e["noise"]))
    check(f"{name} damaged", {k: v for k, v in stats["damaged"].items() if v}, dict(e["damaged"]))
    check(f"{name} diagnostics",
          {k: {"count": v["count"], "first": v["first"]} for k, v in stats["diagnostics"].items()},
          e["diagnostics"])
    latencies = [f["latency_us"] for f in records if f["type"] == "frame" and f["check"] == "ok"
                 and counted_latency(f)]
    check_percentiles(f"{name} latency_us", stats["latency_us"], latencies, 1000)
    check_registers(name, stats, records)
    slaves, stray, stray_bad = expected_slaves(records)
    check(f"{name} slaves", [s["slave"] for s in stats["slaves"]], list(slaves))
    check(f"{name} stray_addresses", stats["stray_addresses"], stray)
    check(f"{name} stray_bad_checks", stats["stray_bad_checks"], stray_bad)
    for got in stats["slaves"]:
        want = slaves.get(got["slave"])
        if want is None:
            continue
        what = f"{name} slave {got['slave']}"
        for key in ("requests", "responses", "timeouts", "exceptions", "bad_checks", "garbled",
                    "retries", "exceptions_by_code", "by_fc"):
            check(f"{what} {key}", got[key], want[key])
        check_percentiles(f"{what} latency_us", got["latency_us"], want["latency"], 1000)
        check_percentiles(f"{what} poll_interval_ms", got["poll_interval_ms"], want["poll"], 1000)


def run(name, busgen_args, modtap_args):
    capture = os.path.join(WORK, name)
    subprocess.run([BUSGEN, *busgen_args, "-o", capture], check=True, stderr=subprocess.DEVNULL)
    stats_path = capture + ".stats.json"
    out = subprocess.run([MODTAP, "-r", capture, *modtap_args, "-T", "json", "--stats", stats_path],
                         check=True, capture_output=True, text=True).stdout
    records = [json.loads(line) for line in out.splitlines()]
    with open(stats_path) as f:
        stats = json.load(f)
    check(f"{name} complete", stats["complete"], True)
    compare(name, stats, records)
    return capture, records


def main():
    os.makedirs(WORK, exist_ok=True)
    for name, (busgen_args, modtap_args) in CAPTURES.items():
        capture, records = run(name, busgen_args, modtap_args)
        print(f"{name}: {len(records)} records")
    # Every diagnostic the faulty captures should show, shown.
    with open(os.path.join(WORK, "faults-model.stats.json")) as f:
        diagnostics = json.load(f)["diagnostics"]
    for name in ("bad-check", "broadcast", "quantity-out-of-spec", "out-of-range",
                 "garbage-after-request"):
        if name not in diagnostics:
            failures.append(f"faults-model: no {name} among {sorted(diagnostics)}")

    # A capture that breaks off: the statistics cover what was read, marked incomplete.
    capture = os.path.join(WORK, "faults-sniffer")
    with open(capture, "rb") as f:
        data = f.read()
    cut = capture + ".cut.pcap"
    with open(cut, "wb") as f:
        f.write(data[: len(data) * 2 // 3 + 7])
    stats_path = cut + ".stats.json"
    result = subprocess.run([MODTAP, "-r", cut, "-T", "json", "--stats", stats_path],
                            capture_output=True, text=True)
    check("cut capture exit status", result.returncode, 2)
    with open(stats_path) as f:
        stats = json.load(f)
    check("cut capture complete", stats["complete"], False)
    compare("cut capture", stats, [json.loads(line) for line in result.stdout.splitlines()])

    for failure in failures[:40]:
        print("FAIL", failure)
    return 1 if failures else 0


sys.exit(main())
