#!/usr/bin/python3
"""--metrics as Prometheus sees it: modtap listens on a pty that carries simulator traffic,
a real Prometheus server (Debian's package) scrapes it, and what Prometheus holds equals what
modtap's --stats says at the end, the problems found too (slave 4 is absent); promtool accepts
the exposition.

usage: metrics_prometheus.py MODTAP BUSGEN WORKDIR"""
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import tty
import urllib.parse
import urllib.request

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from checks import check, failures, free_port  # noqa: E402

MODTAP, BUSGEN, WORK = sys.argv[1:4]


def get(url, timeout=2):
    with urllib.request.urlopen(url, timeout=timeout) as response:
        return response.status, response.headers.get("Content-Type"), response.read().decode()


def wait_for(url, seconds=30):
    deadline = time.time() + seconds
    while time.time() < deadline:
        try:
            return get(url)
        except OSError:
            time.sleep(0.1)
    raise SystemExit(f"FAIL: nothing answers {url} after {seconds} s")


def start_prometheus(target, port):
    config = os.path.join(WORK, "prometheus.yml")
    with open(config, "w") as f:
        f.write("global:\n  scrape_interval: 1s\n  scrape_timeout: 1s\n"
                "scrape_configs:\n  - job_name: modtap\n    static_configs:\n"
                f"      - targets: ['{target}']\n")
    tsdb = os.path.join(WORK, "tsdb")
    shutil.rmtree(tsdb, ignore_errors=True)
    log = open(os.path.join(WORK, "prometheus.log"), "w")
    process = subprocess.Popen(["prometheus", f"--config.file={config}",
                                f"--storage.tsdb.path={tsdb}",
                                f"--web.listen-address=127.0.0.1:{port}"],
                               stdout=log, stderr=subprocess.STDOUT)
    wait_for(f"http://127.0.0.1:{port}/-/ready")
    return process


def query(port, expression):
    """The instant vector of `expression`: {frozenset(labels minus job/instance): value}."""
    url = f"http://127.0.0.1:{port}/api/v1/query?" + urllib.parse.urlencode({"query": expression})
    body = json.loads(get(url)[2])
    if body["status"] != "success":
        raise SystemExit(f"FAIL: {expression}: {body}")
    result = {}
    for sample in body["data"]["result"]:
        labels = {k: v for k, v in sample["metric"].items()
                  if k not in ("job", "instance", "__name__")}
        result[frozenset(labels.items())] = float(sample["value"][1])
    return result


def scalar(port, expression):
    values = query(port, expression)
    return next(iter(values.values())) if values else None


def feed(pty_master, data, rate):
    """Writes the capture in reads of 128 bytes at about `rate` bytes a second."""
    for at in range(0, len(data), 128):
        os.write(pty_master, data[at:at + 128])
        time.sleep(128 / rate)


def refusals():
    """A port already taken, and an address that is none: a message naming it, exit 2."""
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        address = f"127.0.0.1:{taken.getsockname()[1]}"
        capture = os.path.join(WORK, "scan.raw")
        for bad, words in ((address, "Address already in use"), ("nowhere", "HOST:PORT")):
            run = subprocess.run([MODTAP, "-r", capture, "-q", "--metrics", bad],
                                 capture_output=True, text=True, timeout=60)
            check(f"--metrics {bad} exit status", run.returncode, 2)
            if bad not in run.stderr or words not in run.stderr:
                failures.append(f"--metrics {bad}: says {run.stderr.strip()!r}")


