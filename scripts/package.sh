#!/usr/bin/env bash
# Builds the Debian package build-package/modtap_VERSION_ARCH.deb (as root on Debian 12) and
# checks it with lintian (docs/packaging.md). Beside what building needs: help2man for the man
# pages, dpkg-dev for the Depends line, lintian, Wireshark's headers for its plugin.
set -euo pipefail
cd "$(dirname "$0")/.."
export BUILD_DIR=build-package BUILD_TYPE=Release
export EXTRA_PACKAGES="help2man dpkg-dev lintian libwireshark-dev libglib2.0-dev ${EXTRA_PACKAGES:-}"
export CMAKE_ARGS="-DCMAKE_INSTALL_PREFIX=/usr -DMODTAP_HARDENING=ON ${CMAKE_ARGS:-}"
bash scripts/setup.sh
(cd "$BUILD_DIR" && cpack -G DEB >/dev/null)
deb=$(ls "$BUILD_DIR"/modtap_*.deb)
lintian --fail-on error "$deb"
echo "$deb"
