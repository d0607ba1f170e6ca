#!/usr/bin/env bash
# Sets up, builds and runs every test. --sanitize builds under ASan+UBSan in build-sanitize/.
# Beside what setup.sh installs, the tests need the peers they check modtap against (tshark,
# Wireshark under Xvfb, mbpoll, libmodbus, pymodbus, Prometheus, mosquitto, Chromium, ser2net,
# systemd-analyze, lintian, bash-completion) and their own tools (GoogleTest, Google Benchmark,
# clang for the fuzzers, valgrind for the instruction budget, help2man for the man pages) and
# Wireshark's headers for its plugin.
set -euo pipefail
cd "$(dirname "$0")/.."
export EXTRA_PACKAGES="libgtest-dev libgmock-dev libbenchmark-dev clang libclang-rt-14-dev
  nlohmann-json3-dev python3 python3-pil python3-pymodbus libmodbus-dev mbpoll tshark wireshark
  xvfb chromium prometheus mosquitto mosquitto-clients strace systemd jpnevulator tmux ser2net
  help2man valgrind dpkg-dev lintian bash-completion openssl curl libwireshark-dev libglib2.0-dev"
# Configured for /usr so that the package test can build a .deb from this build. Without
# link-time optimisation: the tests check what modtap does, not how fast, and the whole-program
# links of the test programs took a third of CI's build (setup.sh's build has it again).
export CMAKE_ARGS="-DMODTAP_TESTS=ON -DMODTAP_BENCHMARKS=ON -DMODTAP_IPO=OFF
  -DCMAKE_INSTALL_PREFIX=/usr"
if [ "${1:-}" = "--sanitize" ]; then
  export BUILD_DIR=build-sanitize BUILD_TYPE=Debug
  export CMAKE_ARGS="-DMODTAP_TESTS=ON -DMODTAP_SANITIZE=ON -DMODTAP_BENCHMARKS=OFF"
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1
fi
bash scripts/setup.sh
ctest --test-dir "${BUILD_DIR:-build}" --output-on-failure -j"$(nproc)"
