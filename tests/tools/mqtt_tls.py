#!/usr/bin/python3
"""--mqtt over TLS to a real broker (Debian's mosquitto on localhost, a TLS-only listener that
takes no client without a password), with certificates made here by openssl. modtap's values
reach the broker over mqtts:// with the password from the environment or a file, never from
the command line (/proc/PID/cmdline of a running modtap does not hold it). A CA that did not
sign the broker's certificate, or a name the certificate does not carry, is refused with a
clear error and the broker sees no client; a wrong password is refused by the broker, named.

usage: mqtt_tls.py MODTAP BUS_SIMULATOR WORKDIR"""
import os
import shutil
import socket
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from certificates import make_ca, make_certificate  # noqa: E402
from checks import free_port  # noqa: E402

MODTAP, SIMULATOR, WORK = map(os.path.abspath, sys.argv[1:4])
PASSWORD = "s3cret-on-no-command-line"
failures = []


def check(what, ok, detail=""):
    if not ok:
        failures.append(f"{what}: {detail}")


def make_certificates():
    """A CA, the broker's certificate for the name localhost signed by it, another CA, and a
    client certificate."""
    make_ca(WORK, "ca")
    make_ca(WORK, "other-ca")
    make_certificate(WORK, "broker", "ca", dns_name="localhost")
    make_certificate(WORK, "client", "ca")


def start_broker(port, certificate_port):
    passwords = os.path.join(WORK, "passwords")
    subprocess.run(["mosquitto_passwd", "-c", "-b", passwords, "modtap", PASSWORD], check=True)
    config = os.path.join(WORK, "mosquitto.conf")
    with open(config, "w") as f:
        f.write(f"user root\nlistener {port} 127.0.0.1\npersistence false\n"
                f"allow_anonymous false\npassword_file {passwords}\n"
                f"cafile {WORK}/ca.pem\ncertfile {WORK}/broker.pem\nkeyfile {WORK}/broker.key\n"
                f"listener {certificate_port} 127.0.0.1\nrequire_certificate true\n"
                f"cafile {WORK}/ca.pem\ncertfile {WORK}/broker.pem\nkeyfile {WORK}/broker.key\n"
                "log_type all\n")
    log = open(os.path.join(WORK, "mosquitto.log"), "w")
    broker = subprocess.Popen(["mosquitto", "-c", config], stdout=log, stderr=subprocess.STDOUT)
    deadline = time.time() + 20
    while time.time() < deadline:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1).close()
            return broker
        except OSError:
            time.sleep(0.1)
    raise SystemExit("FAIL: mosquitto did not start")


def clients_seen():
    return open(os.path.join(WORK, "mosquitto.log")).read().count("New client connected")


def retained(port, prefix):
    """Every retained message under the prefix, read over TLS as another client."""
    run = subprocess.run(["mosquitto_sub", "-h", "localhost", "-p", str(port), "--cafile",
                          os.path.join(WORK, "ca.pem"), "-u", "modtap", "-P", PASSWORD, "-t",
                          f"{prefix}/#", "-v", "--retained-only", "-W", "3"],
                         capture_output=True, text=True)
    return dict(line.split(" ", 1) for line in run.stdout.splitlines() if " " in line)


def modtap(capture, url, *options, env_password=True):
    env = dict(os.environ)
    env.pop("MODTAP_MQTT_PASSWORD", None)
    if env_password:
        env["MODTAP_MQTT_PASSWORD"] = PASSWORD
    return subprocess.run([MODTAP, "-r", capture, "-T", "none", "--mqtt", url,
                           "--mqtt-interval", "0", *options],
                          capture_output=True, text=True, env=env, timeout=60)


shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)
make_certificates()
capture = os.path.join(WORK, "bus.pcap")
subprocess.run([SIMULATOR, "-n", "50", "--seed", "7", "--format", "pcap", "-o", capture],
               check=True, capture_output=True)
