#!/usr/bin/env bash
# Wake-up latency of the real hapticd next to cyclictest's (rt-tests), same
# period, SCHED_FIFO priority and CPU, interleaved in short slices (one of
# each variant per round, rounds >= 10) so the machine's drift hits all
# alike. hapticd runs the loopback wheel, scene spring-wheel, with the
# recorder writing every channel from the first cycle; its numbers are its
# own histogram (`hapticctl stats --json`, reset by stats.reset after a
# warm-up), cyclictest's come from its -h histogram. Both are read the same
# way: 1 us buckets, nearest rank, the bucket's upper edge, capped at the max.
#
# The host stalls this VM's vCPU for milliseconds about twice a second: the
# ratios hapticd / cyclictest (per slice pair, median and spread over the
# rounds) are the result, never an absolute tail. "late" = woken one period
# or more after the deadline (hapticd's overruns; cyclictest's histogram
# from the period up), per 10,000 cycles.
#
# usage: bench/latency.sh [--rounds N] [--slice S] [--periods "1000 250 100"] [--load] [--telemetry] [--axes N] [--bare] [--out DIR]
#   --load  adds two hapticd variants per round: under control-plane load
#           (bench/hapticd_load: 16 clients streaming telemetry at 1 kHz, one
#           param.set 1,000 times a second, every reply naming its cycle),
#           once unpinned and once with [control] cpu and [recorder] cpu on
#           another CPU than the loop; checks every change is acknowledged
#           and no recorded sample is lost.
#   --telemetry  adds a hapticd variant sending UDP telemetry ([telemetry],
#           PlotJuggler's JSON) at the loop rate, every channel, to a
#           receiver that never reads (bench/udp_sink), and reports its
#           percentiles against the same round's hapticd without it.
#   --axes N  adds a hapticd variant on an N-axis loopback stage (2..6,
#           issue 22): one read and one write of every axis per period, the
#           task scene `box` (a 2 cm cube, K = 400 N/m) with the hand on x
#           moving through two of its faces, tau = J^T F; reported against
#           cyclictest and against the same round's one-axis hapticd.
#   --bare  adds each hapticd variant's twin that records nothing (no
#           --record: the recorder thread idles, nothing is written to the
#           disk), reported against its recording twin in the same rounds:
#           what the recorder's disk writes on the other CPU cost the loop.
#   env: CPU (1: the RT CPU), OTHER_CPU (0), PRIORITY (80), BUILD (build), WARMUP_S (0.5)
# Needs root (SCHED_FIFO, /dev/cpu_dma_latency, mlockall) like cyclictest.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
rounds=10 slice=3 periods="1000 250 100" load=0 telemetry=0 axes=0 bare=0 out=""
while [[ $# -gt 0 ]]; do
  case "$1" in
    --rounds) rounds="$2"; shift 2 ;;
    --slice) slice="$2"; shift 2 ;;
    --periods) periods="$2"; shift 2 ;;
    --load) load=1; shift ;;
    --telemetry) telemetry=1; shift ;;
    --axes) axes="$2"; shift 2 ;;
    --bare) bare=1; shift ;;
    --out) out="$2"; shift 2 ;;
    *) echo "usage: $0 [--rounds N] [--slice S] [--periods \"1000 250 100\"] [--load] [--telemetry] [--axes N] [--bare] [--out DIR]" >&2; exit 2 ;;
  esac
done
cpu="${CPU:-1}" other="${OTHER_CPU:-0}" prio="${PRIORITY:-80}" warmup="${WARMUP_S:-0.5}"
build="${BUILD:-$here/build}"
hapticd="$build/daemon/hapticd" hapticctl="$build/cli/hapticctl" loadgen="$build/bench/hapticd_load"
udpsink="$build/bench/udp_sink"
for tool in cyclictest jq awk; do
  command -v "$tool" >/dev/null || { echo "$tool not found (scripts/install-deps.sh)" >&2; exit 1; }
