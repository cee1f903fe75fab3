#!/usr/bin/env bash
# clang-format must leave every C++ file unchanged; no function outside tests/
# and bench/ is over 80 lines (scripts/long_functions.py); clang-tidy (.clang-tidy's
# checks) must be clean on the project's own sources: every .cpp outside
# tests/ and bench/.
#
# clang-tidy runs its matchers over the whole AST, the system headers
# included (LLVM 14 has no way to skip them), so parsing Eigen, nlohmann-json
# and toml++ again for each file was most of its time. It now runs over the
# CMake unity units of a clang tree configured, not built, in build-tidy
# (-DCMAKE_UNITY_BUILD=ON, 16 sources a unit): each unit includes its
# sources, which the header filter below reports on exactly as on a main
# file. No check is lost:
# - misc-unused-using-decls only looks at the main file: it runs alone over
#   each source that has a using-declaration (and not over the units);
# - bugprone-suspicious-include fires on the unit's own #include of a .cpp:
#   findings located in the generated unit are CMake's, not the project's,
#   and dropped; a .cpp including a .cpp is still found (it is in the source);
# - a source in no unit (a target with UNITY_BUILD off) runs alone.
# Every source in a unit is also compiled by itself (clang -fsyntax-only,
# scripts/compile_alone.py): the builds compile units, and a unit can hide
# a source's missing include behind its neighbour's.
set -euo pipefail
cd "$(dirname "$0")/.."
root="$(pwd)"
mapfile -t files < <(git ls-files '*.cpp' '*.hpp')
clang-format --dry-run --Werror "${files[@]}"
echo "clang-format: ${#files[@]} files clean"
# No function outside tests/ and bench/ over 80 lines (data tables aside).
python3 scripts/long_functions.py
echo "function length: none over 80 lines"

# Not tests: neither tests/ nor a driver's own tests/ (drivers/skeleton/tests).
mapfile -t sources < <(git ls-files '*.cpp' | grep -v '^tests/\|/tests/' | grep -v '^bench/')
tidy="${TIDY_BUILD:-build-tidy}"
# Two configurations of one clang tree, neither built: the units, and each
# source's own command for the runs over single files.
configure() {
  CC=clang CXX=clang++ cmake -S . -B "$1" -G Ninja -DCMAKE_BUILD_TYPE=Release -DHAPTICD_BENCH=OFF "${@:2}" >/dev/null
}
configure "$tidy" -DCMAKE_UNITY_BUILD=ON -DCMAKE_UNITY_BUILD_BATCH_SIZE=16
configure "$tidy-files" -DCMAKE_UNITY_BUILD=OFF
jobs="$(nproc 2>/dev/null || echo 2)"
log="$tidy/clang-tidy.log"
: >"$log"

# The units that hold project sources (not tests'), and the sources they cover.
mapfile -t units < <(python3 - "$tidy/compile_commands.json" "$root" <<'PY'
import json, sys
db, root = json.load(open(sys.argv[1])), sys.argv[2] + "/"
for e in db:
    f = e["file"]
    if "/Unity/unity_" in f and "/tests/" not in f[len(root):] and "/bench/" not in f[len(root):]:
        print(f)
PY
)
covered="$(cat "${units[@]}" | sed -n 's|^#include "\(.*\)"$|\1|p' | sed "s|^$root/||" | sort -u)"
alone=()
for s in "${sources[@]}"; do grep -qxF "$s" <<<"$covered" || alone+=("$s"); done
with_using=()
for s in "${sources[@]}"; do
  grep -qE '^\s*using\s+[A-Za-z_][A-Za-z_0-9:]*::[A-Za-z_0-9~]+\s*;' "$s" && with_using+=("$s")
done

# The project's own files, headers as well as sources (a unit's sources are
# reported on through this filter as its headers are); not tests/, bench/ or
# the build trees.
filter="^$root/(world|analysis|rt|rpc|drivers|sim|daemon|client|cli)/.*\\.(cpp|hpp)\$"
# Collect first, judge after: clang-tidy's own exit status (an error makes
# xargs fail) must not hide the findings it printed.
run() { # db clang-tidy-args...
  xargs -P "$jobs" -n 1 clang-tidy -p "$1" --quiet --header-filter="$filter" "${@:2}" >>"$log" 2>/dev/null || true
}
# misc-unused-using-decls looks at the main file only, which in a unit is
# CMake's generated one: 5 % of a unit's time for nothing; it runs per file below.
printf '%s\n' "${units[@]}" | run "$tidy" --checks=-misc-unused-using-decls
[ "${#alone[@]}" -eq 0 ] || printf '%s\n' "${alone[@]}" | run "$tidy-files"
[ "${#with_using[@]}" -eq 0 ] || printf '%s\n' "${with_using[@]}" | run "$tidy-files" --checks='-*,misc-unused-using-decls'

# Parsed alone above already: the sources in no unit, those with a
# using-declaration, and the first source of each unit (nothing comes before
# it in the unit, so the unit's own run parsed it as it stands alone).
firsts="$(for u in "${units[@]}"; do sed -n 's|^#include "\(.*\)"$|\1|p' "$u" | head -n 1; done | sed "s|^$root/||")"
parsed_alone="$(printf '%s\n' "${alone[@]}" "${with_using[@]}" "$firsts")"
in_units=()
for s in "${sources[@]}"; do grep -qxF "$s" <<<"$parsed_alone" || in_units+=("$s"); done
alone_ok=0
python3 scripts/compile_alone.py "$tidy-files/compile_commands.json" "$jobs" "${in_units[@]}" || alone_ok=1

findings="$(grep -E 'warning:|error:' "$log" | grep -vE '/Unity/unity_[0-9]+_cxx\.cxx:.*\[bugprone-suspicious-include\]' || true)"
if [ -n "$findings" ]; then
  echo "$findings"
  echo "clang-tidy: findings above (whole output: $log)"
  exit 1
fi
[ "$alone_ok" -eq 0 ] || exit 1
echo "clang-tidy: ${#sources[@]} files clean (${#units[@]} unity units, ${#alone[@]} sources alone," \
  "${#with_using[@]} for misc-unused-using-decls)"
