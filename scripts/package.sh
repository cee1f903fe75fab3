#!/usr/bin/env bash
# Builds the Debian package with the Debian tools (dpkg-buildpackage -us
# -uc -b, debhelper's cmake build system, debian/) and checks it with
# lintian. The .deb, .buildinfo and .changes land in out/.
#
# HAPTICD_BUILD_TREE=build: reuse that already built Release tree (CI's
# build stage, scripts/build.sh) when it was configured with the package's
# flags (debian/check-build-tree); otherwise, or without the variable, the
# package configures and builds its own tree (obj-<triplet>/, tests and
# benchmarks off). The reused tree keeps Debian's install directories
# afterwards (prefix /usr); its code is unchanged.
# HAPTICD_SKIP_DEPS=1 skips scripts/install-deps.sh (already run).
set -euo pipefail
cd "$(dirname "$0")/.."
[ "${HAPTICD_SKIP_DEPS:-0}" = 1 ] || bash scripts/install-deps.sh

tree=${HAPTICD_BUILD_TREE:-}
if [ -n "$tree" ]; then
  tree=$(realpath "$tree")
  if debian/check-build-tree "$tree"; then
    echo "package: reusing the built tree $tree"
  else
    echo "package: not reusing $tree (above); building the package's own tree"
    tree=""
  fi
fi

version=$(dpkg-parsechangelog -S Version)
arch=$(dpkg-architecture -qDEB_HOST_ARCH)
mkdir -p out
rm -f "out/hapticd_${version}_${arch}".{deb,buildinfo,changes}
# The jobs: both cores (the fallback's make; the reused tree is Ninja's).
HAPTICD_BUILD_TREE="$tree" DEB_BUILD_OPTIONS="parallel=$(nproc) ${DEB_BUILD_OPTIONS:-}" \
  dpkg-buildpackage -us -uc -b
# dpkg-buildpackage writes next to the source tree.
for f in "../hapticd_${version}_${arch}".{deb,buildinfo,changes}; do mv -f "$f" out/; done
echo "package: out/hapticd_${version}_${arch}.deb"

# The program's string literals against lintian's list of misspellings (the
# binaries' own spelling tag is overridden: debian/hapticd.lintian-overrides).
mapfile -t program_sources < <(find world analysis rt rpc drivers daemon client cli -name '*.[ch]pp' | sort)
python3 scripts/spelling_in_strings.py "${program_sources[@]}"
# lintian: the package's overrides (debian/hapticd.lintian-overrides) say
# why each tag left is; anything else at warning or above fails.
lintian --fail-on error,warning --display-info "out/hapticd_${version}_${arch}.changes"