def main():
    os.makedirs(WORK, exist_ok=True)
    capture = os.path.join(WORK, "scan.raw")
    subprocess.run([BUSGEN, "-n", "1500", "--slaves", "4", "--faults", "--slave-fault",
                    "4:absent", "-o", capture],
                   check=True, stderr=subprocess.DEVNULL)
    with open(capture, "rb") as f:
        data = f.read()
    refusals()

    master, slave = os.openpty()
    tty.setraw(master)
    tty.setraw(slave)
    metrics_port, prometheus_port = free_port(), free_port()
    stats_path = os.path.join(WORK, "stats.json")
    modtap = subprocess.Popen([MODTAP, "-i", os.ttyname(slave), "--baud", "115200", "--parity",
                               "none", "--metrics", f"127.0.0.1:{metrics_port}", "-q",
                               "--stats", stats_path], stderr=subprocess.PIPE, text=True)
    prometheus = None
    try:
        metrics_url = f"http://127.0.0.1:{metrics_port}/metrics"
        status, content_type, _ = wait_for(metrics_url)
        check("status", status, 200)
        check("content type", content_type, "text/plain; version=0.0.4; charset=utf-8")
        prometheus = start_prometheus(f"127.0.0.1:{metrics_port}", prometheus_port)

        half = len(data) // 2
        feed(master, data[:half], 11520)
        while_running = get(metrics_url)[2]
        feed(master, data[half:], 11520)
        # A last request's time-out (1 s of silence), then two scrapes after it.
        time.sleep(1.5)
        settled = time.time()
        final = get(metrics_url)[2]
        deadline = time.time() + 20
        while time.time() < deadline:
            stamp = scalar(prometheus_port, "timestamp(modtap_frames_total)")
            if stamp and stamp > settled + 1:
                break
            time.sleep(0.5)
        else:
            failures.append("Prometheus did not scrape modtap after the traffic ended")

        lint = subprocess.run(["promtool", "check", "metrics"], input=final, capture_output=True,
                              text=True)
        check("promtool check metrics", (lint.returncode, lint.stdout + lint.stderr), (0, ""))
        frames_then = [line for line in while_running.splitlines()
                       if line.startswith("modtap_frames_total ")]
        frames_then = int(frames_then[0].split()[1]) if frames_then else 0
        if not 0 < frames_then:
            failures.append(f"while the traffic ran, modtap_frames_total was {frames_then}")

        got = {name: query(prometheus_port, name) for name in (
            "modtap_frames_total", "modtap_noise_bytes_total", "modtap_broadcasts_total",
            "modtap_requests_total", "modtap_responses_total", "modtap_timeouts_total",
            "modtap_retries_total", "modtap_bad_checks_total", "modtap_exceptions_total",
            "modtap_response_latency_seconds_count", "modtap_findings_total", "modtap_problem")}
        infinite = query(prometheus_port, 'modtap_response_latency_seconds_bucket{le="+Inf"}')
    finally:
        modtap.send_signal(signal.SIGTERM)
        try:
            modtap.wait(timeout=20)
        except subprocess.TimeoutExpired:
            modtap.kill()
            failures.append("modtap did not stop on SIGTERM")
        if prometheus:
            prometheus.terminate()
            prometheus.wait(timeout=20)
        os.close(master)
        os.close(slave)
    check("modtap exit status", modtap.returncode, 0)

    with open(stats_path) as f:
        stats = json.load(f)
    one = lambda series: next(iter(series.values())) if series else None
    check("frames", one(got["modtap_frames_total"]), stats["frames"])
    check("noise bytes", one(got["modtap_noise_bytes_total"]), stats["noise_bytes"])
    check("broadcasts", one(got["modtap_broadcasts_total"]), stats["broadcasts"])
    if stats["frames"] < 2500:
        failures.append(f"only {stats['frames']} frames reached modtap")
    expected = {name: {} for name in got}
    for s in stats["slaves"]:
        slave = ("slave", str(s["slave"]))
        for fc, counts in s["by_fc"].items():
            for key in ("requests", "responses", "timeouts", "retries"):
                expected[f"modtap_{key}_total"][frozenset({slave, ("fc", fc)})] = counts[key]
        expected["modtap_bad_checks_total"][frozenset({slave})] = s["bad_checks"]
        for code, count in s["exceptions_by_code"].items():
            expected["modtap_exceptions_total"][frozenset({slave, ("code", code)})] = count
        latency = s["latency_us"]["count"] if s["latency_us"] else 0
        expected["modtap_response_latency_seconds_count"][frozenset({slave})] = latency
    for name in ("modtap_requests_total", "modtap_responses_total", "modtap_timeouts_total",
                 "modtap_retries_total", "modtap_bad_checks_total", "modtap_exceptions_total",
                 "modtap_response_latency_seconds_count"):
        check(name, got[name], expected[name])
    check("+Inf bucket = count",
          {frozenset(x for x in k if x[0] != "le"): v for k, v in infinite.items()},
          got["modtap_response_latency_seconds_count"])
    findings = {dict(k)["finding"]: v for k, v in got["modtap_findings_total"].items() if v}
    check("findings", findings, {k: v["count"] for k, v in stats["diagnostics"].items()})

    problems = {}
    for p in stats["problems"]:
        labels = {("kind", p["problem"]), ("severity", p["severity"])}
        if p["slave"] is not None:
            labels.add(("slave", str(p["slave"])))
        problems[frozenset(labels)] = 1
    check("problems", got["modtap_problem"], problems)
    # Fed without the silences between frames, a stray frame or noise now and then reads as
    # the absent slave's answer: it fails to answer all or nearly all.
    if not any(p["slave"] == 4 and p["problem"] in ("no-response", "intermittent-response")
               for p in stats["problems"]):
        failures.append(f"the absent slave 4 is no problem: {stats['problems']}")

    for f in failures:
        print("FAIL:", f)
    if failures:
        sys.exit(1)
    print(f"Prometheus scraped {stats['frames']} frames of {len(stats['slaves'])} slaves; "
          "every counter equals --stats")


main()
