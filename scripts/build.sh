#!/usr/bin/env bash
# Configures and builds hapticd into ./build: Release (what a user or a
# packager builds) with -Werror (CI's and the scripts' choice; the default
# options leave warnings as warnings). Extra arguments go to cmake.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc 2>/dev/null || echo 2)
# Debian's hardening flags (dpkg-buildflags, as the package is built with):
# the tests run the code the package ships, and scripts/package.sh reuses
# this tree (debian/buildflags.sh). They apply when the tree is first
# configured.
. debian/buildflags.sh
# Unity units of 16 sources for the libraries and programs (the tests are
# one file each, tests/CMakeLists.txt): the heavy headers (CLI11's inline
# classes alone cost ~6 s a file at -O3) are compiled once a unit. That every
# source also compiles by itself is checked by scripts/lint.sh.
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DHAPTICD_WERROR=ON \
  -DCMAKE_UNITY_BUILD=ON -DCMAKE_UNITY_BUILD_BATCH_SIZE=16 "$@"
cmake --build build -j"$jobs"
