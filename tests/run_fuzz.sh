#!/usr/bin/env bash
# Fuzzes every target in $FUZZ_BUILD/fuzz_targets.txt (tests/fuzz/fuzz.cmake
# writes it; the build must be HAPTICD_FUZZ=ON, tests/run_sanitizers.sh)
# for a bounded time each, starting from its seeds and kept crashers. New
# inputs go to a scratch corpus, never into the repository. A crash, a leak,
# a sanitizer report or an input slower than FUZZ_TIMEOUT fails the run and
# leaves the input in $FUZZ_ARTIFACTS: fix the code, then keep the input as
# tests/fuzz/regressions/<target>/<what-it-was> (docs/testing.md).
# env: FUZZ_SECONDS (10 per target), FUZZ_TIMEOUT (60 s per input),
#      FUZZ_BUILD (build-asan), FUZZ_ARTIFACTS (build-asan/fuzz-artifacts), FUZZ_ONLY (a target name)
set -uo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${FUZZ_BUILD:-$here/build-asan}"
seconds="${FUZZ_SECONDS:-10}"
artifacts="${FUZZ_ARTIFACTS:-$build/fuzz-artifacts}"
list="$build/fuzz_targets.txt"
[[ -f "$list" ]] || { echo "$list missing: configure with -DHAPTICD_FUZZ=ON (tests/run_sanitizers.sh)" >&2; exit 1; }
mkdir -p "$artifacts"
scratch="$(mktemp -d)"
trap 'rm -rf "$scratch"' EXIT
export ASAN_OPTIONS="${ASAN_OPTIONS:-halt_on_error=1:abort_on_error=1:detect_leaks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}"

status=0
while IFS='|' read -r name binary inputs; do
  [[ -z "$name" ]] && continue
  [[ -n "${FUZZ_ONLY:-}" && "$name" != "$FUZZ_ONLY" ]] && continue
  IFS=',' read -r -a dirs <<<"$inputs"
  mkdir -p "$scratch/$name"
  echo "--- fuzz $name for ${seconds}s"
  # -rss_limit_mb: the daemon's inputs are small; a target growing past
  # 2 GB is a finding. -timeout: the stability gate's slowest honest input
  # (a wall at delay 64) takes seconds under ASan, not a minute.
  if "$binary" -max_total_time="$seconds" -timeout="${FUZZ_TIMEOUT:-60}" -rss_limit_mb=2048 \
    -print_final_stats=1 -artifact_prefix="$artifacts/$name-" "$scratch/$name" "${dirs[@]}" \
    >"$scratch/$name.log" 2>&1; then
    grep -E '^stat::number_of_executed_units|^stat::new_units_added|^#[0-9]+.*DONE' "$scratch/$name.log" | tr '\n' ' '
    echo
  else
    status=1
    tail -n 60 "$scratch/$name.log"
    echo "fuzz $name FAILED; the input is in $artifacts/ (keep it under tests/fuzz/regressions/$name/ once fixed)"
  fi
done <"$list"
exit "$status"
