#!/usr/bin/env bash
# Installs everything hapticd needs to build, test and benchmark on Debian 12.
# Idempotent; run as root or with sudo available.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git
  libeigen3-dev            # matrices, matrix exponential (unsupported/MatrixFunctions)
  libcli11-dev             # hapticctl / hapticd command lines
  nlohmann-json3-dev       # control-plane protocol, --json output
  libtomlplusplus-dev       # config files
  libsystemd-dev systemd   # sd_notify; systemd-analyze verify in the tests
  libgtest-dev libgmock-dev libbenchmark-dev
  # The drivers' libraries (every driver is always built), and umockdev:
  # the USB and GPIO drivers are tested through libusb and libgpiod against
  # emulated devices (DRIVERS.md).
  libusb-1.0-0-dev libmodbus-dev libgpiod-dev umockdev libumockdev-dev
  rt-tests                 # cyclictest, the latency reference in bench/
  libboost-dev             # Boost.Odeint: RK4 and dopri5 references in `hapticctl report accuracy`
  gnuplot-nox              # draws the report figures (PNG, pngcairo terminal)
  clang-format clang-tidy
  # issue 14: clang and its sanitizer/libFuzzer runtimes for the ASan+UBSan
  # and fuzz build (tests/run_sanitizers.sh); jq reads `hapticctl stats
  # --json` in bench/latency.sh.
  clang libclang-rt-14-dev jq
  # issue 20: `hapticctl scope` serves its page with cpp-httplib (server-sent
  # events) and plots with Debian's dygraphs (served from
  # /usr/share/javascript/dygraphs, no CDN); headless chromium opens the page
  # in tests/browser/scope_browser_test.cpp (ctest label `browser`) and takes the
  # README's screenshot.
  libcpp-httplib-dev libjs-dygraphs chromium
  # issue 17: the end-to-end tests run the daemon under the unit's system
  # call filter and address families (tests/support/sandbox_exec.cpp), as
  # systemd would, where systemd is not PID 1.
  libseccomp-dev
  # issue 23: the Debian package (scripts/package.sh: dpkg-buildpackage with
  # debhelper 13's cmake build system and dh_installsysusers) and its check
  # (lintian; tests/package_test.sh installs, verifies and purges it);
  # help2man writes the man pages from each program's --help.
  debhelper lintian help2man
)

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi

missing=()
for p in "${packages[@]}"; do
  dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
if [ "${#missing[@]}" -gt 0 ]; then
  export DEBIAN_FRONTEND=noninteractive
  "${sudo_cmd[@]}" apt-get update -qq
  "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
