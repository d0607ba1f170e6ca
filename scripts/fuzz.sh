#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (ASan+UBSan) in build-fuzz/ and runs each on its seed
# corpus (tests/fuzz/corpus/TARGET). New inputs go to build-fuzz/corpus/TARGET; an input that
# fails is written to build-fuzz/findings/ and stops that fuzzer with a non-zero exit.
#
#   scripts/fuzz.sh                 every target for 30 s, one per core (CI: 20 s)
#   scripts/fuzz.sh 3600            every target for an hour
#   scripts/fuzz.sh 0 10000000 rtu  the RTU framer for 10 million runs
#
# FUZZ_MAX_LEN (8192 by default) bounds an input: long inputs of many frames slow a framer's
# runs from about 2,000 a second to 350 once the corpus grows to the limit.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-30}
runs=${2:--1}
shift $(( $# > 2 ? 2 : $# ))
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(rtu ascii pdu hexlog pcap sigrok model_yaml filter)

CC=clang CXX=clang++ cmake -S . -B build-fuzz -DMODTAP_FUZZ=ON -DMODTAP_TESTS=OFF \
  -DMODTAP_BENCHMARKS=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build build-fuzz -j"$(nproc)" --target "${targets[@]/#/fuzz_}" >build-fuzz/build.log 2>&1 ||
  { tail -30 build-fuzz/build.log; exit 1; }

mkdir -p build-fuzz/findings
# No allocation stacks in ASan's reports: recording one per malloc costs a quarter of the runs,
# and a finding replays with them: build-fuzz/tests/fuzz/fuzz_TARGET build-fuzz/findings/FILE.
export ASAN_OPTIONS=${ASAN_OPTIONS:-malloc_context_size=0}
# Runs one target and writes what it found to build-fuzz/fuzz_TARGET.summary.
fuzz_one() {
  local t=$1 summary="build-fuzz/fuzz_$1.summary"
  mkdir -p "build-fuzz/corpus/$t"
  local args=(-rss_limit_mb=1024 "-max_len=${FUZZ_MAX_LEN:-8192}" -timeout=10 -print_final_stats=1
              "-artifact_prefix=build-fuzz/findings/$t-" "-runs=$runs")
  [ "$seconds" -gt 0 ] && args+=("-max_total_time=$seconds")
  echo "== fuzz_$t" >"$summary"
  local failed=0
  "build-fuzz/tests/fuzz/fuzz_$t" "${args[@]}" "build-fuzz/corpus/$t" "tests/fuzz/corpus/$t" \
    "tests/fuzz/regressions/$t" 2>"build-fuzz/fuzz_$t.log" || failed=1
  [ $failed = 0 ] || grep -E "property failed|ERROR|SUMMARY" "build-fuzz/fuzz_$t.log" | head -5 >>"$summary"
  { grep -E "stat::number_of_executed_units|stat::peak_rss_mb" "build-fuzz/fuzz_$t.log" | tr '\n' ' '
    echo; } >>"$summary" || true
  return $failed
}

# One target a core: a libFuzzer process uses one, so each still runs its full time and the
# whole run takes a core count's share of the sum.
status=0
running=0
for t in "${targets[@]}"; do
  if [ $running -ge "$(nproc)" ]; then
    wait -n || status=1
    running=$((running - 1))
  fi
  fuzz_one "$t" &
  running=$((running + 1))
done
while [ $running -gt 0 ]; do
  wait -n || status=1
  running=$((running - 1))
done
for t in "${targets[@]}"; do cat "build-fuzz/fuzz_$t.summary"; done
exit $status
