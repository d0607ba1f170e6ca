#!/usr/bin/python3
"""modtap on a live tap, with real masters and slaves, over pseudo-terminals.

A relay joins a master's pty to a slave's pty, paces each chunk at the baud rate, and copies
every byte to a third pty that modtap listens on (read-only). What modtap reports must equal
what passed: the requests as the master sent them, the responses as the slave sent them,
each response paired with its request. Nothing may ever come back out of the tap.

Usage: live_bus.py MODTAP LIBMODBUS_SLAVE WORK_DIR
"""
import json
import os
import select
import signal
import socket
import subprocess
import sys
import threading
import time
import tty
import urllib.error
import urllib.request

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from modbus import wait_until_open, with_crc  # noqa: E402

MODTAP, LIBMODBUS_SLAVE, WORK = sys.argv[1:4]
failures = []
passed = 0


def check(name, condition, message):
    if not condition:
        failures.append(f"{name}: {message}")
    return condition


class Pty:
    def __init__(self):
        self.master, self.slave = os.openpty()
        tty.setraw(self.master)
        tty.setraw(self.slave)
        self.path = os.ttyname(self.slave)

    def close(self):
        for fd in (self.master, self.slave):
            try:
                os.close(fd)
            except OSError:
                pass


class Relay(threading.Thread):
    """Master pty <-> slave pty, every byte copied to the tap pty, paced at the baud rate."""

    def __init__(self, master, slave, tap, char_seconds):
        super().__init__(daemon=True)
        self.master, self.slave, self.tap = master, slave, tap
        self.char_seconds = char_seconds
        self.sent = {"request": bytearray(), "response": bytearray()}
        self.tap_wrote = bytearray()
        self.running = True

    def run(self):
        fds = [self.master.master, self.slave.master, self.tap.master]
        while self.running:
            readable, _, _ = select.select(fds, [], [], 0.05)
            for fd in readable:
                try:
                    data = os.read(fd, 4096)
                except OSError:
                    continue
                if fd == self.tap.master:
                    self.tap_wrote += data  # modtap must never write
                    continue
                time.sleep(len(data) * self.char_seconds)
                if fd == self.master.master:
                    self.sent["request"] += data
                    os.write(self.slave.master, data)
                else:
                    self.sent["response"] += data
                    os.write(self.master.master, data)
                os.write(self.tap.master, data)


def char_seconds(baud, data_bits, parity, stop_bits):
    return (1 + data_bits + (0 if parity == "none" else 1) + stop_bits) / baud


