#!/bin/bash
# The Debian package as a technician gets it: cpack builds it from this build, lintian finds no
# error in it, apt-get installs it, and everything works from /usr: the bundled capture reads
# as the build's own modtap reads it, both man pages render, tshark lists the plugin and the
# extcap, systemd-analyze accepts the unit, modtap lists the installed models, bash completes
# its options. apt-get purge then leaves no file of it behind.
# Usage: debian_package_test.sh BUILD_DIR WORK_DIR
set -euo pipefail
build=$(realpath "$1") work=$2
fail() { echo "FAIL: $*"; exit 1; }
[ "$(id -u)" = 0 ] || { echo "SKIP: installing a package needs root"; exit 77; }
prefix=$(sed -n 's/^CMAKE_INSTALL_PREFIX:PATH=//p' "$build/CMakeCache.txt")
[ "$prefix" = /usr ] ||
  { echo "SKIP: the build installs to $prefix, a package to /usr (-DCMAKE_INSTALL_PREFIX=/usr)"; exit 77; }
if dpkg-query -W -f='${Status}' modtap 2>/dev/null | grep -q "install ok installed"; then
  echo "SKIP: a modtap package is installed already, which this test would purge"; exit 77
fi
rm -rf "$work" && mkdir -p "$work"
(cd "$work" && cpack --config "$build/CPackConfig.cmake" >cpack.log 2>&1) || { cat "$work/cpack.log"; fail "cpack"; }
version=$("$build/tools/modtap/modtap" --version | cut -d' ' -f2)
deb=$work/modtap_${version}_$(dpkg --print-architecture).deb
[ -f "$deb" ] || fail "cpack wrote no $deb: $(ls "$work")"

lintian --fail-on error --no-tag-display-limit "$deb" >"$work/lintian.log" 2>&1 ||
  { cat "$work/lintian.log"; fail "lintian reports errors"; }
dpkg-deb -f "$deb" Depends | grep -q libpcap || fail "Depends does not name the libraries modtap links"

trap 'apt-get purge -y -qq modtap >/dev/null 2>&1 || true' EXIT
DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$deb" >"$work/apt.log" 2>&1 ||
  { cat "$work/apt.log"; fail "apt-get install"; }
files=$(dpkg -L modtap)

sample=(/usr/share/doc/modtap/examples/brainchild-io-16do.sr --baud 19200 --parity even
        --sigrok-channels tx=1,rx=0 --sigrok-invert -T json)
installed=$(/usr/bin/modtap -r "${sample[@]}")
[ "$(grep -c '"type":"frame"' <<<"$installed")" -gt 10 ] || fail "the installed modtap reads no frames"
[ "$installed" = "$("$build/tools/modtap/modtap" -r "${sample[@]}")" ] ||
  fail "the installed modtap reads the bundled capture otherwise than the build's"
/usr/bin/modtap-bus-simulator -n 20 -o - 2>/dev/null | /usr/bin/modtap -r - --format raw -T stats | grep -q . ||
  fail "the installed simulator and modtap do not run together"

for page in modtap:--interface modtap-bus-simulator:--faults modtap-models:EXAMPLE; do
  path=$(man -w "${page%%:*}") || fail "man finds no page ${page%%:*}"
  man -l "$path" 2>/dev/null | grep -q -- "${page#*:}" || fail "man -l $path does not show ${page#*:}"
done

tshark -G plugins | grep -q '^modtap\.so' || fail "tshark -G plugins does not list modtap.so"
touch "$work/ttyTAP"
MODTAP_EXTCAP_PORTS=$work/ttyTAP tshark -D 2>/dev/null | grep -q "modtap:$work/ttyTAP" ||
  fail "tshark -D does not list the installed extcap's port"

unit=$(grep '/systemd/system/modtap@\.service$' <<<"$files") || fail "no modtap@.service"
mkdir "$work/units" && cp "$unit" "$work/units/modtap@line3.service"
verify=$(systemd-analyze verify "$work/units/modtap@line3.service" 2>&1) ||
  fail "systemd-analyze verify: $verify"
[ -z "$verify" ] || fail "systemd-analyze verify warns: $verify"
grep -q '^ExecStart=/usr/bin/modtap ' "$unit" || fail "the unit does not run /usr/bin/modtap"

for model in /usr/share/modtap/models/*.yaml; do
  name=$(sed -n 's/^model: *\([^ #]*\).*/\1/p' "$model")
  /usr/bin/modtap models | grep -q "^$name " || fail "modtap models does not list $name"
  /usr/bin/modtap models check "$model" >/dev/null || fail "modtap models check $model"
done

completion=$(bash -c 'source /usr/share/bash-completion/bash_completion
  COMP_WORDS=(modtap --for); COMP_CWORD=1; COMP_LINE="modtap --for"; COMP_POINT=${#COMP_LINE}
  _comp_load modtap 2>/dev/null || __load_completion modtap
  $(complete -p modtap | sed "s/.*-F \([^ ]*\) .*/\1/") modtap --for modtap
  printf "%s\n" "${COMPREPLY[@]}"')
grep -qx -- '--format' <<<"$completion" || fail "bash does not complete modtap --for: $completion"

DEBIAN_FRONTEND=noninteractive apt-get purge -y -qq modtap >/dev/null 2>&1 || fail "apt-get purge"
trap - EXIT
left=$(while read -r f; do if [ -e "$f" ] && [ ! -d "$f" ]; then echo "$f"; fi; done <<<"$files")
for d in /usr/share/modtap /usr/share/doc/modtap /usr/share/wireshark/profiles/modtap; do
  [ -e "$d" ] && left+=$'\n'$d
done
[ -z "${left//$'\n'/}" ] || fail "apt-get purge left behind:$left"
echo "packaged $(basename "$deb"): lintian clean of errors, installed, run from /usr, purged"
