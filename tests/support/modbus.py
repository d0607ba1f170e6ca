"""Small helpers shared by the Python test programs."""
import datetime
import os
import time


def with_crc(body):
    """An RTU ADU: slave address and PDU, then CRC-16/MODBUS, low byte first."""
    crc = 0xFFFF
    for byte in body:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    return bytes(body) + bytes([crc & 0xFF, crc >> 8])


def wait_until_open(process, path, timeout=20):
    """Waits until `process` holds `path` open: a slow start (sanitizers, a busy machine)
    must not turn into bytes written before anyone listened."""
    deadline = time.time() + timeout
    fds = f"/proc/{process.pid}/fd"
    while time.time() < deadline and process.poll() is None:
        try:
            if any(os.readlink(os.path.join(fds, fd)) == path for fd in os.listdir(fds)):
                return True
        except OSError:
            pass
        time.sleep(0.01)
    return False


def simulated_blocks(path):
    """(stamp, bytes) of each block of the simulator's hex log: one frame each, stamped at its
    end."""
    blocks = []
    for line in open(path):
        line = line.rstrip("\n")
        if len(line) >= 27 and line[4] == "-" and line[26] == ":":
            stamp = datetime.datetime.strptime(line[:26], "%Y-%m-%d %H:%M:%S.%f").timestamp()
            blocks.append((stamp, bytearray()))
        elif line.strip():
            blocks[-1][1].extend(bytes.fromhex(line))
    return blocks


def replay(blocks, ptys):
    """Writes each block to every pty when its last byte arrives, as a UART's FIFO hands it."""
    start = time.monotonic() + 0.2
    first = blocks[0][0]
    for stamp, data in blocks:
        due = start + stamp - first
        while (left := due - time.monotonic()) > 0:
            time.sleep(min(left, 0.0005))
        for pty in ptys:
            os.write(pty, bytes(data))
