#!/usr/bin/env bash
# Installs what modtap needs on Debian 12 (as root) and builds it into build/.
set -euo pipefail
cd "$(dirname "$0")/.."
packages=(cmake g++ make pkg-config libfmt-dev libpcap-dev libcli11-dev libyaml-dev libgtest-dev
          libgmock-dev libbenchmark-dev sigrok-cli tshark python3 libmodbus-dev mbpoll
          python3-pymodbus nlohmann-json3-dev clang libclang-rt-14-dev strace chromium
          python3-pil libmicrohttpd-dev prometheus libmosquitto-dev mosquitto mosquitto-clients
          systemd wireshark xvfb)
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
# A Release build is laid out by a profile of modtap's own runs (scripts/pgo.sh: a sixth fewer
# instructions a frame), trained again when modtap changed. PGO=keep uses the last profile as
# it is (while iterating: switching the profile off and on rebuilds everything); PGO=off
# builds without one.
pgo=(-DMODTAP_PGO=)
if [ "$type" = Release ] && [ "${PGO:-on}" != off ]; then
  if [ "${PGO:-on}" = keep ]; then bash scripts/pgo.sh --keep; else bash scripts/pgo.sh; fi
  pgo=(-DMODTAP_PGO=use -DMODTAP_PGO_DIR="$PWD/build-pgo/profile")
fi
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE="$type" "${pgo[@]}" ${CMAKE_ARGS:-} >/dev/null
cmake --build "$build" -j"$(nproc)"
