# tests/systemd.cmake: CTest registration of the systemd unit check.
# Included from the top-level CMakeLists.txt after enable_testing() and after
# the daemon's targets (it uses the built hapticd if the target exists).
if(NOT DEFINED HAPTICD_GENERATED_UNIT)
  include(${CMAKE_CURRENT_LIST_DIR}/../systemd/install.cmake)
endif()
find_program(HAPTICD_SYSTEMD_ANALYZE systemd-analyze)
if(NOT HAPTICD_SYSTEMD_ANALYZE)
  message(STATUS "systemd-analyze not found: systemd_unit_verify is not registered")
  return()
endif()
if(TARGET hapticd)
  set(_hapticd_verify_binary $<TARGET_FILE:hapticd>)
else()
  set(_hapticd_verify_binary "")  # the script makes a dummy executable
endif()
add_test(NAME systemd_unit_verify
         COMMAND ${CMAKE_CURRENT_LIST_DIR}/systemd_verify.sh ${HAPTICD_GENERATED_UNIT} "${_hapticd_verify_binary}")
# The same check on a copy with a misspelt key must fail: proves the check
# does not pass on warnings.
add_test(NAME systemd_unit_verify_detects_typo
         COMMAND ${CMAKE_CURRENT_LIST_DIR}/systemd_verify.sh ${HAPTICD_GENERATED_UNIT} "${_hapticd_verify_binary}"
                 --inject-typo)
# The template for several devices on one machine, and its typo check.
add_test(NAME systemd_template_unit_verify
         COMMAND ${CMAKE_CURRENT_LIST_DIR}/systemd_verify.sh ${HAPTICD_GENERATED_TEMPLATE_UNIT} "${_hapticd_verify_binary}")
add_test(NAME systemd_template_unit_verify_detects_typo
         COMMAND ${CMAKE_CURRENT_LIST_DIR}/systemd_verify.sh ${HAPTICD_GENERATED_TEMPLATE_UNIT} "${_hapticd_verify_binary}"
                 --inject-typo)
# Issue 17: `systemd-analyze security --offline=yes` exposure at most 2.0,
# for each unit alone and with each per-driver drop-in (systemd/drivers/),
# verify clean for each; and the same check on a unit stripped of its
# sandboxing must see it over 2.0 (the check can fail).
set(HAPTICD_MAX_EXPOSURE 2.0)
add_test(NAME systemd_unit_security
         COMMAND ${CMAKE_CURRENT_LIST_DIR}/systemd_security.sh ${HAPTICD_GENERATED_UNIT} ${HAPTICD_DROPIN_SOURCE_DIR}
                 ${HAPTICD_MAX_EXPOSURE})
add_test(NAME systemd_template_unit_security
         COMMAND ${CMAKE_CURRENT_LIST_DIR}/systemd_security.sh ${HAPTICD_GENERATED_TEMPLATE_UNIT}
                 ${HAPTICD_DROPIN_SOURCE_DIR} ${HAPTICD_MAX_EXPOSURE})
add_test(NAME systemd_unit_security_detects_loosening
         COMMAND ${CMAKE_CURRENT_LIST_DIR}/systemd_security.sh ${HAPTICD_GENERATED_UNIT} ${HAPTICD_DROPIN_SOURCE_DIR}
                 ${HAPTICD_MAX_EXPOSURE} --loosened)
set_tests_properties(systemd_unit_verify systemd_unit_verify_detects_typo systemd_template_unit_verify
                     systemd_template_unit_verify_detects_typo systemd_unit_security systemd_template_unit_security
                     systemd_unit_security_detects_loosening PROPERTIES LABELS systemd)
set_tests_properties(systemd_unit_verify_detects_typo systemd_template_unit_verify_detects_typo
                     PROPERTIES WILL_FAIL TRUE)

