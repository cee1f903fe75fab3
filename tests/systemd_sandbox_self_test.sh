#!/usr/bin/env bash
# The sandboxed end-to-end runs mean something only if sandbox_exec applies
# the policy: hapticd with require_rt runs SCHED_FIFO under the unit's
# policy, and is refused (EPERM) under the same policy less
# sched_setscheduler.
#
# usage: systemd_sandbox_self_test.sh SANDBOX_EXEC HAPTICD UNIT_FILE
set -euo pipefail
sandbox=${1:?usage}; hapticd=${2:?usage}; unit=${3:?usage}
if (($(id -u) != 0)); then
  echo "systemd_sandbox_self_test: skipped: needs root"
  exit 77
fi
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
bash "$here/systemd_sandbox_policy.sh" "$work/unit" "$unit"
grep -qx sched_setscheduler "$work/unit.syscalls" || { echo "the unit's policy lacks sched_setscheduler" >&2; exit 1; }
grep -vx sched_setscheduler "$work/unit.syscalls" >"$work/less.syscalls"
cp "$work/unit.families" "$work/less.families"
cp "$work/unit.network" "$work/less.network"
cat >"$work/h.toml" <<TOML
[loop]
require_rt = true
duration = "0.2s"
[control]
socket = "$work/h.sock"
[recorder]
directory = "$work"
TOML
"$sandbox" "$work/unit" -- "$hapticd" --config "$work/h.toml" >"$work/full.log" 2>&1 ||
  { cat "$work/full.log"; echo "FAILED: hapticd did not run SCHED_FIFO under the unit's policy" >&2; exit 1; }
if "$sandbox" "$work/less" -- "$hapticd" --config "$work/h.toml" >"$work/less.log" 2>&1; then
  cat "$work/less.log"
  echo "FAILED: hapticd ran without sched_setscheduler: the filter is not applied" >&2
  exit 1
fi
grep -q "SCHED_FIFO priority 80 refused (EPERM)" "$work/less.log" ||
  { cat "$work/less.log"; echo "FAILED: not refused for the missing call" >&2; exit 1; }
echo "systemd_sandbox_self_test: OK: SCHED_FIFO under the unit's policy, refused (EPERM) without sched_setscheduler"
