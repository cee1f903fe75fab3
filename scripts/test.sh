#!/usr/bin/env bash
# One command: install dependencies, build, and run every test
# (unit, paper reproductions, end-to-end against the real hapticd, systemd
# unit verification, the kept fuzz crashers, format and lint), then the
# sanitizer stages (tests/run_sanitizers.sh: the whole suite under
# ASan+UBSan, bounded fuzzing, ThreadSanitizer where threads meet). Each
# stage's time is printed at the end.
#   --quick  install, build and ctest only: what a contributor runs while
#            working; CI runs everything.
set -euo pipefail
cd "$(dirname "$0")/.."
quick=0
case "${1:-}" in
  --quick) quick=1 ;;
  "") ;;
  *) echo "usage: scripts/test.sh [--quick]  (got '$1')" >&2; exit 2 ;;
esac
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
# The ASan+UBSan build at nice 19 beside ctest, package and lint (its output
# in build/asan-build.log): ctest waits on daemons, sockets and timers for most of
# its time and leaves a core idle, which the niced compiler takes; a stage
# that needs the CPU gets it first. The sanitizer stage then finds it built.
asan_pid=""
wait_asan_build() {  # the time it still takes after lint; its log on failure
  wait "$asan_pid" && return 0
  tail -n 60 build/asan-build.log
  return 1
}
if [ "$quick" -eq 0 ]; then
  (renice -n 19 -p "$BASHPID" >/dev/null && exec bash tests/run_sanitizers.sh asan-build) >build/asan-build.log 2>&1 &
  asan_pid=$!
fi
timed ctest sh -c 'cd build && ctest --output-on-failure --timeout 900 -j2'
if [ "$quick" -eq 0 ]; then
  timed package bash tests/package_test.sh build
  timed lint bash scripts/lint.sh
  # --- issue 14: sanitizers and fuzzing (tests/run_sanitizers.sh times its own parts)
  timed "asan build (rest)" wait_asan_build
  timed sanitizers bash tests/run_sanitizers.sh
  # ---
fi
echo "stage times:"
printf '  %s\n' "${times[@]}"
if [ "$status" -eq 0 ]; then echo "all test stages passed"; else echo "some test stage failed"; fi
exit "$status"
