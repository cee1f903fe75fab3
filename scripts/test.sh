#!/usr/bin/env bash
# One command: install dependencies, build, and run every test
# (unit, paper reproductions, end-to-end against the real hapticd, systemd
# unit verification, the kept fuzz crashers, format and lint), then the
# sanitizer stages (tests/run_sanitizers.sh: the whole suite under
# ASan+UBSan, bounded fuzzing, ThreadSanitizer where threads meet). Each
# stage's time is printed at the end.
set -euo pipefail
cd "$(dirname "$0")/.."
status=0
times=()
timed() {  # name command...: runs it, records its time; a failure fails the run
  local name="$1" start=$SECONDS rc=0
  shift
  "$@" || rc=$?
  times+=("$(printf '%-22s %5d s %s' "$name" $((SECONDS - start)) "$([ "$rc" -eq 0 ] && echo ok || echo FAILED)")")
  [ "$rc" -eq 0 ] || status=1
  return 0
}
timed install-deps bash scripts/install-deps.sh
timed build bash scripts/build.sh
[ "$status" -eq 0 ] || { printf '%s\n' "${times[@]}"; exit 1; }
timed ctest sh -c 'cd build && ctest --output-on-failure --timeout 900 -j2'
timed package bash tests/package_test.sh build
timed lint bash scripts/lint.sh
# --- issue 14: sanitizers and fuzzing (tests/run_sanitizers.sh times its own parts)
timed sanitizers bash tests/run_sanitizers.sh
# ---
echo "stage times:"
printf '  %s\n' "${times[@]}"
if [ "$status" -eq 0 ]; then echo "all test stages passed"; else echo "some test stage failed"; fi
exit "$status"
