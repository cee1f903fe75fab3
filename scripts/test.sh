#!/usr/bin/env bash
# One command: install dependencies, build, and run every test
# (unit, paper reproductions, end-to-end against the real hapticd, systemd
# unit verification, ThreadSanitizer on the RT primitives, format and lint).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
status=0
(cd build && ctest --output-on-failure --timeout 900 -j2) || status=1
if [ -x tests/run_tsan.sh ]; then bash tests/run_tsan.sh || status=1; fi
bash scripts/lint.sh || status=1
if [ "$status" -eq 0 ]; then echo "all test stages passed"; else echo "some test stage failed"; fi
exit "$status"