done
for bin in "$hapticd" "$hapticctl"; do [[ -x "$bin" ]] || { echo "$bin not built (scripts/build.sh)" >&2; exit 1; }; done
if [[ "$load" == 1 && ! -x "$loadgen" ]]; then echo "$loadgen not built (ninja -C build hapticd_load)" >&2; exit 1; fi
if [[ "$telemetry" == 1 && ! -x "$udpsink" ]]; then echo "$udpsink not built (ninja -C build udp_sink)" >&2; exit 1; fi
[[ "$(id -u)" == 0 ]] || echo "warning: not root: SCHED_FIFO and cpu_dma_latency will be refused; the numbers mean little" >&2

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
out="${out:-$work/results}"
mkdir -p "$out"
variants=(cyclictest hapticd)
[[ "$load" == 1 ]] && variants+=(loaded loaded-pinned)
[[ "$telemetry" == 1 ]] && variants+=(telemetry)
if [[ "$axes" != 0 ]]; then
  [[ "$axes" =~ ^[2-6]$ ]] || { echo "--axes takes 2 to 6 (got '$axes')" >&2; exit 2; }
  variants+=("axes$axes")
fi
if [[ "$bare" == 1 ]]; then
  variants+=(hapticd-bare)
  [[ "$axes" != 0 ]] && variants+=("axes$axes-bare")
fi

# ---- the RT CPU's own accounting (/proc/stat, USER_HZ ticks): how busy it
# was and how much time the host stole from it over a slice. A vCPU that
# runs is preempted by the host; one that sleeps (HLT) mostly is not: the
# late cycles follow what the loop costs the CPU, not the wake-up path
# (README, "Wake-up latency with six axes").
cpu_ticks() {  # prints "busy steal total" of the RT CPU so far
  awk -v c="cpu$cpu" '$1 == c { t = 0; for (i = 2; i <= NF; i++) t += $i; print $2 + $3 + $4 + $7 + $8, $9, t }' /proc/stat
}
cpu_since() {  # "busy steal total" before -> "busy_pct steal_ms_per_s" since
  local now; now="$(cpu_ticks)"
  awk -v a="$1" -v b="$now" -v hz="$(getconf CLK_TCK)" 'BEGIN { split(a, x, " "); split(b, y, " ")
    t = y[3] - x[3]; if (t <= 0) t = 1
    printf "%.2f %.2f\n", 100 * (y[1] - x[1]) / t, 1000 * (y[2] - x[2]) / t }'
}
# ---- one slice of each kind: writes one line "p50 p99 p999 max late_per_10k cycles [compute_p50 compute_p99]",
# and "busy_pct steal_ms_per_s" of the RT CPU over the slice to FILE.cpu
cyclictest_slice() {  # period_us file
  local period="$1" result="$2" hist=$((2 * $1 > 2000 ? 2 * $1 : 2000)) before
  before="$(cpu_ticks)"
  cyclictest -m -q -p"$prio" -a"$cpu" -t1 -i"$period" -D"$slice" -h"$hist" >"$work/ct.txt" 2>&1 || true
  cpu_since "$before" >"$result.cpu"
  awk -v H="$hist" -v T="$period" '
    /^[0-9]+[ \t]+[0-9]+/ { c[$1 + 0] = $2 + 0; n += $2; if ($1 + 0 >= T) late += $2 }
    /# Max Latencies:/ { max = $4 + 0 }
    /# Histogram Overflows:/ { over = $4 + 0 }
    function pct(p,   r, s, i) {
      r = int(p * (n + over)); if (r < p * (n + over)) r++; if (r < 1) r = 1
      s = 0; for (i = 0; i < H; i++) { s += c[i]; if (s >= r) return (i + 1 < max ? i + 1 : max) }
      return max
    }
    END {
      if (n + over == 0) { print "cyclictest produced no samples" > "/dev/stderr"; exit 1 }
      printf "%s %s %s %s %.3f %d\n", pct(0.5), pct(0.99), pct(0.999), max, (late + over) * 1e4 / (n + over), n + over
    }' "$work/ct.txt" >"$result"
}

