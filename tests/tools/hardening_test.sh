#!/bin/bash
# The package's hardening (MODTAP_HARDENING, which scripts/package.sh turns on) reaches the
# programs: a build of its own with the option makes the extcap, the smallest program, and
# it must carry what Debian's flags give: read-only relocations bound at start (relro, bindnow),
# a position-independent executable, the stack protector and the fortified C library calls.
# Usage: hardening_test.sh SOURCE_DIR WORK_DIR
set -euo pipefail
source=$1 work=$2
fail() { echo "FAIL: $*"; exit 1; }
command -v dpkg-buildflags >/dev/null || { echo "SKIP: no dpkg-buildflags (dpkg-dev)"; exit 77; }
rm -rf "$work"
cmake -S "$source" -B "$work" -DCMAKE_BUILD_TYPE=Release -DMODTAP_HARDENING=ON >"$work.log" 2>&1 ||
  { cat "$work.log"; fail "configure"; }
cmake --build "$work" -j"$(nproc)" --target modtap-extcap >>"$work.log" 2>&1 ||
  { tail -20 "$work.log"; fail "build"; }
program=$work/tools/extcap/modtap-extcap
dynamic=$(readelf -dW "$program")
grep -q "BIND_NOW" <<<"$dynamic" || fail "not bound at start (bindnow): $dynamic"
grep -q "Flags: NOW PIE" <<<"$dynamic" || fail "not a position-independent executable"
readelf -lW "$program" | grep -q GNU_RELRO || fail "no read-only relocations (relro)"
symbols=$(nm -D "$program")
grep -q "__stack_chk_fail" <<<"$symbols" || fail "no stack protector"
grep -qE "__[a-z]+_chk@" <<<"$symbols" || fail "no fortified C library call"
rm -rf "$work" "$work.log"
echo "hardened: relro, bindnow, PIE, stack protector, fortified calls"
