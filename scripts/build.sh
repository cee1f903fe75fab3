#!/usr/bin/env bash
# Configures and builds hapticd into ./build (Release-with-debug-info, -Werror).
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc 2>/dev/null || echo 2)
cmake -S . -B build -G Ninja -DHAPTICD_WERROR=ON "$@"
cmake --build build -j"$jobs"
