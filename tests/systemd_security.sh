#!/usr/bin/env bash
# The unit's `systemd-analyze security` exposure, offline (systemd >= 252:
# no running systemd needed), alone and with each per-driver drop-in of
# systemd/drivers/, must be at most MAX; and `systemd-analyze verify` of
# each combination must say nothing about it (it reports unknown keys only
# as warnings on stderr, with exit status 0: any stderr line naming the unit
# fails). A drop-in is applied the way systemd applies one: its lines after
# the unit's (the copy is the unit's text followed by the drop-in's).
#
# usage: systemd_security.sh UNIT_FILE DROPIN_DIR MAX [--loosened]
#   UNIT_FILE   the generated unit (build/systemd/hapticd.service or hapticd@.service)
#   DROPIN_DIR  systemd/drivers (its *.conf files)
#   MAX         the largest exposure accepted, e.g. 2.0
#   --loosened  self-test: the unit without its sandboxing lines (system
#               call filter, private network, device policy, /proc
#               protection) must score OVER max, or this check could not fail
set -euo pipefail

unit_src=${1:?usage: systemd_security.sh UNIT_FILE DROPIN_DIR MAX [--loosened]}
dropins=${2:?usage: systemd_security.sh UNIT_FILE DROPIN_DIR MAX [--loosened]}
max=${3:?usage: systemd_security.sh UNIT_FILE DROPIN_DIR MAX [--loosened]}
mode=${4:-}
[[ -r $unit_src ]] || { echo "systemd_security: cannot read $unit_src" >&2; exit 2; }
[[ -d $dropins ]] || { echo "systemd_security: no directory $dropins" >&2; exit 2; }
command -v systemd-analyze >/dev/null || { echo "systemd_security: systemd-analyze not found" >&2; exit 2; }
systemd-analyze security --help 2>&1 | grep -q -- '--offline' ||
  { echo "systemd_security: this systemd-analyze has no --offline (systemd >= 252 has)" >&2; exit 2; }

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
binary=$work/hapticd
printf '#!/bin/sh\nexit 0\n' >"$binary"
chmod 755 "$binary"

# A template is analysed as an instance of itself (%i = verify).
unit_name=$(basename "$unit_src")
unit_name=${unit_name/@./@verify.}
# ExecStart must name an executable that exists here (verify checks it).
sed -E "s|^ExecStart=[^ ]+|ExecStart=${binary}|" "$unit_src" >"$work/base"

# exposure NAME FILE...: writes the combination as unit NAME, prints its exposure.
exposure() {
  local name=$1
  shift
  local dir=$work/$name.d
  mkdir -p "$dir"
  cat "$@" >"$dir/$unit_name"
  if ! SYSTEMD_LOG_LEVEL=notice systemd-analyze verify --man=no "$dir/$unit_name" >"$dir/verify.out" \
    2>"$dir/verify.err"; then
    echo "systemd_security: $name: systemd-analyze verify failed:" >&2
    cat "$dir/verify.err" >&2
    return 1
  fi
  if grep -e hapticd -e "$work" "$dir/verify.err" >&2; then
    echo "systemd_security: $name: systemd-analyze verify complains about the unit (above)" >&2
    return 1
  fi
  systemd-analyze security --offline=yes --no-pager "$dir/$unit_name" >"$dir/security.out" 2>&1 || true
  local level
  level=$(sed -n 's/.*Overall exposure level for [^:]*: \([0-9.]*\).*/\1/p' "$dir/security.out")
  if [[ -z $level ]]; then
    echo "systemd_security: $name: no exposure level in:" >&2
    cat "$dir/security.out" >&2
    return 1
  fi
  echo "$level"
}

over() { awk -v a="$1" -v b="$2" 'BEGIN { exit !(a > b) }'; }

if [[ $mode == --loosened ]]; then
  grep -v -E '^(SystemCallFilter|SystemCallArchitectures|PrivateNetwork|IPAddressDeny|DevicePolicy|DeviceAllow|ProtectProc|ProcSubset|RestrictAddressFamilies|MemoryDenyWriteExecute|PrivateMounts)=' \
    "$work/base" >"$work/loose"
  level=$(exposure loosened "$work/loose")
  echo "systemd_security: $unit_src without its sandboxing lines: exposure $level"
  if over "$level" "$max"; then
    echo "systemd_security: OK: the check tells a loosened unit (over $max) apart"
    exit 0
  fi
  echo "systemd_security: FAILED: a loosened unit scores $level, not over $max: the check cannot fail" >&2
  exit 1
fi

fail=0
report() {
  local name=$1 label=$2 level=$3
  if over "$level" "$max"; then
    echo "systemd_security: $label: exposure $level, over $max" >&2
    grep -F '✗' "$work/$name.d/security.out" >&2 || true
    fail=1
  else
    echo "systemd_security: $label: exposure $level (at most $max)"
  fi
}
level=$(exposure unit "$work/base") || exit 1
report unit unit "$level"
shopt -s nullglob
confs=("$dropins"/*.conf)
((${#confs[@]} > 0)) || { echo "systemd_security: no drop-ins in $dropins" >&2; exit 2; }
for conf in "${confs[@]}"; do
  name=$(basename "$conf" .conf)
  level=$(exposure "$name" "$work/base" "$conf") || exit 1
  report "$name" "unit + $name.conf" "$level"
done
if ((fail)); then
  echo "systemd_security: FAILED for $unit_src" >&2
  exit 1
fi
echo "systemd_security: $unit_src and its ${#confs[@]} drop-ins OK"
