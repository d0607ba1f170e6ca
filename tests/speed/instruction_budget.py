#!/usr/bin/python3
"""Instructions per frame of each output against the budget in instruction_budget.txt.

    instruction_budget.py MODTAP BUS_SIMULATOR WORK_DIR [--update]

Runs modtap under callgrind on fixed captures (the bus simulator's mixed traffic with seed 1,
and random bytes read as RTU) and counts the instructions each output takes per frame (per KiB
for the random bytes). Instruction counts do not move with the machine's load, as times do: the
same binary on the same input counts the same. A figure over its budget by more than 3% fails,
with every figure printed; one far under it says the budget may come down. --update writes the
figures measured as the new budget (a change that needs more raises it in the same commit and
says why in its message; docs/performance.md).

The budget holds for the build the test command makes (Release without link-time optimisation,
without profile or sanitizers, Debian 12's g++): another build counts other instructions, so
the test is registered for that build only.
"""
import os
import random
import re
import subprocess
import sys

TOLERANCE = 0.03
TRANSACTIONS = 30000  # about 58 k frames: each run takes seconds under callgrind
RANDOM_BYTES = 256 << 10

# name, modtap's arguments after -r CAPTURE, capture ("bus" or "random").
RUNS = [
    ("none", ["-T", "none"], "bus"),
    ("text", ["-T", "text"], "bus"),
    ("json", ["-T", "json"], "bus"),
    ("pcapng", ["-q", "-w", "{work}/out.pcapng"], "bus"),
    ("model-gd20", ["--model", "gd20", "-T", "text"], "bus"),
    ("stats", ["-T", "stats"], "bus"),
    ("random-rtu", ["--format", "raw", "--mode", "rtu", "--baud", "115200", "-T", "none"],
     "random"),
]


def budget_path():
    return os.path.join(os.path.dirname(os.path.abspath(__file__)), "instruction_budget.txt")


def read_budget():
    budget = {}
    with open(budget_path()) as f:
        for line in f:
            line = line.split("#", 1)[0].strip()
            if line:
                name, figure = line.split()
                budget[name] = float(figure)
    return budget


def write_budget(figures):
    with open(budget_path()) as f:
        header = [line for line in f if line.startswith("#")]
    with open(budget_path(), "w") as f:
        f.writelines(header)
        for name, _, _ in RUNS:
            f.write(f"{name} {figures[name]:.0f}\n")


def make_captures(busgen, work):
    bus = os.path.join(work, "bus.pcap")
    subprocess.run([busgen, "-n", str(TRANSACTIONS), "--seed", "1", "--format", "pcap", "-o", bus],
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    rand = os.path.join(work, "random.bin")
    with open(rand, "wb") as f:
        f.write(random.Random(1).randbytes(RANDOM_BYTES))
    return {"bus": bus, "random": rand}


def frames_in(modtap, capture):
    out = subprocess.run([modtap, "-r", capture, "-q", "--stats", "-"], check=True,
                         capture_output=True, text=True).stdout
    return int(re.search(r'"frames":\s*(\d+)', out).group(1))


def instructions(modtap, args):
    run = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null",
                          modtap] + args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                         text=True)
    if run.returncode != 0:
        sys.exit(f"modtap {' '.join(args)} failed under callgrind:\n{run.stderr}")
    return int(re.search(r"Collected : (\d+)", run.stderr).group(1))


def measure(modtap, captures, work):
    units = {"bus": frames_in(modtap, captures["bus"]), "random": RANDOM_BYTES / 1024}
    figures = {}
    for name, args, capture in RUNS:
        args = ["-r", captures[capture]] + [a.format(work=work) for a in args]
        figures[name] = instructions(modtap, args) / units[capture]
    return figures, units


def main():
    if len(sys.argv) not in (4, 5) or (len(sys.argv) == 5 and sys.argv[4] != "--update"):
        sys.exit(__doc__)
    modtap, busgen, work = sys.argv[1:4]
    os.makedirs(work, exist_ok=True)
    figures, units = measure(modtap, make_captures(busgen, work), work)
    if len(sys.argv) == 5:
        write_budget(figures)
        print(f"budget written to {budget_path()}")
    budget = read_budget()
    print(f"{units['bus']} frames; random bytes per KiB")
    print(f"{'output':<12} {'budget':>10} {'measured':>10} {'ratio':>7}")
    over = []
    for name, _, _ in RUNS:
        ratio = figures[name] / budget[name]
        mark = ""
        if ratio > 1 + TOLERANCE:
            over.append(name)
            mark = "  over budget"
        elif ratio < 1 - 2 * TOLERANCE:
            mark = "  well under: lower the budget (--update)"
        print(f"{name:<12} {budget[name]:>10.0f} {figures[name]:>10.0f} {ratio:>7.3f}{mark}")
    if over:
        sys.exit(f"over budget by more than {TOLERANCE:.0%}: {', '.join(over)} (tests/speed/"
                 "instruction_budget.txt; a change that needs more raises it and says why)")


if __name__ == "__main__":
    main()
