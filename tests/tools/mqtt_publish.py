#!/usr/bin/python3
"""--mqtt against a real broker (Debian's mosquitto, started here on localhost): a master reads
an NTA5000 and a GD20 through a pty, and every value it read reaches the broker under the
model's name, with the model's unit and scaled value. Then the broker goes away and comes back:
modtap keeps capturing, and afterwards the broker holds the bus's current state again, values
that changed while it was away included. Home Assistant discovery points at those topics, the
health summary counts what --stats counts, and the status topic says offline at the end and,
as the last will, when modtap is killed.

usage: mqtt_publish.py MODTAP WORKDIR"""
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import tty

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from checks import check, failures, free_port, verdict  # noqa: E402
from modbus import with_crc  # noqa: E402

MODTAP, WORK = map(os.path.abspath, sys.argv[1:3])
PREFIX, BUS = "plant", "line3"
# (slave, first register, the model's names, scales and units for the registers read)
DRIVES = {
    1: (0x2524, [("output_frequency", 0.01, "Hz"), ("output_voltage", 0.1, "V"),
                 ("dc_voltage", 1, "V"), ("output_current", 0.1, "A")]),
    2: (0x3000, [("operation_frequency", 0.01, "Hz"), ("setting_frequency", 0.01, "Hz"),
                 ("bus_voltage", 1, "V"), ("output_voltage", 1, "V"),
                 ("output_current", 0.1, "A")]),
}


class Broker:
    """mosquitto on localhost, without persistence: a restart forgets every retained message."""

    def __init__(self, port):
        self.port = port
        self.config = os.path.join(WORK, "mosquitto.conf")
        with open(self.config, "w") as f:
            f.write(f"listener {port} 127.0.0.1\nallow_anonymous true\npersistence false\n")
        self.process = None

    def start(self):
        log = open(os.path.join(WORK, "mosquitto.log"), "a")
        self.process = subprocess.Popen(["mosquitto", "-c", self.config], stdout=log,
                                        stderr=subprocess.STDOUT)
        deadline = time.time() + 20
        while time.time() < deadline:
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=1).close()
                return
            except OSError:
                time.sleep(0.1)
        raise SystemExit("FAIL: mosquitto did not start")

    def stop(self):
        if self.process and self.process.poll() is None:
            self.process.terminate()
            self.process.wait(timeout=20)


class Subscriber:
    """mosquitto_sub on every topic, each message as 'RETAINED TOPIC PAYLOAD'."""

    def __init__(self, port, name):
        self.path = os.path.join(WORK, name)
        self.process = subprocess.Popen(
            ["mosquitto_sub", "-p", str(port), "-v", "-t", "#", "-F", "%r %t %p"],
            stdout=open(self.path, "w"), stderr=subprocess.DEVNULL)
        time.sleep(0.5)  # subscribed before anything is published

    def messages(self):
        self.process.terminate()
        self.process.wait(timeout=20)
        with open(self.path) as f:
            return [tuple(line.rstrip("\n").split(" ", 2)) for line in f if line.strip()]


def values_at(poll):
    """What each drive answers at poll number `poll`: raw register values. Slave 1's current is
    77 (7.7 A) from poll 30 on: it changes only while the broker is away."""
    return {
        1: [1000 + 50 * (poll % 17), 2200 + poll % 3, 310, 42 if poll < 30 else 77],
        2: [2500 + 25 * (poll % 10), 5000, 540, 380 + poll % 2, 55],
    }


def exchange(master, slave, first, raw):
    request = with_crc([slave, 3, first >> 8, first & 0xFF, 0, len(raw)])
    body = [slave, 3, 2 * len(raw)]
    for value in raw:
        body += [value >> 8, value & 0xFF]
    os.write(master, request)
    time.sleep(0.004)
    os.write(master, with_crc(body))
    time.sleep(0.02)


def poll(master, polls, read):
    for number in polls:
        answers = values_at(number)
        for slave, (first, _) in DRIVES.items():
            exchange(master, slave, first, answers[slave])
            for at, raw in enumerate(answers[slave]):
                read.setdefault((slave, at), []).append(raw)


def distinct_in_order(values):
    return [v for i, v in enumerate(values) if i == 0 or v != values[i - 1]]


