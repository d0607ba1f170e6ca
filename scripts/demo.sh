#!/usr/bin/env bash
# Sets up and builds modtap, then diagnoses the bundled capture of a bus with two faulty drives:
# what is wrong first, then the bus's statistics.
set -euo pipefail
cd "$(dirname "$0")/.."
say() { printf 'modtap demo: %s\n' "$*" >&2; }
say "installing the packages modtap builds with (apt-get), then building it (a few minutes)"
bash scripts/setup.sh >/dev/null
say "diagnosing captures/samples/six-drives-two-faults.pcap (modtap -r FILE -T stats)"
./build/tools/modtap/modtap -r captures/samples/six-drives-two-faults.pcap -T stats "$@"
