#!/bin/sh
# cmake --install puts the program, the models, the Lua plugin and the extcap in their places
# under the prefix (docs/wireshark.md: with --prefix /usr these are where Wireshark looks).
# Usage: install_test.sh BUILD_DIR LIBDIR WORK_DIR
set -eu
build=$1 libdir=$2 stage=$3/prefix
rm -rf "$stage"
cmake --install "$build" --prefix "$stage" >/dev/null
for f in bin/modtap share/modtap/models/nta5000.yaml share/modtap/models/gd20.yaml \
         "$libdir/wireshark/plugins/modtap.lua" "$libdir/wireshark/extcap/modtap-extcap" \
         share/wireshark/profiles/modtap/preferences share/wireshark/profiles/modtap/colorfilters \
         share/wireshark/profiles/modtap/recent \
         lib/systemd/system/modtap@.service share/modtap/line3.conf.example; do
  [ -e "$stage/$f" ] || { echo "missing after install: $f"; exit 1; }
done
"$stage/bin/modtap" models --models-dir "$stage/share/modtap/models" | grep -q '^nta5000 ' ||
  { echo "the installed modtap does not read the installed models"; exit 1; }
"$stage/$libdir/wireshark/extcap/modtap-extcap" --extcap-interfaces | grep -q '^extcap ' ||
  { echo "the installed extcap does not answer"; exit 1; }
echo "installed: bin/modtap, share/modtap/models, $libdir/wireshark/{plugins,extcap}," \
     "share/wireshark/profiles/modtap, lib/systemd/system/modtap@.service"