def register_messages(messages):
    """{(slave, name): [payload, ...]} for the register topics."""
    found = {}
    for _, topic, payload in messages:
        parts = topic.split("/")
        if len(parts) == 4 and parts[:2] == [PREFIX, BUS] and parts[2].isdigit():
            found.setdefault((int(parts[2]), parts[3]), []).append(json.loads(payload))
    return found


def check_every_value(messages, read):
    """With --mqtt-interval 0 every change the master read is a message, in order."""
    got = register_messages(messages)
    for slave, (first, registers) in DRIVES.items():
        for at, (name, scale, unit) in enumerate(registers):
            payloads = got.get((slave, name), [])
            expected = distinct_in_order(read[(slave, at)])
            check(f"slave {slave} {name}: raw values published", [p["raw"] for p in payloads],
                  expected)
            for p in payloads:
                if abs(p["value"] - p["raw"] * scale) > 1e-9 or p["unit"] != unit or \
                        p["addr"] != first + at or p["name"] != name:
                    failures.append(f"slave {slave} {name}: published {p}")
                    break


def check_state(messages, read, what):
    """The retained messages a new subscriber gets: the last value of every register."""
    retained = [m for m in messages if m[0] == "1"]
    got = register_messages(retained)
    for slave, (_, registers) in DRIVES.items():
        for at, (name, _, _) in enumerate(registers):
            payloads = got.get((slave, name))
            check(f"{what}: slave {slave} {name}", payloads and payloads[-1]["raw"],
                  read[(slave, at)][-1])


def check_discovery(messages):
    topics = {topic for _, topic, _ in messages}
    configs = [json.loads(p) for _, t, p in messages
               if t.startswith("homeassistant/sensor/") and t.endswith("/config")]
    check("discovery messages", len({c["unique_id"] for c in configs}),
          sum(len(r) for _, r in DRIVES.values()))
    for config in configs:
        if config["state_topic"] not in topics:
            failures.append(f"discovery names {config['state_topic']}, which has no value")
        check(f"{config['name']}: availability", config["availability_topic"],
              f"{PREFIX}/{BUS}/status")
        if "{{ value_json" not in config["value_template"]:
            failures.append(f"{config['name']}: template {config['value_template']!r}")
    units = {c["state_topic"].split("/")[-1] + "@" + c["state_topic"].split("/")[2]:
             c.get("unit_of_measurement") for c in configs}
    check("slave 1 output_frequency's unit", units.get("output_frequency@1"), "Hz")


def statuses(messages):
    return [p for _, t, p in messages if t == f"{PREFIX}/{BUS}/status"]


def open_pty():
    master, slave = os.openpty()
    tty.setraw(master)
    tty.setraw(slave)
    return master, slave


def start_modtap(port, slave, *extra):
    return subprocess.Popen(
        [MODTAP, "-i", os.ttyname(slave), "--baud", "115200", "--parity", "none",
         "--model", "1=nta5000", "--model", "2=gd20", "--mqtt",
         f"mqtt://127.0.0.1:{port}/{PREFIX}", "--mqtt-bus", BUS, *extra],
        stderr=subprocess.PIPE, text=True)


def stop(process, sig=signal.SIGTERM):
    process.send_signal(sig)
    try:
        process.wait(timeout=30)
    except subprocess.TimeoutExpired:
        process.kill()
        failures.append("modtap did not stop")


def wait_online(port, seconds=60):
    """Until modtap's status on the (restarted) broker says online again."""
    deadline = time.time() + seconds
    while time.time() < deadline:
        run = subprocess.run(["mosquitto_sub", "-p", str(port), "-t", f"{PREFIX}/{BUS}/status",
                              "-C", "1", "-W", "2"], capture_output=True, text=True)
        if run.stdout.strip() == "online":
            return True
    return False


