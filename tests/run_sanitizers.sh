#!/usr/bin/env bash
# The sanitizer stages CI runs (scripts/test.sh), each timed:
#   asan  build-asan: clang, AddressSanitizer + UndefinedBehaviorSanitizer,
#         -O1, no recovery (the first finding fails), instrumented for
#         libFuzzer too; builds and runs the WHOLE test suite (ctest), the
#         kept fuzz crashers included.
#   fuzz  the same build: every fuzz target for FUZZ_SECONDS (tests/run_fuzz.sh).
#         Without clang: GCC's ASan+UBSan build, and the fuzz stage is the
#         replay of each target's crashers and seeds the asan stage's ctest ran.
#   tsan  build-tsan: ThreadSanitizer, -O1; builds only target tsan_tests
#         (tests/CMakeLists.txt) and runs the RT, daemon, control, recorder,
#         driver-framework, modbus, canopen (session and conformance) and
#         usb-hid umockdev tests (with the preload and their suppressions):
#         where threads meet.
#   asan-build  the asan stage's build alone (scripts/test.sh starts it at
#         nice 19 beside the Release ctest, package and lint stages).
# usage: tests/run_sanitizers.sh [asan] [fuzz] [tsan] [asan-build]   (default: asan fuzz tsan)
#
# With tsan after asan, the TSan build runs at nice 19 beside the ASan+UBSan
# tests and the fuzzing: those wait on sockets, processes and timers most of
# the time and leave a core idle; the niced compiler only takes what they
# leave. The TSan tests run once it is done, alone.
# env: FUZZ_SECONDS (10), JOBS (nproc), ASAN_BUILD (build-asan), TSAN_BUILD (build-tsan)
#
# Findings are fixed, not suppressed. A suppression needs a comment saying
# why the finding is a false positive: the only ones are usb-hid's, inside
# the uninstrumented third-party libraries umockdev brings
# (tests/drivers/usb_hid/tsan.supp).
set -uo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
asan_build="${ASAN_BUILD:-$here/build-asan}"
tsan_build="${TSAN_BUILD:-$here/build-tsan}"
jobs="${JOBS:-$(nproc 2>/dev/null || echo 2)}"
stages=("$@")
[[ ${#stages[@]} -eq 0 ]] && stages=(asan fuzz tsan)
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
# Unity builds (CMake, 16 sources a unit) for the project's libraries and
# programs: the heavy headers are parsed once a unit instead of once a file.
# As in the Release build (scripts/build.sh); scripts/lint.sh checks that each
# source compiles by itself. The test targets are unity builds of 8 files a
# unit with the precompiled framework headers (tests/CMakeLists.txt) in both
# sanitizer builds.
unity=(-DCMAKE_UNITY_BUILD=ON -DCMAKE_UNITY_BUILD_BATCH_SIZE=16)

# TSan's shadow memory breaks with the high mmap randomization of recent
# kernels ("FATAL: ThreadSanitizer: unexpected memory mapping"); running
# with ASLR off avoids it without touching sysctls. ctest and everything it
# starts inherit the personality.
no_aslr=()
setarch "$(uname -m)" -R true 2>/dev/null && no_aslr=(setarch "$(uname -m)" -R)

export ASAN_OPTIONS="${ASAN_OPTIONS:-halt_on_error=1:abort_on_error=1:detect_leaks=1:detect_stack_use_after_return=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}"
export TSAN_OPTIONS="${TSAN_OPTIONS:-halt_on_error=1:second_deadlock_stack=1}"

status=0
timings=()
stage() {  # name command...
  local name="$1" start=$SECONDS
  shift
  echo "=== sanitizers: $name"
  if "$@"; then
    timings+=("$name: $((SECONDS - start)) s, passed")
    return 0
  fi
  timings+=("$name: $((SECONDS - start)) s, FAILED")
  status=1
  return 1
}

# clang (scripts/install-deps.sh installs it) makes the ASan+UBSan build the
# libFuzzer build too. Without it GCC builds the suite with ASan+UBSan and
# the fuzz stage falls back to what ctest already did: every target replays
# its kept crashers and seeds (fuzz_<name>_replay, tests/fuzz/replay_main.cpp).
have_clang=0
command -v clang++ >/dev/null && command -v clang >/dev/null && have_clang=1
configure_asan() {
  local compiler=(CC=clang CXX=clang++) fuzz=ON
  [[ "$have_clang" == 1 ]] || { compiler=(CC=gcc CXX=g++); fuzz=OFF; }
  env "${compiler[@]}" cmake -S "$here" -B "$asan_build" -G Ninja "${launcher[@]}" \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1" "${unity[@]}" \
    -DHAPTICD_SANITIZE=address,undefined -DHAPTICD_FUZZ=$fuzz -DHAPTICD_BENCH=OFF >/dev/null
}
asan_build_all() { configure_asan && ninja -C "$asan_build" -j"$jobs"; }
# Left out under ASan, each run in the Release ctest stage instead:
# - what measures the instrumented daemon's wall-clock behaviour or memory:
#   the overload and socket-fuzz attacks (ASan's quarantine keeps freed
#   memory, so RSS grows 50-60 MiB by design; its 2-3x slowdown adds
#   overruns) and the resonant-excitation run on the real clock;
# - the usb-hid tests on the umockdev bus: with ASan's interceptors in the
#   executable the preload's /sys mapping is not seen (UmockdevUsbBoard
#   refuses to start); they run under TSan with the preload, and the ASan
#   build does not build them (tests/drivers/usb_hid/CMakeLists.txt).
# - the runs under the unit's system call filter (sandboxed_*,
#   sandbox_exec_applies_the_policy): LeakSanitizer's exit check stops the
#   process's threads with ptrace, which the filter refuses ("LeakSanitizer
#   has encountered a fatal error"); the policy is what they test, and
#   loosening it for a sanitizer would test another one.
# - the four heavy numeric runs: the passivity brute-force references and
#   the quick stability sweep (by itself and through `hapticctl report
#   stability`): 24 s together in Release, about twenty times that at -O1
#   with ASan (most of the CI machine's 466 s*proc of analysis and reports
#   there). They run whole in the Release ctest; their code runs under ASan
#   in the analysis and report tests' smaller cases.
# - five more numeric runs, 211 s*proc of the 873 the ASan+UBSan tests took
#   on a clean clone (2026-12-06): the time-domain references of the critical
#   stiffness (300,000 steps of a dynamic-size Eigen model, 16 times, in the
#   test's own code, which this build compiles at -O0), Table I's relay
#   runs, and the gate's limit searches over every axis of a stage (also
#   with each axis' own mass and damping: 139 s under ASan, 3.6 s in Release)
#   and along a normal. The same code runs here in the smaller cases beside them
#   (CriticalStiffness.TableIIComparison, RelayBias.TwoMassCrossover...,
#   TaskGate.AxisSpringsWithEachAxisItsOwnStiffness..., the other TaskGate
#   tests); the whole runs run in the Release ctest.
asan_heavy='CriticalStiffness\.(TimeDomainAgreesAroundKcr|FractionalDelayIsContinuousInDelay)$|RelayBias\.TableIPlantsFromZeroToEightMilliseconds$|TaskGate\.(AxisSpringsIsJudgedPerAxisExactlyAndRefusedNamingTheAxisAndItsLimit|AxisSpringsWithEachAxisItsOwnMassAndDampingIsJudgedWithThemOnItsAxis|APlaneWallsLimitAlongItsNormalIsTheOneAxisHulinLimitWithMn)$'
asan_excluded='^(Overload\.(ClientsThatNeverRead|HundredClientsComingAndGoing)|SocketFuzz\.|Freudenberg4\.ResonantExcitationPumpsOrDampsByPhase|UsbHid\.|UsbHidEndToEnd\.|sandboxed_|sandbox_exec_applies_the_policy$|ScenePassivity\.SpringsAgreeWithTheBruteForceReference$|WallPassivity\.AgreesWithTheBruteForceReference$|StabilitySweep\.QuickSweepAgreesAndIsDeterministic$|ReportStabilityCli\.QuickSweepHasNoDisagreementAndTheMapsMatchThePapers$|'"$asan_heavy"')'
# - the headless Chromium test of `hapticctl scope` (label browser): it runs
#   once, in the Release ctest; under ASan it would test the same page again
#   (not built there).
# As in the Release stage (scripts/test.sh): a real-clock test that fails
# beside another test and the background TSan build runs once more, alone,
# with that build paused; one that fails alone too fails the stage, and
# every such test is named.
# The tests LastTestsFailed.log names, as one anchored ctest -R regex.
failed_tests_regex() {  # build-dir
  local names
  names=$(cut -d: -f2- "$1/Testing/Temporary/LastTestsFailed.log" | sed 's/[][\\.*^$+?(){}|/]/\\&/g' | paste -sd'|')
  printf '^(%s)$' "$names"
}
asan_tests() {
  (cd "$asan_build" && ctest --output-on-failure --timeout 1200 -j"$jobs" -E "$asan_excluded" -LE browser) &&
    return 0
  local failed
  failed=$(cut -d: -f2 "$asan_build/Testing/Temporary/LastTestsFailed.log" 2>/dev/null | tr '\n' ' ')
  [[ -n "$failed" ]] || return 1
  echo "asan+ubsan: failed beside another test and the background build: $failed; again, alone:"
  [[ -z "$tsan_pid" ]] || kill -STOP -- "-$tsan_pid" 2>/dev/null || true
  local rc=0
  # By name: the numbers in LastTestsFailed.log count the tests the -E and
  # -LE filters left, and --rerun-failed alone would run others by them.
  (cd "$asan_build" && ctest --output-on-failure --timeout 1200 -j1 --no-tests=error -R "$(failed_tests_regex "$asan_build")") ||
    rc=1
  [[ -z "$tsan_pid" ]] || kill -CONT -- "-$tsan_pid" 2>/dev/null || true
  if [[ "$rc" -eq 0 ]]; then
    timings+=("asan+ubsan: passed alone after failing beside others: $failed")
  else
    timings+=("asan+ubsan: failed alone too: $(cut -d: -f2 "$asan_build/Testing/Temporary/LastTestsFailed.log" | tr '\n' ' ')")
  fi
  return "$rc"
}
fuzz() {
  if [[ "$have_clang" != 1 ]]; then
    echo "no clang: no libFuzzer; the asan stage replayed every fuzz target's crashers and seeds (ctest -L fuzz)"
    return 0
  fi
  FUZZ_BUILD="$asan_build" bash "$here/tests/run_fuzz.sh"
}

tsan_build_targets() {
  cmake -S "$here" -B "$tsan_build" -G Ninja "${launcher[@]}" \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1" "${unity[@]}" \
    -DHAPTICD_TSAN=ON -DHAPTICD_BENCH=OFF >/dev/null && ninja -C "$tsan_build" -j"$jobs" tsan_tests
}
# Each binary directly, not through ctest: the TSan build lists its tests at
# test time (CMakeLists.txt), and the umockdev ones must not be started
# without their preload.
tsan_run() {  # name command...: one binary, its output in $tsan_build/tsan-<name>.log
  local name="$1"
  shift
  "$@" >"$tsan_build/tsan-$name.log" 2>&1
}
# Two lanes at once (the stage runs alone at the end of CI; one binary at a
# time left a core idle for 109 s): modbus (45 s of its simulated
# amplifier's timeouts) with the light ones, and the rest. Each binary's
# output is printed whole after its lane. One that fails beside the other
# lane runs again alone; one that fails alone too fails the stage.
# - The RT primitives (the 10-million-item ring transfer is ~20x slower
#   under TSan; it still runs); the engine's loop thread against a
#   publishing, estopping, clearing control thread and a draining consumer,
#   and every other daemon test; the control server's threads; the
#   recorder's writer; the driver framework's conformance suite; modbus
#   against its simulated amplifier's server thread; the UDP telemetry
#   sender's thread against telemetry.set and the recorder's drain.
# - The canopen driver's hooks: their RT loop thread against clear_fault(),
#   commissioning SDO through the ring and the published status on other
#   threads, the simulated drive's bus thread; a stop during a fault clear
#   the loop runs; the homing's periods against the bus thread and a stop;
#   the conformance suite over the socket; the simulated bus's relay thread
#   and two drives on it under the several-drive device (issue 22).
# - The usb-hid driver through libusb under umockdev: the RT-like thread
#   against clear_fault's hand-over, libusb's event and hotplug threads, the
#   umockdev handler thread. The preload must come before libtsan (the test
#   links it, but -fsanitize=thread puts libtsan first); the suppressions
#   cover races TSan reports inside the uninstrumented umockdev, glib and
#   libudev (tests/drivers/usb_hid/tsan.supp says why each is one).
tsan_binary() {  # name: runs that binary as CI does
  local t="$tsan_build/tests"
  case "$1" in
    canopen_tests)
      tsan_run "$1" "${no_aslr[@]}" "$t/drivers/canopen/canopen_tests" \
        --gtest_filter='CanopenDeviceTest.*:DriveStop.*:HomingDevice.*:Canopen/*:CanBusTest.*:TwoDrivesOnTheBus.*' ;;
    usb_hid_umockdev_tests)
      LD_PRELOAD=libumockdev-preload.so.0 \
        TSAN_OPTIONS="$TSAN_OPTIONS:suppressions=$here/tests/drivers/usb_hid/tsan.supp" \
        tsan_run "$1" "${no_aslr[@]}" "$t/drivers/usb_hid/usb_hid_umockdev_tests" ;;
    modbus_tests) tsan_run "$1" "${no_aslr[@]}" "$t/drivers/modbus/modbus_tests" ;;
    *) tsan_run "$1" "${no_aslr[@]}" "$t/$1" ;;
  esac
}
tsan_lane() {  # names...: one after another; prints the failed ones' names
  local name
  for name in "$@"; do tsan_binary "$name" || echo "$name"; done
}
tsan_tests() {
  local lane_a lane_b failed rc=0 name
  lane_a="$(mktemp)" lane_b="$(mktemp)"
  tsan_lane modbus_tests drivers_tests telemetry_tests >"$lane_a" &
  tsan_lane rt_tests daemon_tests control_tests recorder_tests canopen_tests usb_hid_umockdev_tests >"$lane_b"
  wait
  failed="$(cat "$lane_a" "$lane_b")"
  rm -f "$lane_a" "$lane_b"
  for name in modbus_tests drivers_tests telemetry_tests rt_tests daemon_tests control_tests recorder_tests \
    canopen_tests usb_hid_umockdev_tests; do
    echo "--- tsan $name"
    cat "$tsan_build/tsan-$name.log"
  done
  for name in $failed; do
    echo "tsan: $name failed beside the other lane; again, alone:"
    if tsan_binary "$name"; then
      timings+=("tsan: $name passed alone after failing beside the other lane")
    else
      cat "$tsan_build/tsan-$name.log"
      timings+=("tsan: $name failed alone too")
      rc=1
    fi
  done
  return "$rc"
}

