#!/usr/bin/env bash
# The Debian package, end to end (issue 23): build it (scripts/package.sh,
# reusing the Release tree ./build when it carries the package's flags) and
# lintian it; then, on a throwaway machine, install it, check what it
# installed (user and group, units with systemd-analyze verify, udev rules,
# the conffile, hapticd --setup-check), purge it, and compare the file list
# of the system before and after: nothing may stay but logs and recordings.
#
# Installing needs root and changes the machine: it runs when CI=true (the
# CI machine is thrown away after the run) or HAPTICD_PACKAGE_INSTALL_TEST=1;
# otherwise only the build and lintian run, and the script says so. Why not
# a debootstrap chroot: it downloads and unpacks a whole Debian (minutes and
# hundreds of MB per run) to check what purge leaves, which the file list
# does here.
#
# usage: tests/package_test.sh [BUILD_TREE]   (default: build)
set -euo pipefail
cd "$(dirname "$0")/.."
tree=${1:-build}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
say() { printf 'package_test: %s\n' "$*"; }
step_start=$SECONDS
step() { say "$1 ($((SECONDS - step_start)) s so far)"; }

step "building the package"
HAPTICD_SKIP_DEPS=1 HAPTICD_BUILD_TREE=$tree bash scripts/package.sh
deb=$(ls out/hapticd_*.deb)

if [ "${CI:-}" != true ] && [ "${HAPTICD_PACKAGE_INSTALL_TEST:-0}" != 1 ]; then
  say "built and lintian-clean; install/purge not run (set HAPTICD_PACKAGE_INSTALL_TEST=1 as root on a throwaway machine)"
  exit 0
fi
[ "$(id -u)" -eq 0 ] || { say "the install test needs root"; exit 1; }
export DEBIAN_FRONTEND=noninteractive
# A package left by an earlier, interrupted run of this test.
if dpkg -s hapticd >/dev/null 2>&1; then
  say "hapticd is installed already: purging it first"
  apt-get purge -y -qq hapticd >/dev/null
fi

# What the package may touch, without what is expected to change: dpkg's and
# apt's own state and logs.
snapshot() {
  find /etc /lib /usr /var /opt -xdev \
    \( -path /var/lib/dpkg -o -path /var/lib/apt -o -path /var/cache -o -path /var/log -o -path /var/tmp \
       -o -path /usr/share/man -o -path /var/lib/systemd/deb-systemd-helper-masked \) -prune -o -print 2>/dev/null |
    sort
}
snapshot >"$work/before"

step "installing $deb"
apt-get install -y -qq "./$deb" >/dev/null
status=0
fail() { say "FAILED: $*"; status=1; }

getent group hapticd >/dev/null || fail "no hapticd group after install"
getent passwd hapticd >/dev/null || fail "no hapticd user after install"
for f in /usr/bin/hapticd /usr/bin/hapticctl /usr/bin/hapticd-devsim /lib/systemd/system/hapticd.service \
  /lib/systemd/system/hapticd@.service /usr/lib/sysusers.d/hapticd.conf /lib/udev/rules.d/70-hapticd-usb-hid.rules \
  /lib/udev/rules.d/70-hapticd-gpio-pwm.rules /lib/udev/rules.d/70-hapticd-realtime.rules \
  /usr/share/doc/hapticd/examples/usb-hid.toml /usr/share/doc/hapticd/examples/networkd/80-hapticd-can.network \
  "/usr/lib/$(dpkg-architecture -qDEB_HOST_MULTIARCH)/hapticd/libhapticd-gpio-board.so"; do
  [ -e "$f" ] || fail "$f not installed"
done
grep -qx /etc/hapticd/hapticd.toml /var/lib/dpkg/info/hapticd.conffiles || fail "/etc/hapticd/hapticd.toml is no conffile"
[ ! -e /etc/systemd/system/multi-user.target.wants/hapticd.service ] || fail "the service was enabled on install"
# The devsim finds its board library where it is installed.
hapticd-devsim gpio-pwm --help >/dev/null || fail "hapticd-devsim gpio-pwm --help"

step "hapticd --setup-check on the installed config"
set +e
hapticd --setup-check --json -c /etc/hapticd/hapticd.toml >"$work/setup.json"
setup_rc=$?
set -e
cat "$work/setup.json"
verdict=$(jq -r .verdict "$work/setup.json")
case "$verdict:$setup_rc" in
  ok:0 | warning:0) ;;
  *) fail "setup-check said $verdict with exit $setup_rc (the loopback config needs no device)" ;;
esac
[ "$(jq -r .service_user "$work/setup.json")" = hapticd ] || fail "setup-check did not check for the hapticd user"

step "systemd-analyze verify of the installed units"
bash tests/systemd_verify.sh /lib/systemd/system/hapticd.service /usr/bin/hapticd || fail "hapticd.service"
bash tests/systemd_verify.sh /lib/systemd/system/hapticd@.service /usr/bin/hapticd || fail "hapticd@.service"

# A recording, as the service would leave one, must survive the purge.
install -d -o hapticd -g hapticd /var/lib/hapticd/recordings
echo "# a recording" >/var/lib/hapticd/recordings/kept.csv

step "purging"
apt-get purge -y -qq hapticd >/dev/null
snapshot >"$work/after"
# Left by design: the recordings, and the user's entries in the account
# files (Debian never removes a system user; systemd-sysusers keeps a backup
# of each file it changed).
comm -13 "$work/before" "$work/after" |
  grep -vxE '/var/lib/hapticd(/recordings(/kept\.csv)?)?|/etc/(passwd|group|shadow|gshadow)-' >"$work/left" || true
comm -23 "$work/before" "$work/after" >"$work/gone"
say "file list: $(wc -l <"$work/before") paths before, $(wc -l <"$work/after") after the purge; new and kept by design: $(comm -13 "$work/before" "$work/after" | grep -cvxF -f "$work/left" || true)"
if [ -s "$work/left" ]; then
  fail "the purge left files:"
  cat "$work/left"
fi
if [ -s "$work/gone" ]; then
  fail "install and purge removed files that were there before:"
  cat "$work/gone"
fi
rm -rf /var/lib/hapticd
step "done"
exit "$status"