# The one-axis wheel, or an N-axis stage (variant axesN) rendering a box whose
# faces the hand on x crosses at 1 Hz (the others held), every axis 0.1 kg.
device_and_scene() {  # variant
  if [[ "$1" != axes* ]]; then
    printf '[device]\ndriver = "loopback"\n[scene]\nname = "spring-wheel"\nintegrator = "exact"\n'
    return
  fi
  local n="${1#axes}" low high masses hands
  n="${n%-bare}"
  low="$(printf -- '-0.01,%.0s' $(seq "$n"))" high="$(printf -- '0.01,%.0s' $(seq "$n"))"
  masses="$(printf -- '0.1,%.0s' $(seq "$n"))"
  hands="mode=hold trajectory=sine amplitude=0.015 frequency=1$(printf -- '; mode=hold%.0s' $(seq 2 "$n"))"
  printf '[device]\ndriver = "loopback"\ntorque_limit = 10.0\nkinematics = "cartesian"\n'
  printf '[device.loopback]\naxes = %s\naxis_mass = "%s"\nhands = "%s"\n' "$n" "${masses%,}" "$hands"
  printf '[scene]\nname = "box"\nlow = "%s"\nhigh = "%s"\nstiffness = 400.0\ndamping = 2.0\n' "${low%,}" "${high%,}"
}

hapticd_config() {  # period_us variant socket dir [udp_port]
  local placement="" telemetry_section=""
  if [[ "$2" == telemetry ]]; then
    telemetry_section="[telemetry]
udp = \"127.0.0.1:$5\"
rate_hz = $((1000000 / $1))"
  fi
  [[ "$2" == loaded-pinned ]] && placement="cpu = $other"
  cat <<EOF
[loop]
period = "$1us"
priority = $prio
cpu = $cpu
clock = "real"
overrun_limit = 0
$(device_and_scene "$2")
[control]
socket = "$3"
max_clients = 32
$placement
[recorder]
directory = "$4"
$placement
$telemetry_section
EOF
}

hapticd_slice() {  # period_us variant file
  local period="$1" variant="$2" result="$3" dir="$work/d"
  rm -rf "$dir" && mkdir -p "$dir"
  local sinkpid="" sinkport=""
  if [[ "$variant" == telemetry ]]; then
    # On the other CPU, like any client; it never reads.
    taskset -c "$other" "$udpsink" >"$dir/sink.port" &
    sinkpid=$!
    for _ in $(seq 100); do [[ -s "$dir/sink.port" ]] && break; sleep 0.02; done
    sinkport="$(cat "$dir/sink.port")"
  fi
  hapticd_config "$period" "$variant" "$dir/s.sock" "$dir" "$sinkport" >"$dir/h.toml"
  local record=(--record rec.csv)
  [[ "$variant" == *-bare ]] && record=()
  "$hapticd" --config "$dir/h.toml" "${record[@]}" >"$dir/log" 2>&1 &
  local pid=$!
  for _ in $(seq 200); do
    [[ -S "$dir/s.sock" ]] && "$hapticctl" --socket "$dir/s.sock" status >/dev/null 2>&1 && break
    sleep 0.05
  done
  local ctl=("$hapticctl" --socket "$dir/s.sock") loadpid=""
  if [[ "$variant" == loaded* ]]; then
    # The load runs on the other CPU, like any client should.
    taskset -c "$other" "$loadgen" --socket "$dir/s.sock" --streams 16 --stream-rate 1000 --sets 1000 \
      --duration "$(awk -v s="$slice" -v w="$warmup" 'BEGIN { print s + w + 0.5 }')" >"$dir/load.json" 2>"$dir/load.err" &
    loadpid=$!
  fi
  sleep "$warmup"
  "${ctl[@]}" device call stats.reset >/dev/null
  local before; before="$(cpu_ticks)"
  sleep "$slice"
  "${ctl[@]}" stats --json >"$dir/stats.json"
  cpu_since "$before" >"$result.cpu"
  local load_ok=1
  if [[ -n "$loadpid" ]]; then
    wait "$loadpid" || load_ok=0
    cp "$dir/load.json" "$out/load-$period-$variant-$round.json" 2>/dev/null || true
  fi
  [[ "$variant" == *-bare ]] || "${ctl[@]}" record stop --json >"$dir/record.json" || true
  kill -TERM "$pid"; wait "$pid" || true
  if [[ -n "$sinkpid" ]]; then
    kill -TERM "$sinkpid"; wait "$sinkpid" || true
    jq -c '.telemetry' "$dir/stats.json" >"$out/telemetry-$period-$round.json" 2>/dev/null || true
  fi
  jq -r --argjson T "$period" '
    [.latency.p50_us, .latency.p99_us, .latency.p999_us, .latency.max_us,
     (.overruns * 1e4 / .cycles), .cycles, .compute.p50_us, .compute.p99_us] | map(tostring) | join(" ")' \
    "$dir/stats.json" >"$result"
  # Losses: none allowed in the recording; every change acknowledged under load.
  local lost
  lost=$(jq -r '.dropped_ring + .dropped_write + .cycle_gaps' "$dir/record.json" 2>/dev/null || echo "?")
  [[ "$variant" == *-bare ]] && lost=0  # records nothing, loses nothing
  echo "$lost" >"$result.lost"
  if [[ -n "$loadpid" ]]; then
    jq -c '{sets_sent, sets_acknowledged, sets_failed, sets_unanswered, ack_ms, notifications_received,
            notifications_dropped_by_daemon}' "$dir/load.json" >"$result.load" 2>/dev/null || echo '{}' >"$result.load"
    [[ "$load_ok" == 1 ]] || echo "  load: not every change was acknowledged: $(cat "$dir/load.json" "$dir/load.err")" >&2
  fi
}

