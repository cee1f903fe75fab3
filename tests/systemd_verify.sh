#!/usr/bin/env bash
# Verifies the generated hapticd.service with `systemd-analyze verify`.
# systemd-analyze reports unknown keys and bad values only as warnings on
# stderr with exit status 0, so this script fails on ANY stderr line that
# mentions the unit (its name or file), and on a non-zero exit status. Lines
# about other units (dependencies loaded from the host) are shown and ignored.
#
# usage: systemd_verify.sh UNIT_FILE [BINARY] [--inject-typo]
#   UNIT_FILE  the generated unit (build/systemd/hapticd.service or hapticd@.service)
#   BINARY     executable to put in ExecStart (the built hapticd); empty or
#              missing: a temporary dummy executable
#   --inject-typo  add an unknown key to the copy: the check must then fail
#                  (CTest runs this with WILL_FAIL to prove the check works)
set -euo pipefail

unit_src=${1:?usage: systemd_verify.sh UNIT_FILE [BINARY] [--inject-typo]}
binary=${2:-}
inject=${3:-}
[[ -r $unit_src ]] || { echo "systemd_verify: cannot read $unit_src" >&2; exit 2; }
command -v systemd-analyze >/dev/null || { echo "systemd_verify: systemd-analyze not found" >&2; exit 2; }

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
if [[ -z $binary ]]; then
  binary=$work/hapticd
  printf '#!/bin/sh\nexit 0\n' >"$binary"
  chmod 755 "$binary"
fi
[[ -x $binary ]] || { echo "systemd_verify: $binary is not executable" >&2; exit 2; }

# A template (hapticd@.service) is checked as an instance of itself: systemd
# parses hapticd@verify.service with %i = verify, so every key is checked.
unit_name=$(basename "$unit_src")
unit=$work/${unit_name/@./@verify.}
# Point ExecStart at an executable that exists here (verify checks it).
sed -E "s|^ExecStart=[^ ]+|ExecStart=${binary}|" "$unit_src" >"$unit"
grep -q "^ExecStart=${binary} " "$unit" || { echo "systemd_verify: no ExecStart= in $unit_src" >&2; exit 2; }
if [[ $inject == --inject-typo ]]; then
  sed -i 's/^\[Service\]$/[Service]\nRestrt=on-failure/' "$unit"
fi

set +e
SYSTEMD_LOG_LEVEL=notice systemd-analyze verify --man=no "$unit" >"$work/out" 2>"$work/err"
status=$?
set -e

cat "$work/out"
fail=0
while IFS= read -r line; do
  if [[ $line == *hapticd* || $line == *"$work"* ]]; then
    echo "systemd_verify: unit problem: $line" >&2
    fail=1
  else
    echo "systemd_verify: ignored (not about this unit): $line" >&2
  fi
done <"$work/err"
if ((status != 0)); then
  echo "systemd_verify: systemd-analyze verify exited with $status" >&2
  fail=1
fi
if ((fail)); then
  echo "systemd_verify: FAILED for $unit_src" >&2
  exit 1
fi
echo "systemd_verify: $unit_src OK (ExecStart=$binary)"
