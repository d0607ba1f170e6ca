#!/bin/sh
# cmake --install puts the program, the models, the Wireshark plugin and the extcap in their places
# under the prefix (docs/wireshark.md: with --prefix /usr these are where Wireshark looks).
# A build configured first for CMake's default prefix and then for /usr installs the plugin and
# the extcap where Wireshark looks under /usr: the library folder follows the prefix.
# Usage: install_test.sh BUILD_DIR LIBDIR WORK_DIR SOURCE_DIR
set -eu
build=$1 libdir=$2 stage=$3/prefix source=$4
rm -rf "$stage"
cmake --install "$build" --prefix "$stage" >/dev/null
for f in bin/modtap share/modtap/models/nta5000.yaml share/modtap/models/gd20.yaml \
         "$libdir/wireshark/extcap/modtap-extcap" \
         share/wireshark/profiles/modtap/preferences share/wireshark/profiles/modtap/colorfilters \
         share/wireshark/profiles/modtap/recent \
         lib/systemd/system/modtap@.service share/modtap/line3.conf.example \
         share/bash-completion/completions/modtap share/man/man5/modtap-models.5.gz; do
  [ -e "$stage/$f" ] || { echo "missing after install: $f"; exit 1; }
done
# The plugin goes in the folder of the Wireshark release it was built for (4.0/epan).
ls "$stage/$libdir"/wireshark/plugins/*/epan/modtap.so >/dev/null 2>&1 ||
  { echo "missing after install: $libdir/wireshark/plugins/RELEASE/epan/modtap.so"; exit 1; }
"$stage/bin/modtap" models --models-dir "$stage/share/modtap/models" | grep -q '^nta5000 ' ||
  { echo "the installed modtap does not read the installed models"; exit 1; }
"$stage/$libdir/wireshark/extcap/modtap-extcap" --extcap-interfaces | grep -q '^extcap ' ||
  { echo "the installed extcap does not answer"; exit 1; }
echo "installed: bin/modtap, share/modtap/models, $libdir/wireshark/{plugins,extcap}," \
     "share/wireshark/profiles/modtap, lib/systemd/system/modtap@.service"

scratch=$3/reconfigured
rm -rf "$scratch"
cmake -S "$source" -B "$scratch" -DMODTAP_TESTS=OFF -DMODTAP_BENCHMARKS=OFF >/dev/null
cmake -S "$source" -B "$scratch" -DCMAKE_INSTALL_PREFIX=/usr >/dev/null
usr_libdir=$(sed -n 's/^CMAKE_INSTALL_LIBDIR:PATH=//p' "$scratch/CMakeCache.txt")
for piece in plugins/cmake_install.cmake:plugins tools/extcap/cmake_install.cmake:extcap; do
  grep -q "}/$usr_libdir/wireshark/${piece#*:}[/\"]" "$scratch/${piece%%:*}" ||
    { echo "reconfigured for /usr, the ${piece#*:} do not go to /usr/$usr_libdir/wireshark"; exit 1; }
done
echo "reconfigured for /usr: the plugin and the extcap go to /usr/$usr_libdir/wireshark"
