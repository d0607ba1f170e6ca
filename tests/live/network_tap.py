#!/usr/bin/python3
"""modtap on a bus behind a serial device server: -i tcp://HOST:PORT.

The bus simulator's frames are the truth, read from its hex log (one frame a block, timed).
Two servers hand the same bytes on:
- a TCP server that packs them as an NPort does, 1,024 bytes a packet every 50 ms;
- Debian's ser2net 4, serving a pty that the frames are written into in real time.
Over either, modtap must find every frame with its role, as from the log itself, and send
nothing: the TCP server and the pty's other side check that no byte comes back. A refused and
an unknown server are one clear line each; a server that goes away ends the run with the
connection named, or under --reconnect is waited for and read again when it is back.
Wireshark's extcap captures from the packing server too (its interface modtap:remote, the
server given as an option), and its pcapng reads back to every frame.

Usage: network_tap.py MODTAP BUS_SIMULATOR EXTCAP WORK_DIR
"""
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import termios
import threading
import time
import tty

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from modbus import replay, simulated_blocks, wait_until_open  # noqa: E402

MODTAP, SIMULATOR, EXTCAP, WORK = sys.argv[1:5]
LINE = ["--baud", "19200", "--parity", "none"]
failures = []


def check(name, condition, message):
    if not condition:
        failures.append(f"{name}: {message}")
    return condition


def frames_of(json_lines):
    """(raw, role) of each frame record, in order."""
    out = []
    for line in json_lines.splitlines():
        record = json.loads(line)
        if record.get("type") == "frame":
            out.append((record["raw"], record["role"]))
    return out


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def compare(name, truth, got):
    if check(name, got == truth, f"{len(got)} frames, {len(truth)} sent"):
        return
    for i, (want, have) in enumerate(zip(truth, got)):
        if want != have:
            failures.append(f"{name}: frame {i}: sent {want}, read {have}")
            break


class PackingServer(threading.Thread):
    """Sends `data` to its one client in 1,024-byte packets every 50 ms, then closes; keeps
    whatever the client sends."""

    def __init__(self, data):
        super().__init__(daemon=True)
        self.data = data
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.port = self.listener.getsockname()[1]
        self.received = b""

    def run(self):
        conn, _ = self.listener.accept()
        for at in range(0, len(self.data), 1024):
            conn.sendall(self.data[at:at + 1024])
            time.sleep(0.05)
        time.sleep(0.5)
        conn.setblocking(False)
        try:
            self.received = conn.recv(4096)
        except BlockingIOError:
            pass
        conn.close()
        self.listener.close()


def packed_server(truth, data):
    server = PackingServer(data)
    server.start()
    run = subprocess.run([MODTAP, "-i", f"tcp://127.0.0.1:{server.port}", *LINE, "-T", "json"],
                         capture_output=True, text=True, timeout=60)
    server.join(10)
    compare("packed", truth, frames_of(run.stdout))
    check("packed", run.returncode == 1, f"a server that closes ends the run with 1: {run.returncode}")
    check("packed", "the connection is gone: the server closed it" in run.stderr,
          f"the end is said: {run.stderr!r}")
    check("packed", server.received == b"", f"modtap sent {server.received!r}")


def through_extcap(truth, data):
    listed = subprocess.run([EXTCAP, "--extcap-interfaces"], capture_output=True, text=True).stdout
    check("extcap", "{value=modtap:remote}" in listed, f"no remote interface in {listed!r}")
    config = subprocess.run([EXTCAP, "--extcap-config", "--extcap-interface", "modtap:remote"],
                            capture_output=True, text=True).stdout
    check("extcap", "{call=--server}" in config, f"no server option in {config!r}")
    server = PackingServer(data)
    server.start()
    fifo = os.path.join(WORK, "extcap.fifo")
    if os.path.exists(fifo):
        os.unlink(fifo)
    os.mkfifo(fifo)
    pcapng = os.path.join(WORK, "extcap.pcapng")
    extcap = subprocess.Popen([EXTCAP, "--capture", "--extcap-interface", "modtap:remote",
                               "--server", f"tcp://127.0.0.1:{server.port}", "--fifo", fifo,
                               *LINE], stderr=subprocess.PIPE, text=True)
    with open(fifo, "rb") as source, open(pcapng, "wb") as sink:
        shutil.copyfileobj(source, sink)
    extcap.wait(30)
    server.join(10)
    read_back = subprocess.run([MODTAP, "-r", pcapng, "-T", "json"], capture_output=True, text=True)
    compare("extcap", truth, frames_of(read_back.stdout))
    check("extcap", server.received == b"", f"the extcap sent {server.received!r}")


def bad_servers():
    refused = subprocess.run([MODTAP, "-i", f"tcp://127.0.0.1:{free_port()}", *LINE],
                             capture_output=True, text=True, timeout=30)
    check("refused", refused.returncode == 2 and "cannot connect: Connection refused" in
          refused.stderr, f"{refused.returncode} {refused.stderr!r}")
    unknown = subprocess.run([MODTAP, "-i", "tcp://no-such-host.invalid:2000", *LINE],
                             capture_output=True, text=True, timeout=30)
    check("unknown", unknown.returncode == 2 and "unknown host no-such-host.invalid" in
          unknown.stderr, f"{unknown.returncode} {unknown.stderr!r}")


