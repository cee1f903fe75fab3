#!/usr/bin/env bash
# What the unit (plus drop-ins) lets the daemon do, as systemd would apply
# it, for tests/support/sandbox_exec: evaluates the SystemCallFilter= lines
# in order (the first one, an allow list, sets the mode; later ones add, or
# with ~ remove), expanding each @group with `systemd-analyze syscall-filter`
# (systemd's own lists, so the test uses the same sets as the unit), the
# RestrictAddressFamilies= lines (merged) and PrivateNetwork= (last wins).
#
# usage: systemd_sandbox_policy.sh OUT UNIT_FILE [DROPIN...]
# writes OUT.syscalls (one name a line), OUT.families (AF_UNIX,AF_CAN,...)
# and OUT.network ("private" or "host").
set -euo pipefail

out=${1:?usage: systemd_sandbox_policy.sh OUT UNIT_FILE [DROPIN...]}
shift
(($# > 0)) || { echo "usage: systemd_sandbox_policy.sh OUT UNIT_FILE [DROPIN...]" >&2; exit 2; }
command -v systemd-analyze >/dev/null || { echo "systemd_sandbox_policy: systemd-analyze not found" >&2; exit 2; }

declare -A expanded_groups=()
# expand NAME: prints the system calls NAME stands for (a group, recursively, or itself).
expand() {
  local name=$1
  if [[ $name != @* ]]; then
    echo "$name"
    return
  fi
  [[ -n ${expanded_groups[$name]:-} ]] && return
  expanded_groups[$name]=1
  local member
  while read -r member; do
    [[ -z $member || $member == \#* || $member == "$name" ]] && continue
    expand "$member"
  done < <(systemd-analyze syscall-filter --no-pager "$name")
}

declare -A allowed=()
mode=""
families=()
network=host
while IFS= read -r line; do
  key=${line%%=*}
  value=${line#*=}
  case $key in
    SystemCallFilter)
      if [[ -z $value ]]; then
        allowed=()
        mode=""
        continue
      fi
      deny=0
      if [[ $value == ~* ]]; then
        deny=1
        value=${value#\~}
      fi
      if [[ -z $mode ]]; then
        ((deny)) && { echo "systemd_sandbox_policy: a deny-list filter is not handled" >&2; exit 2; }
        mode=allow
      fi
      for item in $value; do
        expanded_groups=()
        while read -r call; do
          if ((deny)); then unset "allowed[$call]"; else allowed[$call]=1; fi
        done < <(expand "$item")
      done
      ;;
    RestrictAddressFamilies)
      [[ $value == ~* ]] && { echo "systemd_sandbox_policy: a deny-list of families is not handled" >&2; exit 2; }
      if [[ -z $value ]]; then families=(); else families+=($value); fi
      ;;
    PrivateNetwork)
      case $value in yes | true | 1 | on) network=private ;; *) network=host ;; esac
      ;;
  esac
done < <(cat "$@" | sed -n -E 's/^(SystemCallFilter|RestrictAddressFamilies|PrivateNetwork)=/&/p')

[[ $mode == allow ]] || { echo "systemd_sandbox_policy: no SystemCallFilter= allow list in $*" >&2; exit 2; }
printf '%s\n' "${!allowed[@]}" | sort >"$out.syscalls"
(IFS=,; echo "${families[*]}") >"$out.families"
echo "$network" >"$out.network"
echo "systemd_sandbox_policy: $(wc -l <"$out.syscalls") system calls, families ${families[*]:-(any)}, $network network"
