#!/usr/bin/env bash
# Layering: a folder may include project headers only from the folders below
# it (docs/architecture.md). Lower layers never include the daemon. A
# driver's own tests/ folder (drivers/skeleton/tests) is test code, not the
# layer. Prints
# every offending include and exits 1; `--self-test` proves the check fails
# on a planted violation.
set -euo pipefail
root="${1:?usage: layering_check.sh SOURCE_DIR [--self-test]}"
declare -A allowed=(
  [world]="world"
  [analysis]="analysis world"
  [rt]="rt"
  [rpc]="rpc"
  [drivers]="drivers rt rpc world analysis"
  [sim]="sim drivers rt rpc world analysis"
  [client]="client rpc world"
  [cli]="cli client rpc world analysis"
)
check() {
  local dir=$1 bad=0
  for layer in "${!allowed[@]}"; do
    [ -d "$dir/$layer" ] || continue
    while IFS= read -r hit; do
      file=${hit%%:*}
      target=$(sed -E 's/.*#include "([^/"]+)\/.*/\1/' <<<"$hit")
      case " ${allowed[$layer]} " in *" $target "*) continue ;; esac
      echo "layering: $file includes $target/ (a $layer/ file may include only: ${allowed[$layer]})"
      bad=1
    done < <(grep -rHE '^#include "[^/"]+/' "$dir/$layer" --include='*.hpp' --include='*.cpp' --include='*.h' |
      grep -vE "^$dir/$layer/[^:]*/tests/" || true)
  done
  return $bad
}
if [ "${2:-}" = "--self-test" ]; then
  scratch=$(mktemp -d); trap 'rm -rf "$scratch"' EXIT
  mkdir -p "$scratch/drivers/x"
  echo '#include "daemon/service.hpp"' >"$scratch/drivers/x/bad.cpp"
  if check "$scratch" >/dev/null; then echo "self-test: a planted violation passed"; exit 1; fi
  # A driver including its simulated peer: the peer may lean on the driver,
  # never the other way round.
  echo '#include "sim/canopen/simulated_drive.hpp"' >"$scratch/drivers/x/bad.cpp"
  if check "$scratch" >/dev/null; then echo "self-test: a driver including sim/ passed"; exit 1; fi
  echo "self-test: planted violations caught"; exit 0
fi
check "$root" && echo "layering: clean"
