"""The progress bar of a long file review: drawn on standard error when it is a terminal (and
frame lines are not printed on that same terminal), redrawn in place, wiped at the end; never
when standard error is a pipe or a file.

usage: progress_on_terminal.py MODTAP BUSGEN WORKDIR
"""
import os
import pty
import subprocess
import sys
import threading
import time

MODTAP, BUSGEN, WORK = sys.argv[1:4]
failures = []


def drain_late(stream, delay):
    """Reads a pipe only after `delay` seconds: modtap stalls on it, so the run lasts long
    enough for the bar to be redrawn whatever the build's speed."""
    time.sleep(delay)
    while stream.read(65536):
        pass


def run_on_terminal(args, stdout_on_terminal=False):
    """Runs modtap with standard error (and optionally standard output) on a pty; returns what
    the terminal showed. Standard output not on the pty goes to a pipe read 1.5 s late."""
    master, slave = pty.openpty()
    process = subprocess.Popen([MODTAP, *args], stderr=slave,
                               stdout=slave if stdout_on_terminal else subprocess.PIPE)
    os.close(slave)
    if not stdout_on_terminal:
        threading.Thread(target=drain_late, args=(process.stdout, 1.5), daemon=True).start()
    shown = b""
    while True:
        try:
            data = os.read(master, 65536)
        except OSError:  # the pty closes when modtap exits
            break
        if not data:
            break
        shown += data
    os.close(master)
    process.wait(timeout=120)
    if process.returncode != 0:
        failures.append(f"{args}: exit {process.returncode}")
    return shown.decode(errors="replace")


def main():
    os.makedirs(WORK, exist_ok=True)
    capture = os.path.join(WORK, "long.bin")
    subprocess.run([BUSGEN, "-n", "100000", "--back-to-back", "-o", capture], check=True,
                   capture_output=True)
    size = os.path.getsize(capture)

    # Frame lines to standard output elsewhere (a pipe read late): the bar on the terminal.
    shown = run_on_terminal(["-r", capture, "--format", "raw", "-T", "text", "-V"])
    draws = [d for d in shown.split("\r\x1b[K") if d]
    if not draws or not draws[0].startswith("[" + "-" * 24 + "]   0% of"):
        failures.append(f"the bar does not start empty: {shown[:200]!r}")
    if f"of {size / 1e6:.1f} MB" not in shown:
        failures.append(f"the bar does not give the file's size ({size} bytes): {shown[:200]!r}")
    if not shown.endswith("\r\x1b[K"):
        failures.append(f"the bar is not wiped at the end: {shown[-100:]!r}")
    if len(draws) < 2 or "B/s, " not in shown or " left" not in shown:
        failures.append(f"the bar is not redrawn with rate and time left: {draws}")
    if "\n" in shown:
        failures.append(f"the bar prints lines instead of redrawing one: {shown[:200]!r}")

    # Frame lines on the same terminal: no bar among them.
    shown = run_on_terminal(["-r", capture, "--format", "raw", "-c", "50"], stdout_on_terminal=True)
    if "% of" in shown:
        failures.append("a bar drawn among the frame lines")

    # Standard error a pipe: nothing.
    result = subprocess.run([MODTAP, "-r", capture, "--format", "raw", "-T", "stats"],
                            capture_output=True, text=True, timeout=120)
    if result.stderr:
        failures.append(f"standard error not a terminal, yet: {result.stderr[:200]!r}")

    for failure in failures:
        print(failure)
    print(f"{len(failures)} failures")
    return 1 if failures else 0


sys.exit(main())