# The TSan build in the background (its output in $tsan_build/background-build.log), and the
# wait for it: a stage of its own, so its time beside the others shows.
tsan_pid=""
tsan_build_background() {
  mkdir -p "$tsan_build"
  # A process group of its own (job control on while it starts), so the
  # ASan stage can pause it while a failed test runs again alone.
  set -m
  (renice -n 19 -p "$BASHPID" >/dev/null && tsan_build_targets) >"$tsan_build/background-build.log" 2>&1 &
  tsan_pid=$!
  set +m
  echo "=== sanitizers: tsan build started at nice 19 (log: $tsan_build/background-build.log)"
}
tsan_build_wait() {
  wait "$tsan_pid" && return 0
  tail -n 60 "$tsan_build/background-build.log"
  return 1
}

for s in "${stages[@]}"; do
  case "$s" in
    asan-build) stage "asan+ubsan build" asan_build_all ;;
    asan)
      stage "asan+ubsan build" asan_build_all || continue
      [[ " ${stages[*]} " == *" tsan "* ]] && tsan_build_background
      stage "asan+ubsan tests" asan_tests ;;
    fuzz) [[ -d "$asan_build" ]] || stage "asan+ubsan build" asan_build_all; stage "fuzz" fuzz ;;
    tsan)
      if [[ -n "$tsan_pid" ]]; then
        stage "tsan build (rest, after the background)" tsan_build_wait && stage "tsan tests" tsan_tests
      else
        stage "tsan build" tsan_build_targets && stage "tsan tests" tsan_tests
      fi ;;
    *) echo "unknown stage $s (asan, fuzz, tsan, asan-build)" >&2; exit 2 ;;
  esac
done
echo "=== sanitizer stage times"
printf '  %s\n' "${timings[@]}"
exit "$status"
