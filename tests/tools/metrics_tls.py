#!/usr/bin/python3
"""--metrics with --metrics-web-config: HTTPS with a certificate made here by openssl and a user
whose password is a bcrypt hash, in the Prometheus exporter toolkit's format. A request
without the user, or with a wrong password, gets 401 and no metrics; the right one gets them;
plain HTTP gets nothing. A real Prometheus (Debian's) scrapes it with `scheme: https`,
`tls_config` and `basic_auth`, and its API shows modtap's counters. A configuration with a key
modtap does not serve is refused, naming the file and line.

usage: metrics_tls.py MODTAP BUS_SIMULATOR WORKDIR"""
import json
import os
import shutil
import subprocess
import sys
import time
import urllib.parse
import urllib.request
import warnings

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)
    import crypt

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from certificates import make_ca, make_certificate  # noqa: E402
from checks import free_port  # noqa: E402

MODTAP, SIMULATOR, WORK = map(os.path.abspath, sys.argv[1:4])
USER, PASSWORD = "prometheus", "scrape-me-not-in-clear"
failures = []


def check(what, ok, detail=""):
    if not ok:
        failures.append(f"{what}: {detail}")


def fetch(url, user=None, password=None):
    """(status, body) of curl's GET over HTTPS trusting only the test's CA."""
    body = os.path.join(WORK, "body")
    command = ["curl", "-s", "-o", body, "-w", "%{http_code}", "--max-time", "5", "--cacert",
               os.path.join(WORK, "ca.pem"), url]
    if user:
        command[1:1] = ["-u", f"{user}:{password}"]
    run = subprocess.run(command, capture_output=True, text=True)
    if run.returncode != 0:
        raise OSError(f"curl {url}: exit {run.returncode}")
    return int(run.stdout), open(body).read()


def wait_for(check_ready, what, seconds=30):
    deadline = time.time() + seconds
    while time.time() < deadline:
        try:
            if check_ready():
                return
        except OSError:
            pass
        time.sleep(0.2)
    raise SystemExit(f"FAIL: {what} after {seconds} s")


def prometheus_query(port, expression):
    url = f"http://127.0.0.1:{port}/api/v1/query?" + urllib.parse.urlencode({"query": expression})
    with urllib.request.urlopen(url, timeout=5) as response:
        return json.loads(response.read())["data"]["result"]


shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)
make_ca(WORK, "ca")
make_certificate(WORK, "metrics", "ca", dns_name="localhost")
web_config = os.path.join(WORK, "web.yml")
with open(web_config, "w") as f:
    hashed = crypt.crypt(PASSWORD, crypt.mksalt(crypt.METHOD_BLOWFISH, rounds=1024))
    f.write("tls_server_config:\n  cert_file: metrics.pem\n  key_file: metrics.key\n"
            f"basic_auth_users:\n  {USER}: '{hashed}'\n")

bad_config = os.path.join(WORK, "bad.yml")
with open(bad_config, "w") as f:
    f.write("tls_server_config:\n  cert_file: metrics.pem\n  key_file: metrics.key\n"
            "  client_auth_type: RequireAndVerifyClientCert\n")
refused = subprocess.run([MODTAP, "-r", "/dev/null", "--format", "raw", "--metrics",
                          f"127.0.0.1:{free_port()}", "--metrics-web-config", bad_config],
                         capture_output=True, text=True, timeout=30)
check("a key not served is refused", refused.returncode != 0 and
      f"{bad_config}:4: tls_server_config: client_auth_type is not supported" in refused.stderr,
      refused.stderr)

capture = os.path.join(WORK, "bus.raw")
subprocess.run([SIMULATOR, "-n", "10000", "--seed", "5", "-o", capture], check=True,
               capture_output=True)
fifo = os.path.join(WORK, "bus.fifo")
os.mkfifo(fifo)
port, prometheus_port = free_port(), free_port()
modtap = subprocess.Popen([MODTAP, "-r", fifo, "--format", "raw", "-T", "none", "--metrics",
                           f"127.0.0.1:{port}", "--metrics-web-config", web_config],
                          stderr=subprocess.PIPE, text=True)
prometheus = None
url = f"https://localhost:{port}/metrics"
# More than the reader's first block, so frames are counted while the input stays open.
with open(fifo, "wb") as writer:
    writer.write(open(capture, "rb").read())
    writer.flush()
    try:
        wait_for(lambda: fetch(url)[0] == 401, "modtap's HTTPS metrics do not answer")
        status, body = fetch(url)
        check("no user: 401 and nothing else", status == 401 and "modtap_" not in body,
              (status, body[:80]))
        status, body = fetch(url, USER, "wrong")
        check("a wrong password: 401", status == 401 and "modtap_" not in body, (status, body[:80]))
        status, body = fetch(url, "someone", PASSWORD)
        check("an unknown user: 401", status == 401, status)
        status, body = fetch(url, USER, PASSWORD)
        check("the user: 200 and the metrics", status == 200 and "modtap_frames_total" in body,
              (status, body[:80]))
        plain = subprocess.run(["curl", "-s", "--max-time", "5", f"http://localhost:{port}/metrics"],
                               capture_output=True, text=True)
        check("plain HTTP gets nothing", plain.returncode != 0 and "modtap_" not in plain.stdout,
              plain.stdout[:80])

        config = os.path.join(WORK, "prometheus.yml")
        with open(config, "w") as f:
            f.write("global:\n  scrape_interval: 1s\n  scrape_timeout: 1s\n"
                    "scrape_configs:\n  - job_name: modtap\n    scheme: https\n"
                    f"    tls_config:\n      ca_file: {WORK}/ca.pem\n"
                    f"    basic_auth:\n      username: {USER}\n      password: {PASSWORD}\n"
                    f"    static_configs:\n      - targets: ['localhost:{port}']\n")
        prometheus = subprocess.Popen(
            ["prometheus", f"--config.file={config}", f"--storage.tsdb.path={WORK}/tsdb",
             f"--web.listen-address=127.0.0.1:{prometheus_port}"],
            stdout=open(os.path.join(WORK, "prometheus.log"), "w"), stderr=subprocess.STDOUT)
        try:
            wait_for(lambda: prometheus_query(prometheus_port, "modtap_frames_total > 0"),
                     "Prometheus has no modtap_frames_total over HTTPS with basic auth", 60)
        except SystemExit:
            with urllib.request.urlopen(f"http://127.0.0.1:{prometheus_port}/api/v1/targets") as t:
                print("Prometheus's target:", json.loads(t.read())["data"]["activeTargets"])
            raise
        up = prometheus_query(prometheus_port, 'up{job="modtap"}')
        check("Prometheus's target is up", up and up[0]["value"][1] == "1", up)
    finally:
        if prometheus:
            prometheus.terminate()
            prometheus.wait(timeout=20)
_, err = modtap.communicate(timeout=30)
check("modtap ends with its input", modtap.returncode == 0, err)

for f in failures:
    print("FAIL", f)
if failures:
    sys.exit(1)
print("ok: metrics over HTTPS to their user only; Prometheus scrapes them with basic auth")
