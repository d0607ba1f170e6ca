#!/usr/bin/env bash
# Sets up, builds and runs every test. --sanitize builds under ASan+UBSan in build-sanitize/.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ "${1:-}" = "--sanitize" ]; then
  export BUILD_DIR=build-sanitize BUILD_TYPE=Debug
  export CMAKE_ARGS="-DMODTAP_SANITIZE=ON -DMODTAP_BENCHMARKS=OFF"
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1
fi
bash scripts/setup.sh
ctest --test-dir "${BUILD_DIR:-build}" --output-on-failure -j"$(nproc)"
