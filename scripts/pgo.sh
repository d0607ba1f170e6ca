#!/usr/bin/env bash
# Profile-guided optimisation, its first half: builds modtap instrumented in build-pgo/, runs it
# with every output over captures the bus simulator makes (clean, faulty, a byte a packet, 16 ms
# bursts, ASCII, raw, and a pcap read with the wrong settings) and over the bundled
# logic-analyzer capture of a real bus, and leaves the profile in build-pgo/profile/ for a
# Release build with -DMODTAP_PGO=use (scripts/setup.sh does both; docs/performance.md).
# Trains again only when the instrumented modtap or this script changed; with --keep, not at
# all once a profile is there (while iterating, an edited function is built without one).
set -euo pipefail
cd "$(dirname "$0")/.."
train=build-pgo
profile=$PWD/$train/profile
stamp=$profile/trained
if [ "${1:-}" = --keep ] && [ -f "$stamp" ]; then exit 0; fi
mkdir -p "$train"
cmake -S . -B "$train" -DCMAKE_BUILD_TYPE=Release -DMODTAP_TESTS=OFF -DMODTAP_BENCHMARKS=OFF \
  -DMODTAP_IPO=ON -DMODTAP_PGO=train -DMODTAP_PGO_DIR="$profile" >/dev/null
cmake --build "$train" -j"$(nproc)" --target modtap modtap-bus-simulator >"$train/build.log" 2>&1 ||
  { tail -30 "$train/build.log"; exit 1; }
modtap=$train/tools/modtap/modtap
busgen=$train/tools/busgen/modtap-bus-simulator
if [ -f "$stamp" ] && [ "$stamp" -nt "$modtap" ] && [ "$stamp" -nt scripts/pgo.sh ]; then exit 0; fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
simulate() { "$busgen" "$@" >/dev/null 2>&1; }
# Seeds other than the benchmark's (scripts/bench.sh uses 1), so that it does not measure the
# captures the profile was made on.
simulate -n 60000 --seed 4242 --format pcap -o "$work/clean.pcap"
simulate -n 30000 --seed 4243 --faults --delivery sniffer --format pcap -o "$work/faulty.pcap"
simulate -n 5000 --seed 4247 --delivery bytes --format pcap -o "$work/bytes.pcap"
simulate -n 20000 --seed 4244 --slaves 8 --delivery bursts --format pcap -o "$work/bursts.pcap"
simulate -n 10000 --seed 4245 --faults --ascii --format hexlog -o "$work/ascii.log"
simulate -n 30000 --seed 4246 --faults --format raw -o "$work/faults.raw"
rm -rf "$profile"  # the simulator's own runs counted too: only modtap's are the profile
mkdir -p "$profile"

outputs=("-T none" "-T text" "-V" "-T json" "-w $work/out.pcapng" "-q --stats $work/stats.json")
run() {  # run CAPTURE OPTIONS...: every output
  for output in "${outputs[@]}"; do
    # shellcheck disable=SC2086  # each output is its options, split
    "$modtap" -r "$@" $output >/dev/null 2>&1 || echo "pgo: modtap -r $* $output: exit $?" >&2
  done
}
run "$work/clean.pcap"
run "$work/clean.pcap" --model gd20
run "$work/faulty.pcap"
run "$work/bytes.pcap"
run "$work/bursts.pcap"
run "$work/ascii.log"
run "$work/faults.raw" --format raw
run "$work/faulty.pcap" --format raw --mode rtu  # a capture read with the wrong settings
run captures/samples/brainchild-io-16do.sr --baud 19200 --parity even \
  --sigrok-channels tx=1,rx=0 --sigrok-invert
touch "$stamp"
