#!/usr/bin/env bash
# Build the RT tests, the daemon tests (engine thread, plan hand-over,
# telemetry) and the usb-hid driver tests with ThreadSanitizer in build-tsan
# and run them.
# Why setarch -R: TSan's shadow memory layout breaks with the high
# mmap randomization (vm.mmap_rnd_bits > 28) of recent kernels ("FATAL:
# ThreadSanitizer: unexpected memory mapping"); running the binary with ASLR
# disabled avoids it without touching sysctls.
# Arguments go to rt_tests; DAEMON_TSAN_FILTER selects daemon tests (all by default).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${BUILD_DIR:-$here/build-tsan}"

cmake -S "$here" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DHAPTICD_TSAN=ON -DHAPTICD_BENCH=OFF >/dev/null
ninja -C "$build" rt_tests daemon_tests usb_hid_umockdev_tests canopen_tests

run=()
if setarch "$(uname -m)" -R true 2>/dev/null; then
  run=(setarch "$(uname -m)" -R)
fi
export TSAN_OPTIONS="${TSAN_OPTIONS:-halt_on_error=1 second_deadlock_stack=1}"
# The 10-million-item ring transfer is ~20x slower under TSan; it still runs.
"${run[@]}" "$build/tests/rt_tests" "$@"
# The engine's loop thread against a publishing, estopping, clearing control
# thread and a draining consumer (EngineThreads.*), plus every other daemon test.
"${run[@]}" "$build/tests/daemon_tests" --gtest_filter="${DAEMON_TSAN_FILTER:-*}"
# The usb-hid driver through libusb under umockdev: the RT-like thread
# against clear_fault's hand-over, libusb's event and hotplug threads, the
# umockdev handler thread. The preload must come before libtsan (the test
# links it, but -fsanitize=thread puts libtsan first), and the suppressions
# cover races TSan reports inside the uninstrumented umockdev/glib/libudev.
LD_PRELOAD=libumockdev-preload.so.0 \
  TSAN_OPTIONS="$TSAN_OPTIONS suppressions=$here/tests/drivers/usb_hid/tsan.supp" \
  "${run[@]}" "$build/tests/drivers/usb_hid/usb_hid_umockdev_tests"
# The canopen driver's session: its RT loop thread against clear_fault(),
# commissioning SDO through the ring and status() on other threads, the
# simulated drive's bus thread; and the conformance suite over the socket.
"${run[@]}" "$build/tests/drivers/canopen/canopen_tests" --gtest_filter='SessionTest.*:Canopen/*'