class Ser2net:
    """ser2net 4 serving `pty_path` at 19200 8N1 on `port`, as a raw TCP server or, with
    `accepter="telnet(rfc2217),tcp"`, as an RFC 2217 server whose client sets the port."""

    def __init__(self, pty_path, port, accepter="tcp"):
        self.config = os.path.join(WORK, "ser2net.yaml")
        with open(self.config, "w") as f:
            f.write("%YAML 1.1\n---\nconnection: &bus\n"
                    f"    accepter: {accepter},127.0.0.1,{port}\n"
                    f"    connector: serialdev,{pty_path},19200n81,local\n")
        self.port = port
        self.start()

    def start(self):
        self.process = subprocess.Popen(
            ["ser2net", "-n", "-u", "-c", self.config, "-P", os.path.join(WORK, "ser2net.pid")],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        deadline = time.time() + 10
        while time.time() < deadline:
            if self.listening():
                return
            time.sleep(0.05)
        raise RuntimeError("ser2net did not start listening")

    def listening(self):
        """Whether the port is in LISTEN state: asked of the kernel, as a trial connection
        would be ser2net's one client and open the pty."""
        with open("/proc/net/tcp") as f:
            for line in f.readlines()[1:]:
                fields = line.split()
                if int(fields[1].split(":")[1], 16) == self.port and fields[3] == "0A":
                    return True
        return False

    def stop(self):
        self.process.terminate()
        self.process.wait(10)


def nothing_came_back(name, master_fd):
    os.set_blocking(master_fd, False)
    try:
        back = os.read(master_fd, 4096)
    except BlockingIOError:
        back = b""
    check(name, back == b"", f"the pty's other side received {back!r}")


def behind_ser2net(name, accepter, scheme, args, play):
    """Serves a fresh pty with ser2net (`accepter`) and runs modtap on it with `args` while
    `play(server, master_fd, slave_fd, pty_path)` writes the bus; then Ctrl-C. Checks that
    nothing came back to the pty; returns modtap's records, its messages and its exit status."""
    master, slave = os.openpty()
    tty.setraw(master)
    tty.setraw(slave)
    pty_path = os.ttyname(slave)
    server = Ser2net(pty_path, free_port(), accepter)
    # Into files, not pipes read at the end: a full pipe would stop modtap's reading.
    out_path, err_path = os.path.join(WORK, name + ".jsonl"), os.path.join(WORK, name + ".err")
    with open(out_path, "w") as out_file, open(err_path, "w") as err_file:
        modtap = subprocess.Popen([MODTAP, "-i", f"{scheme}://127.0.0.1:{server.port}", *args,
                                   "-T", "json"], stdout=out_file, stderr=err_file)
    try:
        check(name, wait_until_open(server.process, pty_path), "ser2net never opened the pty")
        play(server, master, slave, pty_path)
        time.sleep(0.5)
    finally:
        modtap.send_signal(signal.SIGINT)
        modtap.wait(30)
        server.stop()
    nothing_came_back(name, master)
    os.close(master)
    os.close(slave)
    return open(out_path).read(), open(err_path).read(), modtap.returncode


def through_ser2net(blocks, truth):
    """A raw TCP server, stopped and started again halfway under --reconnect."""
    halves = [blocks[:len(blocks) // 2], blocks[len(blocks) // 2:]]

    def play(server, master, _slave, pty_path):
        replay(halves[0], [master])
        time.sleep(0.5)
        server.stop()
        time.sleep(1.5)
        server.start()
        check("ser2net", wait_until_open(server.process, pty_path),
              "modtap did not connect again under --reconnect")
        replay(halves[1], [master])

    out, err, status = behind_ser2net("ser2net", "tcp", "tcp", [*LINE, "--reconnect"], play)
    compare("ser2net", truth, frames_of(out))
    check("ser2net", status == 0, f"Ctrl-C ends the run with 0: {status}")
    for said in ("the connection is gone", "waiting for the port to come back", "is back"):
        check("ser2net", said in err, f"says {said!r}: {err!r}")


def through_rfc2217(blocks, truth):
    """modtap sets the server's port to 9600 8N1 (ser2net's own setting is 19200) and reads the
    line's bytes out of the Telnet stream."""

    def play(_server, master, slave, _pty_path):
        deadline = time.time() + 10
        while time.time() < deadline and termios.tcgetattr(slave)[4] != termios.B9600:
            time.sleep(0.05)
        check("rfc2217", termios.tcgetattr(slave)[4] == termios.B9600,
              "the server's port was not set to 9600 baud")
        replay(blocks, [master])

    out, err, _ = behind_ser2net("rfc2217", "telnet(rfc2217),tcp", "rfc2217",
                                 ["--baud", "9600", "--parity", "none"], play)
    compare("rfc2217", truth, frames_of(out))
    check("rfc2217", "the server set its port to 9600 8N1" in err,
          f"says the port's settings: {err!r}")


def main():
    os.makedirs(WORK, exist_ok=True)
    log = os.path.join(WORK, "bus.log")
    subprocess.run([SIMULATOR, "-n", "150", "--seed", "7", "--slaves", "8", "--format", "hexlog",
                    "--delivery", "frames", "-o", log], check=True, stderr=subprocess.DEVNULL)
    truth = frames_of(subprocess.run([MODTAP, "-r", log, *LINE, "-T", "json"], check=True,
                                     capture_output=True, text=True).stdout)
    check("truth", len(truth) > 250, f"the simulator's log reads as {len(truth)} frames")
    blocks = simulated_blocks(log)
    data = b"".join(bytes(block) for _, block in blocks)
    packed_server(truth, data)
    through_extcap(truth, data)
    bad_servers()
    if shutil.which("ser2net"):
        through_ser2net(blocks, truth)
        through_rfc2217(blocks, truth)
    else:
        failures.append("ser2net: not installed (the README's test command installs it)")
    for failure in failures:
        print(failure)
    print("network taps:", "FAILED" if failures else "passed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
