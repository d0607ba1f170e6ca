#!/usr/bin/env bash
# Installs what building and running modtap needs on Debian 12 (as root) and builds it into
# build/: Release, without tests unless MODTAP_TESTS=ON is in CMAKE_ARGS (scripts/test.sh).
# PGO=on lays the build out by a profile of modtap's own runs (scripts/pgo.sh: about a sixth
# fewer instructions a frame, for packages and benchmarks; docs/performance.md); PGO=keep uses
# the last profile without training it again.
set -euo pipefail
cd "$(dirname "$0")/.."
# To build: the compiler, CMake and the libraries modtap links or loads (libmicrohttpd and
# libmosquitto are loaded when --metrics or --mqtt asks, their headers used at build time).
# To run: sigrok-cli reads logic-analyzer captures.
packages=(cmake g++ make pkg-config libfmt-dev libpcap-dev libcli11-dev libyaml-dev libcrypt-dev
          libmicrohttpd-dev libmosquitto-dev libncurses-dev sigrok-cli ${EXTRA_PACKAGES:-})
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null
fi
build=${BUILD_DIR:-build}
type=${BUILD_TYPE:-Release}
pgo=(-DMODTAP_PGO=)
if [ "$type" = Release ] && [ "${PGO:-off}" != off ]; then
  if [ "${PGO}" = keep ]; then bash scripts/pgo.sh --keep; else bash scripts/pgo.sh; fi
  pgo=(-DMODTAP_PGO=use -DMODTAP_PGO_DIR="$PWD/build-pgo/profile")
fi
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE="$type" -DMODTAP_TESTS=OFF -DMODTAP_BENCHMARKS=OFF \
  -DMODTAP_IPO=ON "${pgo[@]}" ${CMAKE_ARGS:-} >/dev/null
cmake --build "$build" -j"$(nproc)"
