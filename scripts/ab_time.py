#!/usr/bin/python3
"""Two modtap builds timed side by side on the same captures, as docs/performance.md measures
against a commit: each output run 7 times in pairs A B A B, the medians and their ratio.

    scripts/ab_time.py OLD_MODTAP NEW_MODTAP CAPTURE [CAPTURE ...]
"""
import statistics
import subprocess
import sys
import time

OUTPUTS = [["-T", "none"], [], ["-T", "json"], ["--model", "gd20"]]
PAIRS = 7


def seconds(modtap, capture, output):
    start = time.perf_counter()
    subprocess.run([modtap, "-r", capture] + output, stdout=subprocess.DEVNULL, check=True)
    return time.perf_counter() - start


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    old, new, captures = sys.argv[1], sys.argv[2], sys.argv[3:]
    for capture in captures:
        for output in OUTPUTS:
            runs = {old: [], new: []}
            for _ in range(PAIRS):
                for modtap in (old, new):
                    runs[modtap].append(seconds(modtap, capture, output))
            a, b = statistics.median(runs[old]), statistics.median(runs[new])
            print(f"{capture.split('/')[-1]:12} {' '.join(output) or 'text':14} "
                  f"old {a:.3f} s  new {b:.3f} s  ratio {b / a:.3f}", flush=True)


if __name__ == "__main__":
    main()
