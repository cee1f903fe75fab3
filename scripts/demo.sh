#!/usr/bin/env bash
# One command: install dependencies, build, and run the main job: hapticd on
# the loopback device with the default scene (Freudenberg's 1 Hz virtual
# wheel, exact integrator), then the 45-degree step demo: the scripted hand
# turns the wheel 45 degrees and holds it; the virtual wheel swings and the
# hand feels k z0 cos(w_n t), at most 800 N mm.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh >/dev/null

work=$(mktemp -d /tmp/hapticd-demo-XXXXXX)
socket="$work/hapticd.sock"
hapticd=build/daemon/hapticd
ctl() { build/cli/hapticctl --socket "$socket" "$@"; }

cat >"$work/hapticd.toml" <<TOML
[control]
socket = "$socket"
[recorder]
directory = "$work"
TOML
# The built-in default plus a socket and recording directory of our own,
# and max_velocity: the scripted hand's ideal 45-degree step moves the wheel
# 0.785 rad in one period (785 rad/s), faster than the default lets a device
# move (docs/config.md, "Position plausibility").
sed -n '/^\[loop\]/,/^\[control\]/p' config/hapticd.toml | sed '$d' |
  sed 's/^\[device\]$/[device]\nmax_velocity = 1000/' >>"$work/hapticd.toml"

"$hapticd" --config "$work/hapticd.toml" >"$work/hapticd.log" 2>&1 &
pid=$!
trap 'kill -TERM $pid 2>/dev/null || true; wait $pid 2>/dev/null || true' EXIT
for _ in $(seq 100); do ctl status >/dev/null 2>&1 && break; sleep 0.05; done

echo "== hapticd is running =="
ctl status | sed -n '1,12p'
echo
echo "== Freudenberg 2: the hand turns the wheel 45 degrees at t = 0.2 s and holds it =="
ctl record start --path step.csv
ctl hand mode=hold trajectory=step amplitude=0.785398163 at=0.2 >/dev/null
ctl stream --rate 10 --count 25 position command virtual_position
ctl record stop
echo
kill -TERM $pid
wait $pid || true
trap - EXIT
cat "$work/hapticd.log"
echo
csv="$work/step.csv"
awk -F, '
  /^# period_s:/ {period=$0; sub(/.*: /, "", period)}
  /^#/ || /^time_s/ {next}
  # The virtual world advances one period per cycle; time_s is wall-clock
  # deadlines, which jump ahead over periods the host stalled us through.
  { t=$2*period; tau=$6; if (tau>max) max=tau; if (tau<min) min=tau;
    if (started && prev<0 && tau>=0) {   # upward zero crossing, interpolated
      tc=pt+(0-prev)/(tau-prev)*(t-pt); if (n==0) first=tc; last=tc; n++ }
    if ($3 > 0.7) started=1; prev=tau; pt=t }
  END {
    printf "peak torque on the hand: %.1f N mm (Freudenberg: k z0 = 800 N mm)\n", -min*1000;
    if (n > 1) printf "oscillation: %.4f Hz (virtual wheel tuned to 1 Hz)\n", (n-1)/(last-first);
  }' "$csv"
echo "recording: $csv ($(grep -vc '^#' "$csv") lines)"