port, certificate_port = free_port(), free_port()
broker = start_broker(port, certificate_port)
ca = os.path.join(WORK, "ca.pem")
try:
    # The password from the environment, the broker's name checked against the CA's certificate.
    run = modtap(capture, f"mqtts://modtap@localhost:{port}/plant", "--mqtt-ca", ca,
                 "--mqtt-bus", "env")
    check("mqtts:// with MODTAP_MQTT_PASSWORD", run.returncode == 0, run.stderr)
    messages = retained(port, "plant/env")
    check("values over TLS", messages.get("plant/env/status") == "offline" and
          any(topic.split("/")[2].isdigit() for topic in messages), sorted(messages)[:5])

    # From a file, and the process's command line does not hold it while it runs.
    password_file = os.path.join(WORK, "mqtt-password")
    with open(password_file, "w") as f:
        f.write(PASSWORD + "\n")
    os.chmod(password_file, 0o600)
    fifo = os.path.join(WORK, "bus.fifo")
    os.mkfifo(fifo)
    env = {k: v for k, v in os.environ.items() if k != "MODTAP_MQTT_PASSWORD"}
    running = subprocess.Popen([MODTAP, "-r", fifo, "--format", "raw", "-T", "none", "--mqtt",
                                f"mqtts://modtap@localhost:{port}/plant", "--mqtt-ca", ca,
                                "--mqtt-bus", "file", "--mqtt-password-file", password_file],
                               stderr=subprocess.PIPE, text=True, env=env)
    with open(fifo, "wb") as writer:
        writer.write(open(capture, "rb").read()[24:200])  # some bytes; the run stays open
        writer.flush()
        time.sleep(1.5)
        cmdline = open(f"/proc/{running.pid}/cmdline", "rb").read()
        check("no password in /proc/PID/cmdline", PASSWORD.encode() not in cmdline, cmdline)
    _, err = running.communicate(timeout=30)
    check("--mqtt-password-file", running.returncode == 0, err)
    check("the file's password reached the broker", retained(port, "plant/file").get(
        "plant/file/status") == "offline", err)

    # In the URL it still works, with a warning that says where else to give it.
    run = modtap(capture, f"mqtts://modtap:{PASSWORD}@localhost:{port}/plant", "--mqtt-ca", ca,
                 "--mqtt-bus", "url", env_password=False)
    check("password in the URL", run.returncode == 0 and "--mqtt-password-file" in run.stderr,
          run.stderr)

    # Refused before anything is sent: another CA, a name the certificate lacks.
    seen = clients_seen()
    run = modtap(capture, f"mqtts://modtap@localhost:{port}/plant", "--mqtt-ca",
                 os.path.join(WORK, "other-ca.pem"))
    check("another CA refused", run.returncode != 0 and "certificate verify failed" in run.stderr,
          run.stderr)
    run = modtap(capture, f"mqtts://modtap@127.0.0.1:{port}/plant", "--mqtt-ca", ca)
    check("a name the certificate lacks refused", run.returncode != 0 and
          "certificate verify failed" in run.stderr, run.stderr)
    check("the broker saw no client", clients_seen() == seen, f"{clients_seen() - seen} connected")
    run = modtap(capture, f"mqtts://modtap@127.0.0.1:{port}/plant", "--mqtt-ca", ca,
                 "--mqtt-insecure", "--mqtt-bus", "insecure")
    check("--mqtt-insecure takes the name as it is", run.returncode == 0, run.stderr)

    # A listener that asks for a client certificate: refused without one, taken with one.
    run = modtap(capture, f"mqtts://modtap@localhost:{certificate_port}/plant", "--mqtt-ca", ca)
    check("no client certificate refused", run.returncode != 0, run.stderr)
    run = modtap(capture, f"mqtts://modtap@localhost:{certificate_port}/plant", "--mqtt-ca", ca,
                 "--mqtt-cert", os.path.join(WORK, "client.pem"), "--mqtt-key",
                 os.path.join(WORK, "client.key"), "--mqtt-bus", "certificate")
    check("--mqtt-cert", run.returncode == 0, run.stderr)
    check("the certificate's client reached the broker",
          retained(port, "plant/certificate").get("plant/certificate/status") == "offline")

    # A wrong password: the broker's refusal, named.
    env_run = subprocess.run([MODTAP, "-r", capture, "-T", "none", "--mqtt",
                              f"mqtts://modtap@localhost:{port}/plant", "--mqtt-ca", ca],
                             capture_output=True, text=True, timeout=60,
                             env=dict(os.environ, MODTAP_MQTT_PASSWORD="wrong"))
    check("a wrong password refused", env_run.returncode != 0 and
          "not authori" in env_run.stderr.lower(), env_run.stderr)
finally:
    broker.terminate()
    broker.wait(timeout=20)

for f in failures:
    print("FAIL", f)
if failures:
    sys.exit(1)
print("ok: values over mqtts:// with the password off the command line; another CA, a wrong "
      "name and a wrong password refused, named")
