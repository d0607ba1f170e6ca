#!/usr/bin/python3
"""--mqtt to a broker that stops reading: a TCP server on localhost that answers modtap's
CONNECT and then takes nothing more. modtap reads a capture of a million frames (thousands of
register changes and health summaries, 280 MB of messages) and must neither queue them all in
memory nor hang: it holds at most a few megabytes for the broker, waits for it once, then
drops what it cannot send, says how many, and ends.

usage: mqtt_stalled_broker.py MODTAP BUSGEN WORKDIR MAX_RSS_MB MAX_SECONDS TRANSACTIONS
(the sanitizers' shadow memory and quarantine need more of both, and their slower build reads
fewer transactions)"""
import os
import socket
import subprocess
import sys
import threading
import time

MODTAP, BUSGEN, WORK = map(os.path.abspath, sys.argv[1:4])
MAX_RSS_MB, MAX_SECONDS, TRANSACTIONS = float(sys.argv[4]), float(sys.argv[5]), sys.argv[6]
os.makedirs(WORK, exist_ok=True)
capture = os.path.join(WORK, "bus.raw")
subprocess.run([BUSGEN, "-n", TRANSACTIONS, "--back-to-back", "-o", capture], check=True,
               capture_output=True)

server = socket.socket()
server.bind(("127.0.0.1", 0))
server.listen(1)
port = server.getsockname()[1]
connected = []


def stall():
    conn, _ = server.accept()
    conn.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    packet = conn.recv(2)  # CONNECT's first byte is 0x10
    connected.append(packet[:1] == b"\x10")
    conn.sendall(bytes([0x20, 2, 0, 0]))  # CONNACK: accepted
    time.sleep(MAX_SECONDS + 60)  # and never read again: a hang outlasts the bound
    conn.close()


threading.Thread(target=stall, daemon=True).start()
start = time.monotonic()
stderr = os.path.join(WORK, "stderr")
with open(stderr, "w") as err:
    modtap = subprocess.Popen([MODTAP, "-r", capture, "--format", "raw", "-q", "--mqtt",
                               f"mqtt://127.0.0.1:{port}/stalled", "--mqtt-interval", "0"],
                              stdout=subprocess.DEVNULL, stderr=err)
    _, status, usage = os.wait4(modtap.pid, 0)  # modtap's own peak, not the generator's
seconds = time.monotonic() - start
peak_mb = usage.ru_maxrss / 1024
returncode = os.waitstatus_to_exitcode(status)
with open(stderr) as err:
    message = err.read()

failures = []
if connected != [True]:
    failures.append(f"modtap did not connect: {connected}")
if returncode != 0:
    failures.append(f"exit {returncode}: {message}")
if "messages not sent" not in message:
    failures.append(f"no word of the messages not sent: {message!r}")
# The run itself takes about a second; one wait of 5 s for room, one of 5 s for the offline.
if seconds > MAX_SECONDS:
    failures.append(f"took {seconds:.1f} s")
# Without the bound, every message queued: 300 MB.
if peak_mb > MAX_RSS_MB:
    failures.append(f"peak RSS {peak_mb:.0f} MB")
print(f"{seconds:.1f} s, peak RSS {peak_mb:.0f} MB; {message.strip()}")
for f in failures:
    print("FAIL:", f)
sys.exit(1 if failures else 0)