# ---- summary: median (min-max) of per-round ratios, and medians of the values
median_spread() {  # reads numbers, prints "median (min-max)"
  sort -g | awk '{ v[NR] = $1 } END {
    if (NR == 0) { print "-"; exit }
    m = (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2
    printf "%.2f (%.2f-%.2f)", m, v[1], v[NR] }'
}
median_of() { sort -g | awk '{ v[NR] = $1 } END { if (NR == 0) { print "-"; exit }
  m = (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2; printf "%.1f", m }'; }

echo "hapticd vs cyclictest: cpu $cpu, priority $prio, $rounds rounds of ${slice}s slices (${variants[*]}), kernel $(uname -r)"
for period in $periods; do
  for ((round = 1; round <= rounds; round++)); do
    # Rotate the order so no variant always follows the same one.
    for ((k = 0; k < ${#variants[@]}; k++)); do
      v="${variants[$(((k + round) % ${#variants[@]}))]}"
      f="$out/$period-$v-$round"
      if [[ "$v" == cyclictest ]]; then cyclictest_slice "$period" "$f"; else hapticd_slice "$period" "$v" "$f"; fi
    done
    printf '.' >&2
  done
  echo >&2
  echo
  echo "period ${period} us:"
  printf '  %-16s %8s %8s %8s %8s %10s %s\n' variant p50_us p99_us p99.9_us max_us late/10k "compute p50/p99 us"
  for v in "${variants[@]}"; do
    col() { for ((r = 1; r <= rounds; r++)); do awk -v c="$1" '{ print $c }' "$out/$period-$v-$r"; done | median_of; }
    compute=""
    [[ "$v" != cyclictest ]] && compute="$(col 7)/$(col 8)"
    printf '  %-16s %8s %8s %8s %8s %10s %s\n' "$v" "$(col 1)" "$(col 2)" "$(col 3)" "$(col 4)" "$(col 5)" "$compute"
  done
  for v in "${variants[@]}"; do
    [[ "$v" == cyclictest ]] && continue
    ratios() {  # column, reference variant: this variant / the reference, per round
      for ((r = 1; r <= rounds; r++)); do
        awk -v c="$1" 'NR == FNR { h = $c; next } { if ($c > 0) printf "%.6f\n", h / $c }' \
          "$out/$period-$v-$r" "$out/$period-$2-$r"
      done | median_spread
    }
    printf '  %-16s p50 %s  p99 %s  p99.9 %s  max %s   (%s / cyclictest, median (min-max) of %d rounds)\n' \
      "$v" "$(ratios 1 cyclictest)" "$(ratios 2 cyclictest)" "$(ratios 3 cyclictest)" "$(ratios 4 cyclictest)" "$v" "$rounds"
    if [[ "$v" == loaded* || "$v" == telemetry || "$v" == axes* ]]; then
      printf '  %-16s p50 %s  p99 %s  p99.9 %s   (%s / hapticd without it, same rounds)\n' "" \
        "$(ratios 1 hapticd)" "$(ratios 2 hapticd)" "$(ratios 3 hapticd)" "$v"
    fi
    if [[ "$v" == *-bare ]]; then
      printf '  %-16s p50 %s  p99 %s  p99.9 %s   (%s / %s, recording, same rounds)\n' "" \
        "$(ratios 1 "${v%-bare}")" "$(ratios 2 "${v%-bare}")" "$(ratios 3 "${v%-bare}")" "$v" "${v%-bare}"
    fi
    if [[ "$v" == telemetry ]]; then
      for ((r = 1; r <= rounds; r++)); do cat "$out/telemetry-$period-$r.json" 2>/dev/null; done | jq -s -r '"  " +
        "                 telemetry datagrams sent \(map(.datagrams_sent) | add), samples dropped by the daemon " +
        "\(map(.dropped) | add) (socket buffer full \(map(.buffer_full) | add), refused \(map(.refused) | add))"'
    fi
    late() { for ((r = 1; r <= rounds; r++)); do cat "$out/$period-$1-$r"; done | awk '{ l += $5 * $6 / 1e4; n += $6 } END { printf "%.2f", l * 1e4 / n }'; }
    lost=$(for ((r = 1; r <= rounds; r++)); do cat "$out/$period-$v-$r.lost"; done | awk '$1 != 0 { bad++ } END { print bad + 0 }')
    printf '  %-16s late per 10,000 cycles over all rounds: %s (cyclictest %s); slices that lost recorded samples: %s\n' \
      "" "$(late "$v")" "$(late cyclictest)" "$lost"
    # The late cycles come in bursts (a host stall of milliseconds makes one
    # late wake-up; a cluster of them fills one slice): the per-slice counts'
    # median and spread say whether a variant loses more, the total above
    # is dominated by its worst slices.
    late_slices() { for ((r = 1; r <= rounds; r++)); do awk '{ printf "%.0f\n", $5 * $6 / 1e4 }' "$out/$period-$1-$r"; done | median_spread; }
    printf '  %-16s late cycles per slice: %s (cyclictest %s), median (min-max)\n' "" "$(late_slices "$v")" \
      "$(late_slices cyclictest)"
    # Paired by round (one round's slices ran back to back): the rounds in
    # which this variant was late more often than cyclictest, and fewer
    # times; a two-sided sign test over the rounds that differ. Blind to how
    # big one slice's burst is, which the totals above are not.
    late_pairs() {
      for ((r = 1; r <= rounds; r++)); do
        awk 'NR == FNR { a = sprintf("%.0f", $5 * $6 / 1e4) + 0; next }
             { b = sprintf("%.0f", $5 * $6 / 1e4) + 0; print (a > b) ? 1 : (a < b) ? -1 : 0 }' \
          "$out/$period-$1-$r" "$out/$period-cyclictest-$r"
      done | awk '$1 > 0 { m++ } $1 < 0 { f++ } $1 == 0 { e++ } END {
        n = m + f; k = (m < f) ? m : f; c = 1; s = 0
        for (i = 0; i <= k; i++) { s += c; c = c * (n - i) / (i + 1) }
        p = (n > 0) ? 2 * s / 2 ^ n : 1; if (p > 1) p = 1
        printf "more in %d rounds, fewer in %d, as many in %d (sign test p = %.2f)", m, f, e, p }'
    }
    printf '  %-16s late cycles against cyclictest, round by round: %s\n' "" "$(late_pairs "$v")"
    cpu_col() { for ((r = 1; r <= rounds; r++)); do awk -v c="$2" '{ print $c }' "$out/$period-$1-$r.cpu"; done | median_of; }
    printf '  %-16s the RT CPU busy %s %% (cyclictest %s %%, hapticd %s %%), stolen by the host %s ms/s (%s, %s); medians of the slices\n' \
      "" "$(cpu_col "$v" 1)" "$(cpu_col cyclictest 1)" "$(cpu_col hapticd 1)" "$(cpu_col "$v" 2)" \
      "$(cpu_col cyclictest 2)" "$(cpu_col hapticd 2)"
    if [[ "$v" == loaded* ]]; then
      for ((r = 1; r <= rounds; r++)); do cat "$out/$period-$v-$r.load"; done | jq -s -r '"  " + "                 " +
        "param.set sent \(map(.sets_sent) | add), acknowledged with a cycle \(map(.sets_acknowledged) | add), " +
        "failed \(map(.sets_failed) | add), unanswered \(map(.sets_unanswered) | add); ack p99 (worst slice) " +
        "\(map(.ack_ms.p99) | max) ms; telemetry received \(map(.notifications_received) | add), dropped by the daemon \(map(.notifications_dropped_by_daemon) | add)"'
    fi
  done
done
echo
echo "raw slices: $out (kept with --out DIR)"
