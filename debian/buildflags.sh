# Sourced by scripts/build.sh (and read by debian/rules' reuse check): the
# compiler and linker flags Debian builds the package with, from
# dpkg-buildflags, so the Release tree the tests run is the code the package
# ships and scripts/package.sh can reuse it (HAPTICD_BUILD_TREE).
# The same maintainer options as debian/rules:
#   hardening=+all    adds bindnow to the defaults (format, fortify,
#                     stackprotectorstrong, relro, pie): every symbol is bound
#                     at load, so the RT thread never enters the lazy resolver
#                     after mlockall();
#   strip -g          no debug information: no -dbgsym package, and the
#                     CI's Release build stays as fast as before.
# CMake reads CFLAGS/CXXFLAGS/LDFLAGS only when a tree is first configured,
# and never CPPFLAGS: they go into CXXFLAGS, as debhelper's cmake build
# system does.
if command -v dpkg-buildflags >/dev/null 2>&1; then
  export DEB_BUILD_MAINT_OPTIONS="hardening=+all"
  export DEB_CFLAGS_MAINT_STRIP="-g" DEB_CXXFLAGS_MAINT_STRIP="-g"
  eval "$(dpkg-buildflags --export=sh)"
  export CFLAGS="$CFLAGS $CPPFLAGS" CXXFLAGS="$CXXFLAGS $CPPFLAGS"
  unset DEB_BUILD_MAINT_OPTIONS DEB_CFLAGS_MAINT_STRIP DEB_CXXFLAGS_MAINT_STRIP
fi
