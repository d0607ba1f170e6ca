"""Small helpers shared by the Python test programs."""
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
