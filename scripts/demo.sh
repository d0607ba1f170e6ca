#!/usr/bin/env bash
# Sets up and builds modtap, then runs it on the bundled logic-analyzer capture of a real bus.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh >/dev/null
./build/tools/modtap/modtap -r captures/samples/brainchild-io-16do.sr \
  --baud 19200 --parity even --sigrok-channels tx=1,rx=0 --sigrok-invert "$@"
