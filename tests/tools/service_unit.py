#!/usr/bin/python3
"""The service as installed: `cmake --install` puts modtap@.service (naming the installed
program) and an example configuration in place, systemd-analyze accepts the unit, and its
command line with the example's options (ring buffer, metrics, MQTT) runs as systemd would run
it: as an unprivileged user whose only right to the port is the dialout group, in the state
directory, stopped by SIGTERM. Without dialout the port is refused by name.

usage: service_unit.py BUILD_DIR WORKDIR"""
import glob
import os
import pwd
import shlex
import shutil
import signal
import subprocess
import sys
import time
import tty
import urllib.request

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from checks import check, failures, free_port, verdict  # noqa: E402
from modbus import with_crc  # noqa: E402

BUILD, WORK = map(os.path.abspath, sys.argv[1:3])


def install():
    prefix = os.path.join(WORK, "prefix")
    subprocess.run(["cmake", "--install", BUILD, "--prefix", prefix], check=True,
                   stdout=subprocess.DEVNULL)
    unit = os.path.join(prefix, "lib", "systemd", "system", "modtap@.service")
    example = os.path.join(prefix, "share", "modtap", "line3.conf.example")
    for path in (unit, example):
        if not os.path.exists(path):
            raise SystemExit(f"FAIL: cmake --install did not put {path} in place")
    return prefix, unit, example


def verify(unit):
    """systemd-analyze checks an instance of the template; it warns on stdout or stderr."""
    units = os.path.join(WORK, "units")
    os.makedirs(units)
    instance = os.path.join(units, "modtap@line3.service")
    shutil.copy(unit, instance)
    run = subprocess.run(["systemd-analyze", "verify", instance], capture_output=True, text=True)
    check("systemd-analyze verify", (run.returncode, run.stdout + run.stderr), (0, ""))


def service_command(unit, environment):
    """ExecStart as systemd expands it: ${VAR} one word, $VAR split at white space."""
    line = next(l for l in open(unit) if l.startswith("ExecStart="))[len("ExecStart="):]
    words = []
    for word in shlex.split(line):
        if word.startswith("${") and word.endswith("}"):
            words.append(environment[word[2:-1]])
        elif word.startswith("$"):
            words.extend(environment[word[1:]].split())
        else:
            words.append(word)
    return words


def read_environment(example):
    environment = {}
    for line in open(example):
        line = line.strip()
        if line and not line.startswith("#"):
            key, value = line.split("=", 1)
            environment[key] = value
    return environment


def as_user(groups):
    return ["setpriv", "--reuid=nobody", "--regid=nogroup", f"--groups={groups}", "--"]


def run_the_service(unit, example):
    master, slave = os.openpty()
    tty.setraw(master)
    tty.setraw(slave)
    port_path = os.ttyname(slave)
    os.chown(port_path, 0, int(subprocess.check_output(["getent", "group", "dialout"])
                               .split(b":")[2]))
    os.chmod(port_path, 0o660)

    mqtt_port, metrics_port = free_port(), free_port()
    environment = read_environment(example)
    environment["MODTAP_PORT"] = port_path
    options = environment["MODTAP_OPTIONS"]
    for old, new in (("--baud 19200", "--baud 115200"), ("--parity even", "--parity none"),
                     ("127.0.0.1:9464", f"127.0.0.1:{metrics_port}"),
                     ("127.0.0.1:1883", f"127.0.0.1:{mqtt_port}")):
        if old not in options:
            raise SystemExit(f"FAIL: the example's options no longer hold {old!r}")
        options = options.replace(old, new)
    environment["MODTAP_OPTIONS"] = options
    command = service_command(unit, environment)

    state = os.path.join(WORK, "state")  # StateDirectory=, owned by the service's user
    os.makedirs(state)
    nobody = pwd.getpwnam("nobody")
    os.chown(state, nobody.pw_uid, nobody.pw_gid)

    refused = subprocess.run(as_user("nogroup") + command, cwd=state, capture_output=True,
                             text=True, timeout=30)
    if refused.returncode == 0 or port_path not in refused.stderr or \
            "Permission denied (is the user in the dialout group?)" not in refused.stderr:
        failures.append(f"without dialout: exit {refused.returncode}, {refused.stderr.strip()!r}")

    config = os.path.join(WORK, "mosquitto.conf")
    with open(config, "w") as f:
        f.write(f"listener {mqtt_port} 127.0.0.1\nallow_anonymous true\npersistence false\n")
    broker = subprocess.Popen(["mosquitto", "-c", config], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)
    service = None
    try:
        time.sleep(0.5)
        service = subprocess.Popen(as_user("dialout") + command, cwd=state,
                                   stderr=subprocess.PIPE, text=True)
        time.sleep(1.5)
        sub = subprocess.Popen(["mosquitto_sub", "-p", str(mqtt_port), "-v", "-t", "plant/#"],
                               stdout=subprocess.PIPE, text=True)
        time.sleep(0.5)
        for number in range(60):
            os.write(master, with_crc([1, 3, 0x25, 0x24, 0, 1]))
            time.sleep(0.004)
            os.write(master, with_crc([1, 3, 2, 0x17, 0x70 + number % 8]))
            time.sleep(0.03)
        time.sleep(1)
        with urllib.request.urlopen(f"http://127.0.0.1:{metrics_port}/metrics", timeout=5) as r:
            metrics = r.read().decode()
        service.send_signal(signal.SIGTERM)  # the unit's KillSignal
        service.wait(timeout=30)
        time.sleep(0.5)
        sub.terminate()
        published = sub.communicate(timeout=10)[0]
    finally:
        if service and service.poll() is None:
            service.kill()
        broker.terminate()
        broker.wait(timeout=20)
        os.close(master)
        os.close(slave)
    check("the service's exit status after SIGTERM", service.returncode, 0)
    if "modtap_frames_total 120" not in metrics:
        failures.append("the metrics did not count the 120 frames sent")
    if "plant/line3/1/output_frequency" not in published or \
            "plant/line3/status offline" not in published:
        failures.append(f"MQTT got: {published[-500:]!r}")
    files = glob.glob(os.path.join(state, "bus_00001_*.pcapng"))
    check("ring files in the state directory", len(files), 1)
    for name in files:
        check(f"{name}'s owner", os.stat(name).st_uid, nobody.pw_uid)
        read = subprocess.run(["tshark", "-r", name], capture_output=True, text=True)
        check(f"packets tshark reads in {name}", len(read.stdout.splitlines()), 120)


def main():
    shutil.rmtree(WORK, ignore_errors=True)
    os.makedirs(WORK)
    os.chmod(WORK, 0o755)
    _, unit, example = install()
    verify(unit)
    if os.geteuid() != 0:
        print("service unit: skipping the unprivileged run: it needs root to switch users")
    else:
        run_the_service(unit, example)
    return verdict("service unit")


if __name__ == "__main__":
    sys.exit(main())
