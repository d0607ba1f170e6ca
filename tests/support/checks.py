"""What the test scripts share: failures gathered as they come and said at the end, and a free
port for a server a test starts on localhost."""
import socket

failures = []


def check(what, got, expected):
    if got != expected:
        failures.append(f"{what}: {got!r}, expected {expected!r}")


def verdict(name, found=None):
    """Prints each failure and the script's verdict; returns the exit status. `found`: the
    failures a script gathered itself, where not in this module's list."""
    found = failures if found is None else found
    for failure in found:
        print("FAIL:", failure)
    print(f"{name}:", "failed" if found else "ok")
    return 1 if found else 0


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]