def run_case(name, baud, parity, data_bits, mode, start_slave, run_master, settings=None):
    """`settings` replaces modtap's --baud/--parity arguments (to test --baud auto)."""
    over_limit = run_master.__name__ == "run_pymodbus"  # its first request asks for 126
    global passed
    m, s, t = Pty(), Pty(), Pty()
    relay = Relay(m, s, t, char_seconds(baud, data_bits, parity, 1))
    relay.start()
    settings = settings or ["--baud", str(baud), "--parity", parity]
    # Every case keeps its raw reads, alternately as pcapng and as a timed hex log.
    raw_path = os.path.join(WORK, f"case{run_case.count}.{'pcapng' if run_case.count % 2 else 'log'}")
    run_case.count += 1
    stats_path, report_path = raw_path + ".stats.json", raw_path + ".report.html"
    modtap = subprocess.Popen([MODTAP, "-i", t.path, "--data-bits", str(data_bits), "--mode", mode,
                               "-T", "json", "--save-raw", raw_path, "--stats", stats_path,
                               "--report", report_path] + settings,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    slave = start_slave(s.path)
    time.sleep(0.5)
    try:
        run_master(m.path)
    finally:
        time.sleep(0.5)
        modtap.send_signal(signal.SIGTERM)
        out, err = modtap.communicate(timeout=10)
        slave.terminate()
        slave.wait(timeout=10)
        relay.running = False
        relay.join()
        for p in (m, s, t):
            p.close()
    records = [json.loads(line) for line in out.splitlines()]
    frames = [r for r in records if r["type"] == "frame"]
    requests = [r for r in frames if r["role"] == "request"]
    responses = [r for r in frames if r["role"] == "response"]
    ok = True
    ok &= check(name, modtap.returncode == 0, f"modtap exited {modtap.returncode}: {err}")
    ok &= check(name, len(requests) >= 3 and len(responses) >= 3,
                f"{len(requests)} requests, {len(responses)} responses")
    # SIGTERM ends a live run as Ctrl-C does: the statistics are written, and complete.
    with open(stats_path) as f:
        stats = json.load(f)
    ok &= check(name, stats["complete"] and stats["frames"] == len(frames)
                and stats["requests"] == len(requests) and stats["responses"] == len(responses),
                f"--stats after SIGTERM: {stats['frames']} frames, {len(frames)} in the JSON")
    with open(report_path) as f:
        report = f.read()
    ok &= check(name, f'data-stat="frames">{len(frames)}<' in report,
                "--report after SIGTERM does not show the frames --stats counts")
    ok &= check(name, all(f["check"] == "ok" for f in frames), "a bad check on a clean line")
    ok &= check(name, not [r for r in records if r["type"] == "noise"], "noise on a clean line")
    for role in ("request", "response"):
        seen = "".join(f["raw"] for f in frames if f["role"] == role)
        ok &= check(name, seen == relay.sent[role].hex(),
                    f"{role} bytes differ from what passed: {seen[:80]} vs {relay.sent[role].hex()[:80]}")
    last_request = None
    for f in frames:
        if f["role"] == "request":
            last_request = f["index"]
        else:
            ok &= check(name, f["request"] == last_request, f"frame {f['index']} paired with {f['request']}")
    asked_126 = [f for f in requests if f["fc"] == 3 and f.get("quantity") == 126]
    if over_limit:
        ok &= check(name, len(asked_126) == 1 and asked_126[0]["findings"] == ["quantity-out-of-spec"],
                    f"the request for 126 registers: {asked_126}")
        answer = [f for f in responses if asked_126 and f["request"] == asked_126[0]["index"]]
        ok &= check(name, len(answer) == 1 and answer[0]["exception"] == 3,
                    f"the answer to 126 registers: {answer}")
    ok &= check(name, not relay.tap_wrote, f"modtap wrote {len(relay.tap_wrote)} bytes to the tap")
    # Read again from the raw recording, modtap must find the same frames.
    again = subprocess.run([MODTAP, "-r", raw_path, "--baud", str(baud), "--parity", parity,
                            "--data-bits", str(data_bits), "--mode", mode, "-T", "json"],
                           capture_output=True, text=True)
    reread = [json.loads(line) for line in again.stdout.splitlines()]
    ok &= check(name, [f["raw"] for f in reread if f["type"] == "frame"] == [f["raw"] for f in frames],
                f"{raw_path} read again gives other frames: {again.stderr}")
    if "auto" in settings:
        ok &= check(name, "modtap: using " in err and "listened as" in err, f"no evidence: {err}")
    passed += ok
    print(f"{name}: {len(requests)} requests, {len(responses)} responses, "
          f"{sum(len(v) for v in relay.sent.values())} bytes: {'ok' if ok else 'FAILED'}")


run_case.count = 0


def libmodbus_slave(baud, parity):
    p = {"none": "N", "even": "E", "odd": "O"}[parity]
    return lambda path: subprocess.Popen([LIBMODBUS_SLAVE, path, str(baud), p, "8", "1"])


def mbpoll_master(baud, parity):
    def run(path):
        common = ["mbpoll", "-m", "rtu", "-a", "1", "-b", str(baud), "-P", parity, "-0", "-1",
                  "-o", "1"]
        # mbpoll [options] device [values to write]
        for args, values in ((["-t", "4", "-r", "0", "-c", "10"], []),
                             (["-t", "3", "-r", "5", "-c", "4"], []),
                             (["-t", "0", "-r", "3", "-c", "12"], []),
                             (["-t", "4", "-r", "7"], ["1234"]),
                             (["-t", "4", "-r", "10"], ["11", "12", "13"]),
                             (["-t", "0", "-r", "2"], ["1"])):
            done = subprocess.run(common + args + [path] + values, capture_output=True, text=True,
                                  timeout=20)
            if done.returncode != 0:
                print("mbpoll", " ".join(args), "failed:", done.stdout[-300:], done.stderr[-300:])
    return run


PYMODBUS_SERVER = r"""
import sys
from pymodbus.server import StartSerialServer
from pymodbus.datastore import ModbusSequentialDataBlock, ModbusSlaveContext, ModbusServerContext
from pymodbus.transaction import ModbusAsciiFramer, ModbusRtuFramer
port, baud, parity, bits, mode = sys.argv[1], int(sys.argv[2]), sys.argv[3], int(sys.argv[4]), sys.argv[5]
block = lambda: ModbusSequentialDataBlock(0, list(range(100, 300)))
context = ModbusServerContext(slaves=ModbusSlaveContext(di=block(), co=block(), hr=block(), ir=block()), single=True)
StartSerialServer(context=context, port=port, baudrate=baud, parity=parity, bytesize=bits, stopbits=1,
                  framer=ModbusAsciiFramer if mode == "ascii" else ModbusRtuFramer, timeout=0.5)
"""

PYMODBUS_CLIENT = r"""
import sys
from pymodbus.client import ModbusSerialClient
from pymodbus.transaction import ModbusAsciiFramer, ModbusRtuFramer
port, baud, parity, bits, mode = sys.argv[1], int(sys.argv[2]), sys.argv[3], int(sys.argv[4]), sys.argv[5]
client = ModbusSerialClient(framer=ModbusAsciiFramer if mode == "ascii" else ModbusRtuFramer, port=port, baudrate=baud, parity=parity, bytesize=bits, stopbits=1, timeout=1, strict=False)
client.connect()
# Over the standard's limit of 125: the slave answers exception 03, modtap must show both.
client.read_holding_registers(0, 126, slave=1)
for _ in range(2):
    client.read_holding_registers(0, 10, slave=1)
    client.read_input_registers(3, 2, slave=1)
    client.write_register(5, 4321, slave=1)
    client.read_coils(0, 9, slave=1)
    client.write_coil(4, True, slave=1)
    client.write_registers(20, [1, 2, 3], slave=1)
client.close()
"""


def pymodbus_slave(baud, mode):
    # A pty carries neither parity bits nor 7-bit characters, and Linux refuses (EINVAL) the
    # tcsetattr pyserial-asyncio makes for PARENB or CS7 on a pty. The relay paces at the
    # line's real format, so the server opens its pty as 8N1.
    return lambda path: subprocess.Popen(["/usr/bin/python3", "-c", PYMODBUS_SERVER, path,
                                          str(baud), "N", "8", mode],
                                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def pymodbus_master(baud, parity, bits, mode):
    p = {"none": "N", "even": "E", "odd": "O"}[parity]

    def run_pymodbus(path):
        subprocess.run(["/usr/bin/python3", "-c", PYMODBUS_CLIENT, path, str(baud), p, str(bits),
                        mode], capture_output=True, timeout=60)
    return run_pymodbus


def error_cases():
    global passed
    result = subprocess.run([MODTAP, "-i", "/dev/modtap-no-such-port"], capture_output=True, text=True)
    ok = check("missing port", result.returncode != 0 and
               "/dev/modtap-no-such-port: cannot open: No such file or directory" in result.stderr,
               result.stderr)
    t = Pty()
    first = subprocess.Popen([MODTAP, "-i", t.path, "-T", "none"], stderr=subprocess.PIPE, text=True)
    time.sleep(0.5)
    second = subprocess.run([MODTAP, "-i", t.path], capture_output=True, text=True, timeout=10)
    ok &= check("busy port", second.returncode != 0 and "busy" in second.stderr, second.stderr)
    first.send_signal(signal.SIGTERM)
    first.wait(timeout=10)
    ok &= check("busy port", first.returncode == 0, "the first modtap did not end cleanly")
    t.close()
    passed += ok
    print(f"missing and busy ports: {'ok' if ok else 'FAILED'}")


def junk_and_clean_exit():
    """1 MB of junk gives noise, memory stays bounded, SIGTERM leaves a valid pcapng."""
    global passed
    t = Pty()
    pcapng = os.path.join(WORK, "junk.pcapng")
    # Output to a file: a pipe nobody drains would stop modtap, and then the pty writer.
    json_path = os.path.join(WORK, "junk.json")
    # Under AddressSanitizer freed memory waits in a quarantine that would count as growth.
    env = dict(os.environ)
    env["ASAN_OPTIONS"] = ":".join(filter(None, [env.get("ASAN_OPTIONS"), "quarantine_size_mb=0"]))
    modtap = subprocess.Popen([MODTAP, "-i", t.path, "-T", "json", "-w", pcapng, "--baud", "115200"],
                              stdout=open(json_path, "w"), stderr=subprocess.PIPE, text=True,
                              env=env)
    time.sleep(0.5)
    with open(f"/proc/{modtap.pid}/status") as status:
        start_kb = int(next(l for l in status if l.startswith("VmHWM")).split()[1])
    junk = bytes((i * 7919 + (i >> 8) * 31) & 0xFF for i in range(1 << 20))
    for at in range(0, len(junk), 4096):
        os.write(t.master, junk[at:at + 4096])
        time.sleep(0.0005)
    time.sleep(1.0)
    with open(f"/proc/{modtap.pid}/status") as status:
        peak_kb = int(next(l for l in status if l.startswith("VmHWM")).split()[1])
    modtap.send_signal(signal.SIGTERM)
    modtap.communicate(timeout=20)
    with open(json_path) as out:
        records = [json.loads(line) for line in out]
    seen = sum(len(r["raw"]) // 2 for r in records if r["type"] in ("noise", "frame"))
    ok = check("junk", seen == len(junk), f"{seen} of {len(junk)} bytes accounted for")
    ok &= check("junk", peak_kb - start_kb < 16 * 1024,
                f"peak RSS grew from {start_kb} kB to {peak_kb} kB")
    read = subprocess.run(["tshark", "-r", pcapng, "-T", "fields", "-e", "frame.number"],
                          capture_output=True, text=True)
    ok &= check("junk", read.returncode == 0 and len(read.stdout.split()) == len(records) - sum(
        1 for r in records if r["type"] in ("timeout", "unanswered")),
        f"pcapng after SIGTERM: {read.stderr}")
    t.close()
    passed += ok
    print(f"1 MB of junk: {len(records)} records, peak RSS {start_kb} kB at start, {peak_kb} kB "
          f"after: {'ok' if ok else 'FAILED'}")


def port_disappears():
    """An adapter unplugged mid-capture: a clear message, the frames so far, a valid pcapng."""
    global passed
    t = Pty()
    pcapng = os.path.join(WORK, "unplugged.pcapng")
    modtap = subprocess.Popen([MODTAP, "-i", t.path, "-T", "json", "-w", pcapng, "--baud", "19200"],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(0.5)
    request = with_crc([1, 3, 0, 0, 0, 1])
    response = with_crc([1, 3, 2, 0, 42])
    for frame in (request, response):
        os.write(t.master, frame)
        time.sleep(0.05)
    os.close(t.master)  # the other end of the line goes away, as an unplugged adapter does
    try:
        out, err = modtap.communicate(timeout=10)
    except subprocess.TimeoutExpired:
        modtap.kill()
        out, err = modtap.communicate()
    frames = [json.loads(line) for line in out.splitlines() if '"type":"frame"' in line]
    ok = check("unplugged", modtap.returncode == 1, f"exit status {modtap.returncode}")
    ok &= check("unplugged", t.path in err, f"no message naming the port: {err!r}")
    ok &= check("unplugged", [f["raw"] for f in frames] == [request.hex(), response.hex()],
                f"frames {[f['raw'] for f in frames]}")
    read = subprocess.run(["tshark", "-r", pcapng, "-T", "fields", "-e", "frame.number"],
                          capture_output=True, text=True)
    ok &= check("unplugged", read.returncode == 0 and len(read.stdout.split()) == 2,
                f"pcapng: {read.stdout!r} {read.stderr!r}")
    try:
        os.close(t.slave)
    except OSError:
        pass
    passed += ok
    print(f"port unplugged: {err.strip().splitlines()[-1] if err.strip() else '(no message)'}: "
          f"{'ok' if ok else 'FAILED'}")


def scrape_metrics(address):
    try:
        with urllib.request.urlopen(f"http://{address}/metrics", timeout=5) as response:
            return response.read().decode()
    except OSError as e:
        return str(e)


def reconnects():
    """With --reconnect, an unplugged port is waited for and read again when it comes back.
    The port is a symbolic link, as udev's /dev/serial/by-id names are, moved to a new pty."""
    global passed
    link = os.path.join(WORK, "ttyMODTAP")
    first = Pty()
    if os.path.lexists(link):
        os.unlink(link)
    os.symlink(first.path, link)
    with socket.socket() as s:  # a free port for --metrics, which counts the read error
        s.bind(("127.0.0.1", 0))
        metrics = f"127.0.0.1:{s.getsockname()[1]}"
    modtap = subprocess.Popen([MODTAP, "-i", link, "--reconnect", "-T", "json", "--baud", "19200",
                               "--metrics", metrics],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(0.5)
    before = with_crc([1, 3, 0, 0, 0, 1])
    after = with_crc([1, 3, 2, 0, 42])
    os.write(first.master, before)
    time.sleep(0.2)
    os.close(first.master)  # unplugged
    time.sleep(0.5)
    scrape_unplugged = scrape_metrics(metrics)
    second = Pty()  # plugged in again, under another pty that the link now names
    os.unlink(link)
    os.symlink(second.path, link)
    time.sleep(2.0)  # modtap retries once a second
    os.write(second.master, after)
    time.sleep(0.5)
    scrape = scrape_metrics(metrics)
    try:
        urllib.request.urlopen(urllib.request.Request(f"http://{metrics}/metrics", data=b"x"),
                               timeout=5)
        post = "answered"
    except urllib.error.HTTPError as e:
        post = e.code
    except OSError as e:
        post = str(e)
    modtap.send_signal(signal.SIGTERM)
    out, err = modtap.communicate(timeout=10)
    frames = [json.loads(line)["raw"] for line in out.splitlines() if '"type":"frame"' in line]
    ok = check("reconnect", frames == [before.hex(), after.hex()], f"frames {frames}; {err!r}")
    ok &= check("reconnect", "is back" in err and modtap.returncode == 0, f"{modtap.returncode}: {err!r}")
    ok &= check("reconnect", "waiting for the port to come back" in err, err)
    ok &= check("start-up line", f"listening on {link} at 19200 8E1, mode auto" in err, err)
    ok &= check("reconnect metrics", "modtap_port_read_errors_total 1\n" in scrape and
                "modtap_port_reconnects_total 1\n" in scrape,
                [line for line in scrape.splitlines() if line.startswith("modtap_port")])
    ok &= check("ports open", "modtap_ports_open 0\n" in scrape_unplugged and
                "modtap_ports_open 1\n" in scrape,
                [line for line in scrape_unplugged.splitlines() if "ports_open" in line])
    ok &= check("build info", 'modtap_build_info{version="' in scrape, "no modtap_build_info")
    ok &= check("POST", post == 405, f"a POST: {post}")
    for fd in (first.slave, second.master, second.slave):
        try:
            os.close(fd)
        except OSError:
            pass
    passed += ok
    print(f"port unplugged and back with --reconnect: {'ok' if ok else 'FAILED'}")


def stops_by_itself():
    """-a duration:S ends a live run after S seconds of wall time, as SIGTERM would."""
    global passed
    port = Pty()
    request = with_crc([1, 3, 0, 0, 0, 1])
    started = time.time()
    modtap = subprocess.Popen([MODTAP, "-i", port.path, "-T", "json", "--mode", "rtu",
                               "-a", "duration:1.5"],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wait_until_open(modtap, port.path)
    os.write(port.master, request)
    try:
        out, err = modtap.communicate(timeout=15)
    except subprocess.TimeoutExpired:
        modtap.kill()
        out, err = modtap.communicate()
    took = time.time() - started
    frames = [json.loads(line)["raw"] for line in out.splitlines() if '"type":"frame"' in line]
    ok = check("autostop", modtap.returncode == 0 and frames == [request.hex()] and 1.5 <= took < 8,
               f"status {modtap.returncode} after {took:.1f} s, frames {frames}; {err!r}")
    port.close()
    passed += ok
    print(f"-a duration:1.5 on a port: {'ok' if ok else 'FAILED'} ({took:.1f} s)")


def unprivileged_and_read_only():
    """As an ordinary user in the dialout group, modtap opens the tap read-only and never
    writes to it: strace shows the open's flags and every write; the pty's other side stays
    empty. Without dialout the same port is a clear permission error."""
    global passed
    import grp
    import shutil
    import tempfile
    t = Pty()
    os.chown(t.path, 0, grp.getgrnam("dialout").gr_gid)  # as udev sets a serial adapter
    os.chmod(t.path, 0o660)
    home = tempfile.mkdtemp(prefix="modtap-unprivileged-")
    os.chmod(home, 0o755)  # the checkout may be closed to other users; the copy is not
    binary = shutil.copy(MODTAP, os.path.join(home, "modtap"))
    trace = os.path.join(home, "strace.log")
    as_user = ["setpriv", "--reuid=nobody", "--regid=dialout", "--clear-groups"]
    modtap = subprocess.Popen(["strace", "-f", "-qq", "-e", "trace=open,openat,write,writev,pwrite64",
                               "-o", trace] + as_user + [binary, "-i", t.path, "-T", "json",
                                                        "--baud", "19200"],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                              start_new_session=True)
    time.sleep(1.0)
    request, response = with_crc([1, 3, 0, 0, 0, 1]), with_crc([1, 3, 2, 0, 42])
    for frame in (request, response):
        os.write(t.master, frame)
        time.sleep(0.05)
    time.sleep(0.5)
    os.killpg(modtap.pid, signal.SIGTERM)
    out, err = modtap.communicate(timeout=20)
    frames = [json.loads(line)["raw"] for line in out.splitlines() if '"type":"frame"' in line]
    ok = check("unprivileged", frames == [request.hex(), response.hex()], f"frames {frames}: {err}")
    lines = open(trace).read().splitlines()
    opens = [l for l in lines if f'"{t.path}"' in l and "open" in l]
    fd = opens[0].rsplit("=", 1)[1].strip() if opens else None
    ok &= check("unprivileged", opens and "O_RDONLY" in opens[0] and "O_RDWR" not in opens[0],
                f"the tap's open: {opens}")
    writes = [l for l in lines if fd and any(f"{call}({fd}," in l for call in ("write", "writev", "pwrite64"))]
    ok &= check("unprivileged", fd is not None and not writes, f"writes to the tap (fd {fd}): {writes[:3]}")
    os.set_blocking(t.master, False)
    try:
        echoed = os.read(t.master, 4096)
    except BlockingIOError:
        echoed = b""
    ok &= check("unprivileged", not echoed, f"the other side of the tap received {echoed!r}")
    refused = subprocess.run(["setpriv", "--reuid=nobody", "--regid=nogroup", "--clear-groups",
                              binary, "-i", t.path], capture_output=True, text=True, timeout=10)
    ok &= check("unprivileged", refused.returncode != 0 and "Permission denied" in refused.stderr,
                f"without dialout: {refused.returncode} {refused.stderr!r}")
    t.close()
    shutil.rmtree(home, ignore_errors=True)
    passed += ok
    print(f"as nobody in dialout, the tap opened {'O_RDONLY' if opens and 'O_RDONLY' in opens[0] else '?'}"
          f" and never written: {'ok' if ok else 'FAILED'}; without dialout: "
          f"{refused.stderr.strip()}")


def byte_streams(path):
    """What modtap reads from a file: the bytes of its frames and noise, per channel."""
    run = subprocess.run([MODTAP, "-r", path, "--baud", "115200", "-T", "json"],
                         capture_output=True, text=True)
    streams = {}
    for line in run.stdout.splitlines():
        r = json.loads(line)
        if r["type"] in ("frame", "noise"):
            streams[r["channel"]] = streams.get(r["channel"], "") + r["raw"]
    return run.returncode, run.stderr, streams


def pcapng_into_a_pipe():
    """`-w -` on a port feeds a reader as frames come (`modtap -i PORT -w - | wireshark -k -i -`):
    each packet reaches the pipe while modtap still runs, not when its buffer fills."""
    global passed
    port = Pty()
    modtap = subprocess.Popen([MODTAP, "-i", port.path, "-w", "-", "--mode", "rtu"],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    wait_until_open(modtap, port.path)
    request, response = with_crc([1, 3, 0, 0, 0, 1]), with_crc([1, 3, 2, 0, 5])
    os.write(port.master, request)
    time.sleep(0.05)
    os.write(port.master, response)
    seen = b""
    deadline = time.time() + 5
    while time.time() < deadline and not (request in seen and response in seen):
        if select.select([modtap.stdout], [], [], 0.2)[0]:
            seen += os.read(modtap.stdout.fileno(), 65536)
    modtap.terminate()
    _, err = modtap.communicate(timeout=15)
    ok = check("pcapng pipe", request in seen and response in seen,
               f"{len(seen)} bytes reached the pipe while running; {err!r}")
    port.close()
    passed += ok
    print(f"-w - on a port, read as it grows: {'ok' if ok else 'FAILED'}")


def signals_at_random_moments(runs=50):
    """SIGINT or SIGTERM at random moments while traffic flows: every run exits 0, its -w
    pcapng reads back whole, and holds every byte its --save-raw recording read."""
    global passed
    import random
    rng = random.Random(7)
    frames = [with_crc([1, 3, 0, i, 0, 4]) for i in range(8)] + [with_crc([1, 3, 8] + [i] * 8) for i in range(8)]
    ok, total = True, 0
    for run in range(runs):
        t = Pty()
        out, raw = os.path.join(WORK, "signal.pcapng"), os.path.join(WORK, "signal-raw.pcapng")
        modtap = subprocess.Popen([MODTAP, "-i", t.path, "--baud", "115200", "-T", "none", "-w", out,
                                   "--save-raw", raw], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                  text=True)
        ok &= check("signals", wait_until_open(modtap, t.path), f"run {run}: the port never opened")
        time.sleep(0.1)  # and set it up
        stop_at = time.time() + rng.uniform(0.01, 0.4)
        while time.time() < stop_at:
            frame = frames[rng.randrange(len(frames))]
            cut = rng.randrange(len(frame) + 1)  # a read may end mid-frame
            os.write(t.master, frame[:cut])
            os.write(t.master, frame[cut:])
            time.sleep(rng.uniform(0, 0.003))
        modtap.send_signal(signal.SIGINT if run % 2 else signal.SIGTERM)
        _, err = modtap.communicate(timeout=20)
        t.close()
        ok &= check("signals", modtap.returncode == 0, f"run {run}: exit {modtap.returncode}: {err}")
        status_out, err_out, written = byte_streams(out)
        status_raw, err_raw, read = byte_streams(raw)
        ok &= check("signals", status_out == 0 and status_raw == 0, f"run {run}: {err_out} {err_raw}")
        ok &= check("signals", bool(read), f"run {run}: nothing read before the signal")
        same = "".join(written.values()) == "".join(read.values())
        total += sum(map(len, read.values())) // 2
        ok &= check("signals", same, f"run {run}: -w holds {sum(map(len, written.values())) // 2} bytes, "
                                     f"--save-raw {sum(map(len, read.values())) // 2}")
        if not ok:
            break
    passed += ok
    print(f"SIGINT/SIGTERM at {runs} random moments, {total} bytes read in all: "
          f"{'ok' if ok else 'FAILED'}")


os.makedirs(WORK, exist_ok=True)
run_case("mbpoll -> libmodbus, RTU 9600 8E1", 9600, "even", 8, "rtu",
         libmodbus_slave(9600, "even"), mbpoll_master(9600, "even"))
run_case("mbpoll -> libmodbus, RTU 115200 8N1", 115200, "none", 8, "rtu",
         libmodbus_slave(115200, "none"), mbpoll_master(115200, "none"))
run_case("pymodbus -> pymodbus, RTU 115200 8N1", 115200, "none", 8, "rtu",
         pymodbus_slave(115200, "rtu"), pymodbus_master(115200, "none", 8, "rtu"))
run_case("pymodbus -> pymodbus, RTU 9600 8E1", 9600, "even", 8, "rtu",
         pymodbus_slave(9600, "rtu"), pymodbus_master(9600, "even", 8, "rtu"))
run_case("pymodbus -> pymodbus, ASCII 9600 7E1", 9600, "even", 7, "ascii",
         pymodbus_slave(9600, "ascii"), pymodbus_master(9600, "even", 7, "ascii"))
run_case("pymodbus -> pymodbus, ASCII 115200 8N1", 115200, "none", 8, "auto",
         pymodbus_slave(115200, "ascii"), pymodbus_master(115200, "none", 8, "ascii"))
run_case("pymodbus -> libmodbus, RTU 115200 8N1, mode auto", 115200, "none", 8, "auto",
         libmodbus_slave(115200, "none"), pymodbus_master(115200, "none", 8, "rtu"))
# A pty has no baud rate, so every setting reads it cleanly and the first candidate wins; what
# this shows is that probing never transmits, reports its evidence and loses no byte of the
# setting it keeps.
run_case("mbpoll -> libmodbus, --baud auto", 19200, "even", 8, "rtu",
         libmodbus_slave(19200, "even"), mbpoll_master(19200, "even"),
         ["--baud", "auto", "--probe-time", "3"])
error_cases()
port_disappears()
reconnects()
stops_by_itself()
pcapng_into_a_pipe()
junk_and_clean_exit()
unprivileged_and_read_only()
signals_at_random_moments()
for f in failures:
    print("FAIL", f)
cases = 16
print(f"{passed} passed, {cases - passed} failed")
sys.exit(1 if failures else 0)
