#!/usr/bin/env bash
# Wake-up latency of the hapticd loop (PeriodicSchedule + RealClock on a
# SCHED_FIFO thread, BM_PeriodicLoop in loop_latency_bench) next to
# cyclictest's, measured in the same run, same period, same priority, both
# holding /dev/cpu_dma_latency at 0 and with memory locked. On these VMs the
# host stalls the vCPU 1-43 ms about twice a second, so absolute tails mean
# little; the ratio to cyclictest is what tells whether the loop adds latency.
#
# usage: bench/cyclictest_compare.sh [cycles=20000] [sequential|concurrent]
#   env: INTERVAL_US (1000), PRIORITY (80), CPU (unset: not pinned),
#        BENCH (build/bench/loop_latency_bench)
# Needs root (or CAP_SYS_NICE) for SCHED_FIFO; runs anyway and says so.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cycles="${1:-20000}"
mode="${2:-sequential}"
interval="${INTERVAL_US:-1000}"
prio="${PRIORITY:-80}"
bench="${BENCH:-$here/build/bench/loop_latency_bench}"
hist_us=50000  # cyclictest histogram range; larger latencies are overflows
command -v cyclictest >/dev/null || { echo "cyclictest not found (apt install rt-tests)" >&2; exit 1; }
[[ -x "$bench" ]] || { echo "$bench not built (scripts/build.sh)" >&2; exit 1; }

tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
ct_args=(-m -p"$prio" -i"$interval" -l"$cycles" -q -h"$hist_us")
[[ -n "${CPU:-}" ]] && ct_args+=(-a"$CPU")

run_cyclictest() { cyclictest "${ct_args[@]}" >"$tmp/ct.txt" 2>&1; }
run_loop() {
  HAPTICD_LOOP_CYCLES="$cycles" HAPTICD_LOOP_PERIOD_US="$interval" HAPTICD_LOOP_PRIORITY="$prio" \
  HAPTICD_LOOP_CPU="${CPU:--1}" \
    "$bench" --benchmark_filter='BM_PeriodicLoop' --benchmark_format=json >"$tmp/loop.json" 2>"$tmp/loop.err"
}

echo "cycles=$cycles interval=${interval}us priority=$prio mode=$mode cpu=${CPU:-any} kernel=$(uname -r)"
case "$mode" in
  sequential) run_cyclictest; run_loop ;;
  concurrent) run_cyclictest & ct_pid=$!; run_loop; wait "$ct_pid" ;;
  *) echo "mode must be sequential or concurrent" >&2; exit 2 ;;
esac

# cyclictest: nearest-rank percentiles from its 1 us histogram (+ overflows).
read -r ct_p50 ct_p99 ct_p999 ct_max ct_total ct_over < <(awk -v H="$hist_us" '
  /^[0-9]+ +[0-9]+/ { c[$1+0] = $2+0; n += $2 }
  /# Max Latencies:/ { max = $4+0 }
  /# Histogram Overflows:/ { over = $4+0 }
  function pct(p,   r, s, i) {
    r = int(p * (n + over)); if (r < p * (n + over)) r++; if (r < 1) r = 1
    s = 0; for (i = 0; i < H; i++) { s += c[i]; if (s >= r) return i }
    return ">" H
  }
  END { print pct(0.5), pct(0.99), pct(0.999), max, n + over, over }' "$tmp/ct.txt")

j() { jq -r ".benchmarks[0].$1" "$tmp/loop.json"; }
lp50=$(j p50_us); lp99=$(j p99_us); lp999=$(j p999_us); lmax=$(j max_us)
label=$(jq -r '.benchmarks[0].label // ""' "$tmp/loop.json")

ratio() { awk -v a="$1" -v b="$2" 'BEGIN { if (b ~ /^>/ || b + 0 == 0) print "-"; else printf "%.2f", a / b }'; }
printf '\n%-10s %14s %14s %10s\n' "latency" "cyclictest" "hapticd loop" "loop/ct"
printf '%-10s %14s %14.1f %10s\n' "p50 (us)" "$ct_p50" "$lp50" "$(ratio "$lp50" "$ct_p50")"
printf '%-10s %14s %14.1f %10s\n' "p99 (us)" "$ct_p99" "$lp99" "$(ratio "$lp99" "$ct_p99")"
printf '%-10s %14s %14.1f %10s\n' "p99.9 (us)" "$ct_p999" "$lp999" "$(ratio "$lp999" "$ct_p999")"
printf '%-10s %14s %14.1f %10s\n' "max (us)" "$ct_max" "$lmax" "$(ratio "$lmax" "$ct_max")"
printf '\ncyclictest: %s samples, %s above %s us\n' "$ct_total" "$ct_over" "$hist_us"
printf 'loop: overruns=%s missed_periods=%s max_overrun_streak=%s sched_fifo=%s dma_latency=%s mlocked=%s\n' \
  "$(j overruns)" "$(j missed)" "$(j max_streak)" "$(j sched_fifo)" "$(j dma_latency)" "$(j mlocked)"
[[ -n "$label" ]] && printf 'loop setup problems: %s\n' "$label"
printf '(cyclictest reports whole microseconds, truncated; the loop reports exact values)\n'