def broker_goes_away_and_comes_back(broker):
    master, slave = open_pty()
    stats = os.path.join(WORK, "stats.json")
    read = {}
    modtap = start_modtap(broker.port, slave, "-q", "--mqtt-interval", "0", "--mqtt-discovery",
                          "--stats", stats)
    try:
        if not wait_online(broker.port, 20):
            raise SystemExit("FAIL: modtap never said online")
        first = Subscriber(broker.port, "before.txt")
        poll(master, range(0, 30), read)
        time.sleep(1)
        before = first.messages()
        check_every_value(before, read)
        check_discovery(before)

        broker.stop()
        poll(master, range(30, 50), read)  # nobody listens; modtap goes on capturing
        broker.start()
        if not wait_online(broker.port):
            failures.append("modtap did not come back to the restarted broker")
        poll(master, range(50, 80), read)
        time.sleep(1)
        second = Subscriber(broker.port, "after.txt")
        stop(modtap)
        after = second.messages()
    finally:
        if modtap.poll() is None:
            modtap.kill()
        os.close(master)
        os.close(slave)
    check("modtap's exit status", modtap.returncode, 0)
    check_state(after, read, "after the broker came back")
    check("the last status", statuses(after)[-1:], ["offline"])
    with open(stats) as f:
        counted = json.load(f)
    check("frames modtap counted", counted["frames"], 80 * 2 * 2)
    health = [json.loads(p) for _, t, p in after if t == f"{PREFIX}/{BUS}/health"]
    check("the last health summary's frames", health[-1]["frames"] if health else None,
          counted["frames"])
    check("the last health summary's slaves", sorted(health[-1]["slaves"]) if health else None,
          ["1", "2"])
    if "messages not sent while the broker was away" not in modtap.stderr.read():
        failures.append("modtap did not say what the broker missed")


def paced_by_interval(broker):
    """--mqtt-interval 1: a value that changes on every poll is published about once a
    second, its last value always."""
    master, slave = open_pty()
    read = {}
    modtap = start_modtap(broker.port, slave, "-q", "--mqtt-interval", "1")
    try:
        if not wait_online(broker.port, 20):
            raise SystemExit("FAIL: modtap never said online")
        subscriber = Subscriber(broker.port, "paced.txt")
        started = time.time()
        poll(master, range(0, 100), read)  # about 5 s
        elapsed = time.time() - started
        time.sleep(0.5)
        stop(modtap)
        messages = subscriber.messages()
    finally:
        if modtap.poll() is None:
            modtap.kill()
        os.close(master)
        os.close(slave)
    frequency = register_messages(messages).get((1, "output_frequency"), [])
    # Once at the start, then once a second at most, and the value held at the end.
    if not elapsed - 1 <= len(frequency) <= elapsed + 3:
        failures.append(f"--mqtt-interval 1 over {elapsed:.1f} s published output_frequency "
                        f"{len(frequency)} times (it changed {len(read[(1, 0)])} times)")
    check("the last paced value", frequency[-1]["raw"] if frequency else None, read[(1, 0)][-1])


def last_will(broker):
    """modtap killed: the broker publishes its will, offline."""
    master, slave = open_pty()
    modtap = start_modtap(broker.port, slave, "-q")
    try:
        if not wait_online(broker.port, 20):
            raise SystemExit("FAIL: modtap never said online")
        stop(modtap, signal.SIGKILL)
        run = subprocess.run(["mosquitto_sub", "-p", str(broker.port), "-t",
                              f"{PREFIX}/{BUS}/status", "-C", "1", "-W", "5"],
                             capture_output=True, text=True)
        check("the status after modtap was killed", run.stdout.strip(), "offline")
    finally:
        os.close(master)
        os.close(slave)


def refusals(port):
    capture = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "captures",
                           "samples", "drives-manual-examples.log")
    for url, words in (("http://127.0.0.1/x", "not an mqtt:// or mqtts:// URL"),
                       ("mqtt://127.0.0.1:99999/x", "port"),
                       (f"mqtt://127.0.0.1:{free_port()}/x", "cannot connect")):
        run = subprocess.run([MODTAP, "-r", capture, "--mqtt", url], capture_output=True,
                             text=True, timeout=60)
        check(f"--mqtt {url}: exit status", run.returncode, 2)
        if words not in run.stderr:
            failures.append(f"--mqtt {url}: says {run.stderr.strip()!r}")


def main():
    shutil.rmtree(WORK, ignore_errors=True)
    os.makedirs(WORK)
    broker = Broker(free_port())
    broker.start()
    try:
        broker_goes_away_and_comes_back(broker)
        paced_by_interval(broker)
        last_will(broker)
        refusals(broker.port)
    finally:
        broker.stop()
    return verdict("mqtt")


if __name__ == "__main__":
    sys.exit(main())