# Issue 17: each driver's end-to-end tests with the daemon under the unit's
# system call filter, address families and private network plus that
# driver's drop-in, applied by tests/support/sandbox_exec (systemd is not
# PID 1 where tests run; DeviceAllow=, ProtectProc= and the mount options
# are not applied: docs/testing.md). Root only: a private network namespace
# needs CAP_SYS_ADMIN, and the real-time calls the filter must let through
# only happen with the privileges the unit grants.
if(TARGET sandbox_exec)
  set(_sandbox_run ${CMAKE_CURRENT_LIST_DIR}/systemd_sandbox_run.sh $<TARGET_FILE:sandbox_exec>
      ${HAPTICD_GENERATED_UNIT})
  add_test(NAME sandboxed_loopback_e2e
           COMMAND ${_sandbox_run} none -- $<TARGET_FILE:e2e_tests>
                   --gtest_filter=Safety.*InTheSamePeriod:Safety.EstopLatchesAndZeroes:Safety.Stall*:Safety.ReadError*:Recording*:Physics*)
  add_test(NAME sandbox_exec_applies_the_policy
           COMMAND ${CMAKE_CURRENT_LIST_DIR}/systemd_sandbox_self_test.sh $<TARGET_FILE:sandbox_exec>
                   $<TARGET_FILE:hapticd> ${HAPTICD_GENERATED_UNIT})
  set(_sandboxed sandboxed_loopback_e2e sandbox_exec_applies_the_policy)
  if(TARGET canopen_e2e_tests)
    add_test(NAME sandboxed_canopen_e2e
             COMMAND ${_sandbox_run} ${HAPTICD_DROPIN_SOURCE_DIR}/canopen.conf -- $<TARGET_FILE:canopen_e2e_tests>
                     --gtest_filter=Canopen.Faults*:Canopen.A2To31*:Canopen.HapticctlDeviceSdo*)
    list(APPEND _sandboxed sandboxed_canopen_e2e)
  endif()
  if(TARGET modbus_e2e_tests)
    add_test(NAME sandboxed_modbus_tcp_e2e
             COMMAND ${_sandbox_run} ${HAPTICD_DROPIN_SOURCE_DIR}/modbus-tcp.conf -- $<TARGET_FILE:modbus_e2e_tests>
                     --gtest_filter=*/Tcp)
    add_test(NAME sandboxed_modbus_rtu_e2e
             COMMAND ${_sandbox_run} ${HAPTICD_DROPIN_SOURCE_DIR}/modbus-rtu.conf -- $<TARGET_FILE:modbus_e2e_tests>
                     --gtest_filter=*A2To31*/Rtu:*AnException*/Rtu)
    list(APPEND _sandboxed sandboxed_modbus_tcp_e2e sandboxed_modbus_rtu_e2e)
  endif()
  set_tests_properties(${_sandboxed} PROPERTIES LABELS "systemd;e2e" RUN_SERIAL TRUE
                       SKIP_RETURN_CODE 77)
endif()

# The sysusers.d entry parses and creates the hapticd user and group
# (dry run in an empty root; warnings fail the test).
find_program(HAPTICD_SYSTEMD_SYSUSERS systemd-sysusers)
if(HAPTICD_SYSTEMD_SYSUSERS)
  add_test(NAME systemd_sysusers_dry_run
           COMMAND sh -c "r=$(mktemp -d) && mkdir -p \"$r/etc\" && \"$1\" --dry-run --root=\"$r\" \"$2\" 2>&1; s=$?; rm -rf \"$r\"; exit $s"
                   sh ${HAPTICD_SYSTEMD_SYSUSERS} ${CMAKE_CURRENT_LIST_DIR}/../systemd/hapticd.sysusers)
  set_tests_properties(systemd_sysusers_dry_run PROPERTIES LABELS systemd
    PASS_REGULAR_EXPRESSION "Creating user 'hapticd' \\(hapticd daemon\\)"
    FAIL_REGULAR_EXPRESSION "[Ii]gnoring|[Ff]ailed|[Ii]nvalid")
endif()
