#!/usr/bin/env bash
# Runs end-to-end tests with every hapticd they start under the unit's
# system call filter, address families and private network (with one
# driver's drop-in), applied by tests/support/sandbox_exec as systemd would:
# systemd is not PID 1 on the machines that run the tests.
#
# usage: systemd_sandbox_run.sh SANDBOX_EXEC UNIT_FILE DROPIN|none -- TEST_BINARY [ARGS...]
set -euo pipefail
sandbox=${1:?usage}; unit=${2:?usage}; dropin=${3:?usage}
shift 3
[[ ${1:-} == -- ]] || { echo "usage: systemd_sandbox_run.sh SANDBOX_EXEC UNIT DROPIN|none -- TEST..." >&2; exit 2; }
shift
if (($(id -u) != 0)); then
  echo "systemd_sandbox_run: skipped: needs root (a private network namespace, the real-time calls)"
  exit 77
fi
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
files=("$unit")
[[ $dropin == none ]] || files+=("$dropin")
bash "$here/systemd_sandbox_policy.sh" "$work/policy" "${files[@]}"
export HAPTICD_E2E_SANDBOX="$sandbox $work/policy --"
"$@"
