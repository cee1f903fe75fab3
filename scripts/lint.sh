#!/usr/bin/env bash
# clang-format must leave every C++ file unchanged; clang-tidy must be clean
# on the project's own sources (uses build/compile_commands.json).
# The build is GCC's: flags only GCC knows (-Wno-restrict) are not clang-tidy's business.
set -euo pipefail
cd "$(dirname "$0")/.."
mapfile -t files < <(git ls-files '*.cpp' '*.hpp')
clang-format --dry-run --Werror "${files[@]}"
echo "clang-format: ${#files[@]} files clean"
mapfile -t sources < <(git ls-files '*.cpp' | grep -v '^tests/' | grep -v '^bench/')
if [ -f build/compile_commands.json ]; then
  # Collect first, judge after: clang-tidy's own exit status (an error makes
  # xargs fail) must not hide the findings it printed.
  printf '%s\n' "${sources[@]}" | xargs -P "$(nproc)" -n 4 clang-tidy -p build --quiet \
    --extra-arg=-Wno-unknown-warning-option >/tmp/hapticd-clang-tidy.log 2>/dev/null || true
  if grep -E 'warning:|error:' /tmp/hapticd-clang-tidy.log; then
    echo "clang-tidy: findings above"
    exit 1
  fi
  echo "clang-tidy: ${#sources[@]} files clean"
fi
